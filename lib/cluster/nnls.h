// Non-negative least squares for the small systems of per-texel mixing
// weights (K <= 8 unknowns): Lawson & Hanson's active-set method (1974,
// "Solving Least Squares Problems", ch. 23) on the normal equations.
// Eigen 3.4 as shipped by Debian has no NNLS module, hence this 60-line one.
#pragma once
#include <Eigen/Dense>

namespace svbrdf {

// Minimises |A w - b|^2 subject to w >= 0, given AtA = A^T A and Atb = A^T b.
Eigen::VectorXd NnlsNormal(const Eigen::MatrixXd& AtA, const Eigen::VectorXd& Atb, int max_iterations = 100);

}  // namespace svbrdf
