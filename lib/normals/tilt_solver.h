// Levenberg-Marquardt for the two tilt unknowns (a, b) of one texel's
// normal (internal to lib/normals). A texel's fit has 2 unknowns and a few
// hundred residuals, and there are tens of thousands of texels per pass: a
// general solver's per-problem set-up (problem, program, evaluator,
// Jacobian matrix) and its projected line search on the bounds (one more
// cost evaluation per step) cost as much as the fit itself. Here the
// 2 x 2 normal equations are accumulated straight from the residuals'
// Jets, one cost evaluation per trial step.
//
// The iteration follows Ceres' Levenberg-Marquardt (Madsen, Nielsen and
// Tingleff, "Methods for non-linear least squares problems", 2004, sec.
// 3.2; Ceres' defaults): damping lambda D with D = diag(J^T J) clamped to
// [1e-6, 1e32], lambda from 1e-4; a step is taken when the cost drops by
// more than 1e-3 of the drop the linear model predicts, then lambda *=
// max(1/3, 1 - (2 rho - 1)^3); otherwise lambda *= nu, nu *= 2. Bounds by
// projecting each step onto the box. Ends after `max_iterations` trial
// steps, or when a step changes the cost by less than function_tolerance
// of it, or the parameters by less than parameter_tolerance (relative).
#pragma once
#include <ceres/jet.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <vector>

namespace svbrdf::normals {

struct TiltSolverOptions {
  int max_iterations = 10;
  double function_tolerance = 1e-6;
  double parameter_tolerance = 1e-6;
  double bound = 1.0;  // |a|, |b| <= bound
};

// Minimises 1/2 |r(ab)|^2 over the box, r given by `cost(const T* ab, T* r)`
// with `num_residuals` residuals, for T = double and T = ceres::Jet<double, 2>.
// `ab` is the start (clamped into the box) and the result; it stays at the
// start when the cost there is not finite. Returns the trial steps taken.
template <class Cost>
int SolveTilt(const Cost& cost, int num_residuals, const TiltSolverOptions& o, double* ab) {
  using Jet2 = ceres::Jet<double, 2>;
  thread_local std::vector<Jet2> rj;
  thread_local std::vector<double> rd;
  rj.resize(num_residuals);
  rd.resize(num_residuals);
  Eigen::Matrix2d H;
  Eigen::Vector2d g;
  auto linearise = [&](const Eigen::Vector2d& x) {
    const Jet2 xj[2] = {Jet2(x[0], 0), Jet2(x[1], 1)};
    cost(xj, rj.data());
    H.setZero();
    g.setZero();
    double c = 0;
    for (const Jet2& r : rj) {
      c += r.a * r.a;
      g += r.a * r.v;
      H.noalias() += r.v * r.v.transpose();
    }
    return 0.5 * c;
  };
  auto value = [&](const Eigen::Vector2d& x) {
    cost(x.data(), rd.data());
    double c = 0;
    for (double r : rd) c += r * r;
    return 0.5 * c;
  };
  auto project = [&](const Eigen::Vector2d& x) -> Eigen::Vector2d { return x.cwiseMax(-o.bound).cwiseMin(o.bound); };

  Eigen::Vector2d x = project(Eigen::Vector2d(ab[0], ab[1]));
  double c = linearise(x);
  if (!std::isfinite(c) || !g.allFinite() || !H.allFinite()) return 0;
  double lambda = 1e-4, nu = 2;
  int it = 0;
  while (it < o.max_iterations) {
    ++it;
    // Projected gradient zero: a minimum (or a corner of the box).
    if ((x - project(x - g)).cwiseAbs().maxCoeff() <= 1e-10) break;
    Eigen::Matrix2d A = H;
    for (int k = 0; k < 2; ++k) A(k, k) += lambda * std::clamp(H(k, k), 1e-6, 1e32);
    const Eigen::Vector2d xn = project(x - A.ldlt().solve(g));
    const Eigen::Vector2d step = xn - x;
    if (!step.allFinite()) break;
    if (step.norm() <= o.parameter_tolerance * (x.norm() + o.parameter_tolerance)) break;
    const double cn = value(xn);
    const double predicted = -(g.dot(step) + 0.5 * step.dot(H * step));
    if (std::isfinite(cn) && std::abs(c - cn) <= o.function_tolerance * c) {
      if (cn < c) x = xn;
      break;
    }
    const double rho = std::isfinite(cn) && predicted > 0 ? (c - cn) / predicted : -1.0;
    if (rho > 1e-3) {
      const Eigen::Vector2d previous = x;
      x = xn;
      c = linearise(x);
      if (!std::isfinite(c) || !g.allFinite() || !H.allFinite()) {
        x = previous;
        break;
      }
      lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
      nu = 2;
    } else {
      lambda *= nu;
      nu *= 2;
    }
  }
  if (x.allFinite()) ab[0] = x[0], ab[1] = x[1];
  return it;
}

}  // namespace svbrdf::normals
