#include "cluster/split.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "cluster/model_selection.h"
#include "cluster/nnls.h"
#include "cluster/prune.h"
#include "cluster/stats.h"
#include "core/error.h"
#include "core/parallel.h"

namespace svbrdf {

namespace {

// Per-feature whitening (mean, standard deviation) of per-texel features
// (rows = texels), estimated on one set of texels and applied to any.
struct Whitening {
  explicit Whitening(const Eigen::MatrixXd& X) : mean(X.colwise().mean()), scale(X.cols()) {
    for (int q = 0; q < X.cols(); ++q) {
      const double sd = std::sqrt((X.col(q).array() - mean[q]).square().sum() / std::max<long>(1, X.rows()));
      scale[q] = sd > 1e-12 ? 1.0 / sd : 1.0;
    }
  }
  Eigen::MatrixXd Apply(const Eigen::MatrixXd& X) const {
    return (X.rowwise() - mean).array().rowwise() * scale.array();
  }
  Eigen::RowVectorXd mean, scale;
};

// Groups 0/1 of the rows of a whitened Z: split at the mean along the
// principal component, refined by 2-means.
std::vector<int> TwoMeans(const Eigen::MatrixXd& Z) {
  const long T = Z.rows();
  const int F = static_cast<int>(Z.cols());
  const Eigen::RowVectorXd mean = Z.colwise().mean();
  const Eigen::MatrixXd C = Z.rowwise() - mean;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(C.transpose() * C);
  const Eigen::VectorXd v = eig.eigenvectors().col(F - 1);
  std::vector<int> g(T);
  for (long j = 0; j < T; ++j) g[j] = C.row(j).dot(v) >= 0 ? 1 : 0;
  for (int it = 0; it < 20; ++it) {
    Eigen::RowVectorXd c[2] = {Eigen::RowVectorXd::Zero(F), Eigen::RowVectorXd::Zero(F)};
    double n[2] = {0, 0};
    for (long j = 0; j < T; ++j) c[g[j]] += Z.row(j), n[g[j]] += 1;
    if (n[0] == 0 || n[1] == 0) break;
    c[0] /= n[0];
    c[1] /= n[1];
    bool changed = false;
    for (long j = 0; j < T; ++j) {
      const int gj = (Z.row(j) - c[1]).squaredNorm() < (Z.row(j) - c[0]).squaredNorm() ? 1 : 0;
      changed |= gj != g[j];
      g[j] = gj;
    }
    if (!changed) break;
  }
  return g;
}

}  // namespace

std::vector<int> SplitSides(const Clustering& cl, int k, int variant) {
  const SampleSet& s = cl.samples();
  const int nt = cl.num_texels();
  BasisMaterial probe[2];
  for (int q = 0; q < 2; ++q) {
    probe[q].spec = ModelSpec::FromLabel("cosine_lobe");
    probe[q].params = {0, 0, 0, 1, 1, 1, q == 0 ? 8.0 : 64.0};  // rd, rs, exponent
  }
  std::vector<int> texels;
  for (int t = 0; t < nt; ++t)
    if (cl.usable()[t] && cl.assign()[t] == k) texels.push_back(t);
  const size_t T = texels.size();
  constexpr int kFeatures = 5;
  using VecF = Eigen::Matrix<double, kFeatures, 1>;
  using MatF = Eigen::Matrix<double, kFeatures, kFeatures>;
  Eigen::MatrixXd X(T, kFeatures);
  ParallelFor(long(T), cl.threads(), [&](long j) {
    const int t = texels[j];
    MatF AtA = MatF::Zero();
    VecF Atb = VecF::Zero();
    for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
      if (cl.holdout()[i]) continue;
      const Vec3 wi(s.wi[0][i], s.wi[1][i], s.wi[2][i]), wo(s.wo[0][i], s.wo[1][i], s.wo[2][i]);
      const double p0 = EvalModelD(probe[0].spec, probe[0].params.data(), wi, wo)[0] * s.geom[i];
      const double p1 = EvalModelD(probe[1].spec, probe[1].params.data(), wi, wo)[0] * s.geom[i];
      for (int c = 0; c < 3; ++c) {
        VecF row = VecF::Zero();
        row[c] = s.geom[i] / kPi;
        row[3] = p0;
        row[4] = p1;
        AtA += row * row.transpose();
        Atb += row * double(s.y[c][i]);
      }
    }
    AtA.diagonal().array() += 1e-9 * (1.0 + AtA.diagonal().maxCoeff());
    X.row(j) = NnlsNormal(AtA, Atb).transpose();
  }, 256);
  std::vector<int> side(nt, 0);
  if (T < 4) return side;
  if (variant == 1) X = Eigen::MatrixXd(X.leftCols(3));
  if (variant == 2) X = Eigen::MatrixXd(X.rightCols(2));
  std::vector<int> g = TwoMeans(Whitening(X).Apply(X));
  const long ones = std::count(g.begin(), g.end(), 1);
  const long usable_texels = std::count(cl.usable().begin(), cl.usable().end(), char(1));
  const long min_half = std::max<long>(2, long(cl.options().min_cluster_fraction * usable_texels));
  // Only with all five features: the subsets (variants 1, 2) are tried when
  // a split did not help, and a second peeled candidate per cluster costs
  // split-search time that a tight time budget then lacks for the normal
  // stage (mixed preset).
  if (variant == 0 && std::min<long>(ones, long(T) - ones) < min_half) {
    // One half too small: either the cluster is one material whose extreme
    // texels (few samples, region borders) took a centroid, or extreme texels
    // hid two materials from the whitening and the 2-means. Peel the small
    // half off and split the rest again: one material's rest yields another
    // small half, two materials' rest two large ones: after peeling, the
    // default capture's pure clusters still give halves too small to split,
    // and the Mitsuba armadillo scan's metal + red cluster (with footprint
    // sub-samples) two large ones.
    std::vector<long> rest;
    const int big = ones * 2 > long(T) ? 1 : 0;
    for (size_t j = 0; j < T; ++j)
      if (g[j] == big) rest.push_back(long(j));
    Eigen::MatrixXd Xr(rest.size(), X.cols());
    for (size_t j = 0; j < rest.size(); ++j) Xr.row(j) = X.row(rest[j]);
    const Whitening w(Xr);
    const Eigen::MatrixXd Zr = w.Apply(Xr);
    const std::vector<int> r = TwoMeans(Zr);
    const long r_ones = std::count(r.begin(), r.end(), 1);
    // The peeled split is a second guess: its halves must be clearly, not
    // just barely, large enough (the tiny preset with 5 materials: a piece
    // of one material, above the minimum but below twice it, became a sixth
    // material).
    constexpr long kPeeledMinHalfFactor = 2;
    if (std::min<long>(r_ones, long(rest.size()) - r_ones) >= kPeeledMinHalfFactor * min_half) {
      // Every texel, the peeled ones too, to the nearer of the rest's groups.
      Eigen::RowVectorXd c[2] = {Eigen::RowVectorXd::Zero(X.cols()), Eigen::RowVectorXd::Zero(X.cols())};
      for (size_t j = 0; j < rest.size(); ++j) c[r[j]] += Zr.row(j);
      c[0] /= double(long(rest.size()) - r_ones);
      c[1] /= double(r_ones);
      const Eigen::MatrixXd Z = w.Apply(X);
      for (size_t j = 0; j < T; ++j) g[j] = (Z.row(j) - c[1]).squaredNorm() < (Z.row(j) - c[0]).squaredNorm() ? 1 : 0;
    }
  }
  for (size_t j = 0; j < T; ++j) side[texels[j]] = g[j] ? 1 : -1;
  return side;
}


