#include "cluster/nnls.h"

namespace svbrdf {

Eigen::VectorXd NnlsNormal(const Eigen::MatrixXd& AtA, const Eigen::VectorXd& Atb, int max_iterations) {
  const int n = static_cast<int>(Atb.size());
  Eigen::VectorXd w = Eigen::VectorXd::Zero(n);
  std::vector<bool> passive(n, false);
  const double tol = 1e-12 * (1.0 + AtA.diagonal().cwiseAbs().maxCoeff());
  // Solves the unconstrained problem restricted to the passive set.
  auto solve_passive = [&](Eigen::VectorXd* z) {
    std::vector<int> idx;
    for (int i = 0; i < n; ++i)
      if (passive[i]) idx.push_back(i);
    z->setZero(n);
    if (idx.empty()) return;
    Eigen::MatrixXd M(idx.size(), idx.size());
    Eigen::VectorXd r(idx.size());
    for (size_t a = 0; a < idx.size(); ++a) {
      r[a] = Atb[idx[a]];
      for (size_t b = 0; b < idx.size(); ++b) M(a, b) = AtA(idx[a], idx[b]);
      M(a, a) += tol;  // keeps rank-deficient sets (identical basis columns) solvable
    }
    const Eigen::VectorXd s = M.ldlt().solve(r);
    for (size_t a = 0; a < idx.size(); ++a) (*z)[idx[a]] = s[a];
  };
  for (int it = 0; it < max_iterations; ++it) {
    const Eigen::VectorXd grad = Atb - AtA * w;  // negative gradient of the objective / 2
    int best = -1;
    for (int i = 0; i < n; ++i)
      if (!passive[i] && grad[i] > tol && (best < 0 || grad[i] > grad[best])) best = i;
    if (best < 0) break;
    passive[best] = true;
    for (int inner = 0; inner < 3 * n; ++inner) {
      Eigen::VectorXd z;
      solve_passive(&z);
      bool feasible = true;
      for (int i = 0; i < n; ++i)
        if (passive[i] && z[i] <= 0) feasible = false;
      if (feasible) {
        w = z;
        break;
      }
      // Step towards z until the first passive variable hits zero.
      double alpha = 1.0;
      for (int i = 0; i < n; ++i)
        if (passive[i] && z[i] <= 0) alpha = std::min(alpha, w[i] / std::max(1e-300, w[i] - z[i]));
      w += alpha * (z - w);
      for (int i = 0; i < n; ++i)
        if (passive[i] && w[i] <= tol) passive[i] = false, w[i] = 0;
    }
  }
  return w.cwiseMax(0.0);
}

}  // namespace svbrdf
