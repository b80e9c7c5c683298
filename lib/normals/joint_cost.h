// The per-texel normal fit with the mixing weights solved inside it
// (variable projection; internal to lib/normals and its tests).
//
// Why: a texel's pooled samples (its own and its 8 neighbours', refine.h)
// are predicted with mixing weights, and weights fitted under one normal
// are biased for another: under the mesh normal a bump-shifted highlight
// of a glossy material is explained by a wrong brightness (weight), and a
// tilt fitted with that weight held fixed stops short of the true tilt.
// Alternating weights and normals converges only slowly from there: on
// the mixed preset (true basis and true weights given, copper texels) the
// refined tilt stays well short of the true tilt after the default passes
// and more, but comes close with the true weights held fixed instead,
// while the gathered samples themselves agree with the true material at
// the true normal (a brute-force tilt fit on them finds the true tilt).
// So here every source's weights (the texel's
// and each neighbour's) are the least-squares optimum for the trial tilt
// (its own pooled samples, the non-negative solve of refine.cc's weight
// step, with a weak prior towards the source's current weights), and
// the tilt's Jacobian includes how the weights move with it (the weights
// of the active set are differentiated through the linear solve).
#pragma once
#include <ceres/jet.h>

#include <Eigen/Dense>
#include <vector>

#include "cluster/nnls.h"
#include "normals/normal_cost.h"

namespace svbrdf::normals {

// Most support materials a source may have (the weights' NNLS handles K <= 8).
constexpr int kMaxSupport = 8;

// One source of pooled samples whose weights are solved per trial tilt.
struct WeightSource {
  // Support materials; their `w` is the prior target (the source's current weights).
  std::vector<WeightedBasis> basis;
  // Prior strength in samples' worth: lambda = prior trace(A) / (m n), as refine.cc's weight step.
  double prior = 1.0;
  // Prior on the sum of the weights towards 1 (per system), in samples' worth
  // as `prior`: SvbrdfEstimate::weight_unit_sum. 0: free brightness.
  double unit_sum = 0.0;
  bool per_channel = false;     // one weight per channel, else one per material
  std::vector<int> members;     // indices into the pooled samples
};

inline double ScalarValue(double x) { return x; }
template <int N>
double ScalarValue(const ceres::Jet<double, N>& x) {
  return x.a;
}

// Solves (A) x = b in place for a small symmetric positive definite A
// (m x m, row-major), any scalar type: Cholesky without pivoting.
template <class T>
void SolveSpd(int m, T* A, T* b) {
  using std::sqrt;
  for (int j = 0; j < m; ++j) {
    T d = A[j * m + j];
    for (int k = 0; k < j; ++k) d -= A[j * m + k] * A[j * m + k];
    d = sqrt(d);
    A[j * m + j] = d;
    for (int i = j + 1; i < m; ++i) {
      T s = A[i * m + j];
      for (int k = 0; k < j; ++k) s -= A[i * m + k] * A[j * m + k];
      A[i * m + j] = s / d;
    }
  }
  for (int i = 0; i < m; ++i) {
    T s = b[i];
    for (int k = 0; k < i; ++k) s -= A[i * m + k] * b[k];
    b[i] = s / A[i * m + i];
  }
  for (int i = m - 1; i >= 0; --i) {
    T s = b[i];
    for (int k = i + 1; k < m; ++k) s -= A[k * m + i] * b[k];
    b[i] = s / A[i * m + i];
  }
}

// Least-squares weights of one source for per-sample predictions P
// (sample-major: P[(s * m + j) * 3 + c], material j, channel c) and
// measurements y (y[s * 3 + c]): the non-negative solution of
//   min |P w - y|^2 + lambda |w - w0|^2 + mu (sum_j w_j - 1)^2
// found in double, then re-solved in T on its active set (positive weights)
// so that Jets carry the weights' derivatives. w: [j * 3 + c].
template <class T>
void SolveSourceWeights(const WeightSource& src, int n, const T* P, const double* y, T* w) {
  const int m = int(src.basis.size());
  const int systems = src.per_channel ? 3 : 1;
  for (int q = 0; q < systems; ++q) {
    // Normal equations of system q (channel q, or all channels summed).
    T A[kMaxSupport * kMaxSupport], b[kMaxSupport];
    for (int j = 0; j < m * m; ++j) A[j] = T(0);
    for (int j = 0; j < m; ++j) b[j] = T(0);
    for (int s = 0; s < n; ++s)
      for (int c = src.per_channel ? q : 0; c < (src.per_channel ? q + 1 : 3); ++c)
        for (int j = 0; j < m; ++j) {
          const T& pj = P[(s * m + j) * 3 + c];
          b[j] += pj * y[s * 3 + c];
          for (int k = 0; k <= j; ++k) A[j * m + k] += pj * P[(s * m + k) * 3 + c];
        }
    T trace = T(0);
    for (int j = 0; j < m; ++j) {
      for (int k = j + 1; k < m; ++k) A[j * m + k] = A[k * m + j];
      trace += A[j * m + j];
    }
    const T lambda = src.prior * trace / double(m * std::max(1, n)) + 1e-12;
    const T mu = src.unit_sum * trace / double(m * std::max(1, n));
    for (int j = 0; j < m; ++j) {
      const double target = src.per_channel ? src.basis[j].w[q]
                                            : (src.basis[j].w[0] + src.basis[j].w[1] + src.basis[j].w[2]) / 3.0;
      A[j * m + j] += lambda;
      b[j] += lambda * target;
      if (src.unit_sum > 0) {
        b[j] += mu;
        for (int k = 0; k < m; ++k) A[j * m + k] += mu;
      }
    }
    // Active set from the double problem.
    Eigen::MatrixXd Ad(m, m);
    Eigen::VectorXd bd(m);
    for (int j = 0; j < m; ++j) {
      bd[j] = ScalarValue(b[j]);
      for (int k = 0; k < m; ++k) Ad(j, k) = ScalarValue(A[j * m + k]);
    }
    const Eigen::VectorXd wd = NnlsNormal(Ad, bd);
    int active[kMaxSupport], na = 0;
    for (int j = 0; j < m; ++j)
      if (wd[j] > 0) active[na++] = j;
    T As[kMaxSupport * kMaxSupport], bs[kMaxSupport];
    for (int i = 0; i < na; ++i) {
      bs[i] = b[active[i]];
      for (int k = 0; k < na; ++k) As[i * na + k] = A[active[i] * m + active[k]];
    }
    if (na > 0) SolveSpd(na, As, bs);
    T x[kMaxSupport];
    for (int j = 0; j < m; ++j) x[j] = T(0);
    for (int i = 0; i < na; ++i) x[active[i]] = bs[i];
    for (int j = 0; j < m; ++j)
      for (int c = 0; c < 3; ++c)
        if (!src.per_channel || c == q) w[j * 3 + c] = x[j];
  }
}

// The residual block of one texel's normal fit: 3 residuals per pooled
// sample, then the 2 of the tilt prior, as NormalBatchCost (scaling,
// Cauchy loss, prior), with each sample predicted under its source's
// weights solved for the trial tilt (SolveSourceWeights).
struct NormalJointCost {
  const std::vector<TexelSample>* samples;
  const std::vector<WeightSource>* sources;
  const std::vector<double>* weight;  // per sample
  double cauchy = 0;
  double prior_scale = 0;
  double prior_mean[2] = {0, 0};  // the prior's centre (NormalBatchCost)

