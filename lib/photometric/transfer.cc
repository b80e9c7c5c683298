#include "photometric/transfer.h"

#include <Eigen/Dense>
#include <array>
#include <cmath>

#include "brdf/model.h"
#include "core/parallel.h"

namespace svbrdf {

namespace {

constexpr int kTerms = kLightTransferMaxTerms;

// Per light: the direct prediction of pixel p (RGB, unit light) as relight
// renders it: zero in attached and cast shadow.
std::vector<Rgb> DirectPrediction(const PsObservations& obs, const std::vector<BasisMaterial>& basis,
                                  const std::vector<Image>& weights, const Vec3& n, long p,
                                  const std::vector<uint8_t>& shadowed) {
  const int x = obs.pixel[p] % obs.width, y = obs.pixel[p] / obs.width;
  const Frame fr = Frame::FromNormal(n);
  const Vec3 wo = fr.ToLocal(obs.to_viewer);
  std::vector<Rgb> out(obs.lights, Rgb::Zero());
  for (int l = 0; l < obs.lights; ++l) {
    if (!shadowed.empty() && shadowed[size_t(p) * obs.lights + l]) continue;
    const Vec3 wi = fr.ToLocal(obs.to_light[l]);
    if (wi.z() <= 0 || wo.z() <= 0) continue;
    Rgb f = Rgb::Zero();
    for (size_t k = 0; k < basis.size(); ++k) {
      const Rgb w(weights[k].at(x, y, 0), weights[k].at(x, y, 1), weights[k].at(x, y, 2));
      if ((w <= 0).all()) continue;
      f += w * EvalModelD(basis[k].spec, basis[k].params.data(), wi, wo);
    }
    out[l] = f * wi.z();
  }
  return out;
}

}  // namespace

TransferFit FitTransfer(const PsObservations& obs, const std::vector<BasisMaterial>& basis,
                        const std::vector<Image>& weights, const Image& normals_cam,
                        const std::vector<uint8_t>& shadowed, const DictionaryFitOptions& o, double ridge) {
  TransferFit out;
  const int kOrders[3] = {4, 9, 16};
  const Rigid3 world_from_cam = obs.cam_from_world.Inverse();
  std::vector<std::array<double, kTerms>> phi(obs.lights);
  for (int l = 0; l < obs.lights; ++l) LightTransferTerms(world_from_cam.rotation * obs.to_light[l], phi[l].data());
  std::vector<std::vector<Image>> maps(3);
  for (int q = 0; q < 3; ++q) maps[q].assign(kOrders[q], Image(obs.width, obs.height, 3));
  std::vector<std::array<double, 4>> err(obs.P(), {0, 0, 0, 0});  // none, then each order
  ParallelFor(obs.P(), o.threads, [&](long p) {
    const int x = obs.pixel[p] % obs.width, y = obs.pixel[p] / obs.width;
    const Vec3 n(normals_cam.at(x, y, 0), normals_cam.at(x, y, 1), normals_cam.at(x, y, 2));
    const std::vector<Rgb> direct = DirectPrediction(obs, basis, weights, n.normalized(), p, shadowed);
    // Weighted ridge fit of the residuals with the first `terms` terms on
    // photos with `in`; returns c (terms x 3).
    auto fit = [&](const std::vector<char>& in, int terms) {
      Eigen::MatrixXd c = Eigen::MatrixXd::Zero(terms, 3);
      for (int ch = 0; ch < 3; ++ch) {
        Eigen::MatrixXd AtA = Eigen::MatrixXd::Zero(terms, terms);
        Eigen::VectorXd Atb = Eigen::VectorXd::Zero(terms);
        int rows = 0;
        for (int l = 0; l < obs.lights; ++l) {
          const size_t i = obs.At(p, l) + ch;
          if (!in[l] || obs.weight[i] <= 0) continue;
          const double w2 = double(obs.weight[i]) * obs.weight[i];
          const Eigen::Map<const Eigen::VectorXd> f(phi[l].data(), terms);
          AtA.noalias() += w2 * f * f.transpose();
          Atb += w2 * (obs.value[i] - direct[l][ch]) * f;
          ++rows;
        }
        if (rows < 2 * terms) continue;  // too few photos: no transfer
        AtA.diagonal().array() += ridge * AtA.diagonal().mean() + 1e-30;
        c.col(ch) = AtA.ldlt().solve(Atb);
      }
      return c;
    };
    for (int f = 0; f < o.folds; ++f) {
      std::vector<char> train(obs.lights);
      for (int l = 0; l < obs.lights; ++l) train[l] = l % o.folds != f;
      for (int q = 0; q < 3; ++q) {
        const Eigen::MatrixXd c = fit(train, kOrders[q]);
        for (int l = f; l < obs.lights; l += o.folds)
          for (int ch = 0; ch < 3; ++ch) {
            const size_t i = obs.At(p, l) + ch;
            if (obs.weight[i] <= 0) continue;
            double t = 0;
            for (int k = 0; k < kOrders[q]; ++k) t += c(k, ch) * phi[l][k];
            const double r0 = obs.weight[i] * (obs.value[i] - direct[l][ch]);
            const double r1 = obs.weight[i] * (obs.value[i] - std::max(0.0, direct[l][ch] + t));
            if (q == 0) err[p][0] += r0 * r0;
            err[p][q + 1] += r1 * r1;
          }
      }
    }
    for (int q = 0; q < 3; ++q) {
      const Eigen::MatrixXd c = fit(std::vector<char>(obs.lights, 1), kOrders[q]);
      for (int k = 0; k < kOrders[q]; ++k)
        for (int ch = 0; ch < 3; ++ch) maps[q][k].at(x, y, ch) = float(c(k, ch));
    }
  }, 64);
  double total[4] = {0, 0, 0, 0};
  for (long p = 0; p < obs.P(); ++p)
    for (int q = 0; q < 4; ++q) total[q] += err[p][q];
  out.cv_error_without = total[0];
  out.cv_error_by_terms.emplace_back(0, total[0]);
  int chosen = -1;
  double best = total[0];
  for (int q = 0; q < 3; ++q) {
    out.cv_error_by_terms.emplace_back(kOrders[q], total[q + 1]);
    if (total[q + 1] < (1.0 - o.min_gain) * best) best = total[q + 1], chosen = q;
  }
  out.cv_error_with = best;
  out.kept = chosen >= 0;
  if (out.kept) {
    out.terms = kOrders[chosen];
    out.maps = std::move(maps[chosen]);
  }
  return out;
}

}  // namespace svbrdf
