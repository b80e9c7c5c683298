#include "cluster/nnls.h"

#include <algorithm>

#include "core/error.h"

namespace svbrdf {

NnlsVector NnlsNormal(const Eigen::Ref<const Eigen::MatrixXd>& AtA, const Eigen::Ref<const Eigen::VectorXd>& Atb,
                      int max_iterations) {
  const int n = static_cast<int>(Atb.size());
  if (n > kNnlsMaxUnknowns || AtA.rows() != n || AtA.cols() != n)
    throw Error(Msg("NNLS: ", AtA.rows(), " x ", AtA.cols(), " normal matrix for ", n, " unknowns (at most ",
                    kNnlsMaxUnknowns, ")"));
  NnlsVector w = NnlsVector::Zero(n);
  bool passive[kNnlsMaxUnknowns] = {};
  const double tol = 1e-12 * (1.0 + (n ? AtA.diagonal().cwiseAbs().maxCoeff() : 0.0));
  // Solves the unconstrained problem restricted to the passive set.
  auto solve_passive = [&](NnlsVector* z) {
    int idx[kNnlsMaxUnknowns];
    int m = 0;
    for (int i = 0; i < n; ++i)
      if (passive[i]) idx[m++] = i;
    z->setZero(n);
    if (m == 0) return;
    NnlsMatrix M(m, m);
    NnlsVector r(m);
    for (int a = 0; a < m; ++a) {
      r[a] = Atb[idx[a]];
      for (int b = 0; b < m; ++b) M(a, b) = AtA(idx[a], idx[b]);
      M(a, a) += tol;  // keeps rank-deficient sets (identical basis columns) solvable
    }
    const NnlsVector s = M.ldlt().solve(r);
    for (int a = 0; a < m; ++a) (*z)[idx[a]] = s[a];
  };
  NnlsVector grad(n), z(n);
  for (int it = 0; it < max_iterations; ++it) {
    grad.noalias() = Atb - AtA * w;  // negative gradient of the objective / 2
    int best = -1;
    for (int i = 0; i < n; ++i)
      if (!passive[i] && grad[i] > tol && (best < 0 || grad[i] > grad[best])) best = i;
    if (best < 0) break;
    passive[best] = true;
    for (int inner = 0; inner < 3 * n; ++inner) {
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