  template <class T>
  bool operator()(const T* ab, T* residual) const {
    using std::log1p;
    using std::sqrt;
    const size_t n = samples->size();
    thread_local std::vector<T> P;
    thread_local std::vector<double> y;
    for (const WeightSource& src : *sources) {
      const int m = int(src.basis.size());
      const int ns = int(src.members.size());
      if (m == 0) {
        for (int i : src.members) residual[3 * i] = residual[3 * i + 1] = residual[3 * i + 2] = T(0);
        continue;
      }
      P.resize(size_t(ns) * m * 3);
      y.resize(size_t(ns) * 3);
      for (int s = 0; s < ns; ++s) {
        const TexelSample& ts = (*samples)[src.members[s]];
        for (int c = 0; c < 3; ++c) y[s * 3 + c] = ts.y[c];
        T* p = &P[size_t(s) * m * 3];
        for (int j = 0; j < 3 * m; ++j) p[j] = T(0);
        ForEachSampleFrame(ab, ts, [&](const Vec3T<T>& wi, const Vec3T<T>& wo, const T& shading) {
          for (int j = 0; j < m; ++j) {
            T f[3];
            EvalBasis(src.basis[j], wi, wo, f);
            for (int c = 0; c < 3; ++c) p[3 * j + c] += f[c] * shading;
          }
        });
      }
      T w[kMaxSupport * 3];
      SolveSourceWeights(src, ns, P.data(), y.data(), w);
      for (int s = 0; s < ns; ++s) {
        const int i = src.members[s];
        T* r = residual + 3 * i;
        const T scale = T(sqrt((*weight)[i]));
        for (int c = 0; c < 3; ++c) {
          T pred = T(0);
          for (int j = 0; j < m; ++j) pred += w[j * 3 + c] * P[(size_t(s) * m + j) * 3 + c];
          r[c] = scale * (pred - y[s * 3 + c]);
        }
        ApplyCauchy(cauchy, r);
      }
    }
    residual[3 * n] = prior_scale * (ab[0] - prior_mean[0]);
    residual[3 * n + 1] = prior_scale * (ab[1] - prior_mean[1]);
    return true;
  }
};

}  // namespace svbrdf::normals