std::vector<int> GeometrySplitSides(const Clustering& cl, int k) {
  const SampleSet& s = cl.samples();
  std::vector<int> texels;
  for (int t = 0; t < cl.num_texels(); ++t)
    if (cl.usable()[t] && cl.assign()[t] == k) texels.push_back(t);
  const size_t T = texels.size();
  std::vector<int> side(cl.num_texels(), 0);
  if (T < 4) return side;
  // Per texel: the mean elevations (local z) of its training light, view and
  // half vectors: what part of the BRDF's domain the texel was seen in.
  Eigen::MatrixXd Z(T, 3);
  for (size_t j = 0; j < T; ++j) {
    const int t = texels[j];
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    int n = 0;
    for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
      if (cl.holdout()[i]) continue;
      const Eigen::Vector3d wi(s.wi[0][i], s.wi[1][i], s.wi[2][i]), wo(s.wo[0][i], s.wo[1][i], s.wo[2][i]);
      m += Eigen::Vector3d(wi.z(), wo.z(), (wi + wo).normalized().z());
      ++n;
    }
    Z.row(j) = (m / std::max(1, n)).transpose();
  }
  Z = Z.rowwise() - Z.colwise().mean();
  for (int q = 0; q < 3; ++q) {
    const double sd = std::sqrt(Z.col(q).squaredNorm() / T);
    Z.col(q) /= sd > 1e-12 ? sd : 1.0;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Z.transpose() * Z);
  const Eigen::VectorXd v = eig.eigenvectors().col(2);
  std::vector<std::pair<double, int>> proj(T);
  for (size_t j = 0; j < T; ++j) proj[j] = {Z.row(j).dot(v), texels[j]};
  std::sort(proj.begin(), proj.end());
  for (size_t j = 0; j < T; ++j) side[proj[j].second] = j < T / 2 ? 1 : -1;
  return side;
}

std::vector<ModelSpec> SplitModels(const ReconstructOptions& o) {
  if (!o.force_model.empty()) return {ModelSpec::FromLabel(o.force_model)};
  std::vector<ModelSpec> specs{ModelSpec::FromLabel(o.cluster_model)};
  for (const std::string& label : o.split_models) {
    const ModelSpec spec = ModelSpec::FromLabel(label);
    const bool candidate = std::find(o.candidate_models.begin(), o.candidate_models.end(), label) != o.candidate_models.end();
    if (candidate && std::find(specs.begin(), specs.end(), spec) == specs.end()) specs.push_back(spec);
  }
  return specs;
}

