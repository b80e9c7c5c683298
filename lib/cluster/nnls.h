// Non-negative least squares for the small systems of per-texel mixing
// weights (up to kNnlsMaxUnknowns unknowns: the basis materials, at most
// 16): Lawson & Hanson's active-set method (1974, "Solving Least Squares
// Problems", ch. 23) on the normal equations.
// Eigen 3.4 as shipped by Debian has no NNLS module, hence this 60-line one.
// It runs once per texel and weight model, so it keeps its work on the
// stack (matrices of dynamic size below a fixed maximum): heap allocations
// per call were a visible share of reconstruct's profile.
#pragma once
#include <Eigen/Dense>

namespace svbrdf {

constexpr int kNnlsMaxUnknowns = 16;
using NnlsMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kNnlsMaxUnknowns, kNnlsMaxUnknowns>;
using NnlsVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kNnlsMaxUnknowns, 1>;

// Minimises |A w - b|^2 subject to w >= 0, given AtA = A^T A and Atb = A^T b
// (at most kNnlsMaxUnknowns unknowns: more is an Error).
NnlsVector NnlsNormal(const Eigen::Ref<const Eigen::MatrixXd>& AtA, const Eigen::Ref<const Eigen::VectorXd>& Atb,
                      int max_iterations = 100);

}  // namespace svbrdf