double PartitionAgreement(const std::vector<int>& a, const std::vector<int>& b, const std::vector<char>& usable) {
  std::map<std::pair<int, int>, long> overlap;
  long total = 0;
  for (size_t t = 0; t < a.size() && t < b.size(); ++t)
    if (t < usable.size() && usable[t]) ++overlap[{a[t], b[t]}], ++total;
  std::vector<std::pair<long, std::pair<int, int>>> pairs;
  for (const auto& [ab, n] : overlap) pairs.push_back({n, ab});
  std::stable_sort(pairs.begin(), pairs.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
  std::set<int> used_a, used_b;
  long agree = 0;
  for (const auto& [n, ab] : pairs)
    if (!used_a.count(ab.first) && !used_b.count(ab.second)) {
      used_a.insert(ab.first), used_b.insert(ab.second);
      agree += n;
    }
  return total > 0 ? double(agree) / total : 1.0;
}

double SplitKeptShare(const std::vector<int>& parent, int k, const std::vector<int>& start,
                      const std::vector<int>& refined, const std::vector<char>& usable) {
  std::vector<char> in_k(parent.size(), 0);
  for (size_t t = 0; t < in_k.size() && t < usable.size(); ++t) in_k[t] = usable[t] && parent[t] == k;
  return PartitionAgreement(start, refined, in_k);
}

double SplitCoherence(const Clustering& cl, const std::vector<int>& side) {
  const std::vector<int>& label = cl.assign();
  std::vector<double> count;
  double pairs = 0, differ = 0, n = 0;
  for (int t = 0; t < cl.num_texels(); ++t) {
    if (side[t] == 0 || !cl.usable()[t] || label[t] < 0) continue;
    if (label[t] >= int(count.size())) count.resize(label[t] + 1, 0.0);
    count[label[t]] += 1, n += 1;
    for (int u : cl.neighbours()[t])
      if (side[u] != 0 && cl.usable()[u] && label[u] >= 0) pairs += 1, differ += label[u] != label[t];
  }
  double same = 0;
  for (double c : count) same += (c / std::max(1.0, n)) * (c / std::max(1.0, n));
  const double expected = 1.0 - same;
  if (pairs == 0 || expected <= 1e-12) return 1.0;
  return 1.0 - (differ / pairs) / expected;
}

SplitModelChoice ChooseSplitModel(const Clustering& cl, int k, const BasisMaterial* parent) {
  const ReconstructOptions& o = cl.options();
  const std::vector<ModelSpec> specs = SplitModels(o);
  auto start = [&](const ModelSpec& spec) { return parent && parent->spec == spec ? parent->params : std::vector<double>{}; };
  if (specs.size() == 1) return {specs[0], start(specs[0]), false};
  std::vector<int64_t> train, hold;
  ValidationSamples(cl, k, &train, &hold);
  if (train.empty()) return {specs[0], start(specs[0]), false};
  // Independent quick fits (screening, as in model selection), one per thread.
  std::vector<FitResult> fits(specs.size());
  std::vector<double> mse(specs.size(), 0.0);
  ParallelFor(long(specs.size()), cl.threads(), [&](long j) {
    FitOptions fo = ScreeningFitOptions(o, Msg("reconstruct: cluster ", k, " (split model)"));
    fo.cancel = cl.cancel();
    fits[j] = FitModel(specs[j], cl.samples(), train, fo, start(specs[j]));
    if (hold.empty()) {
      mse[j] = fits[j].cost;
      return;
    }
    // Not trimmed: a model that extrapolates wildly to the unseen directions
    // of a few samples (highlights) must lose.
    double sum = 0;
    for (double e : SampleErrors(specs[j], fits[j].params, cl.samples(), hold)) sum += e;
    mse[j] = sum / (3.0 * hold.size());
  });
  const size_t best = size_t(std::min_element(mse.begin(), mse.end()) - mse.begin());
  SplitModelChoice choice{specs[best], fits[best].params, true, mse[best]};
  for (size_t j = 0; j < specs.size(); ++j)
    if (parent && specs[j] == parent->spec) choice.parent_mse = mse[j];
  return choice;
}

SplitHalfTest WeakerSplitHalf(const Clustering& cl, int k, int knew, const std::vector<double>& with_sse) {
  SplitHalfTest weaker;
  for (int r : {k, knew}) {
    const MaterialRemoval removal = ScoreRemoval(cl, r, cl.SearchWeightModel(), with_sse);
    if (weaker.half < 0 || removal.drop < weaker.drop) weaker = {r, removal.drop, removal.z};
  }
  return weaker;
}

BasisMaterial FitSplitModel(const Clustering& cl, int k, const BasisMaterial* parent) {
  const SplitModelChoice c = ChooseSplitModel(cl, k, parent);
  if (!c.screened) return MakeBasis(c.spec, cl.Fit(c.spec, k, c.start), k);
  // The chosen model fitted fully (robust, all training samples), from its
  // screening fit: the split test scores the halves before refinement.
  return MakeBasis(c.spec, cl.Fit(c.spec, k, c.start, 0, -1, parent == nullptr), k);
}

}  // namespace svbrdf
