#include "photometric/transfer.h"

#include <Eigen/Dense>
#include <algorithm>
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

// Weighted ridge fit of pixel p's residuals from `direct` with the first
// `terms` transfer terms on the photos with `in`; c (terms x 3).
Eigen::MatrixXd FitTransferTerms(const PsObservations& obs, long p, const std::vector<Rgb>& direct,
                                 const std::vector<std::array<double, kTerms>>& phi, const std::vector<char>& in,
                                 int terms, double ridge) {
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
}

// Given the residual maps (one per light, 0 where the photo is unusable) and
// each light's leave-one-out neighbours: lambda per pixel, the
// leave-one-light-out errors, and (when kept) the maps scaled in place.
ResidualField FinishResidualField(const PsObservations& obs, std::vector<Image> maps,
                                  const std::vector<std::array<int, kLightResidualNeighbours>>& nb,
                                  const std::vector<std::array<double, kLightResidualNeighbours>>& nw,
                                  const std::vector<int>& count, const DictionaryFitOptions& o, ResidualField out) {
  const int L = obs.lights, P = obs.P();
  auto residual = [&](long p, int l, int c) { return double(maps[l].pixels[size_t(obs.pixel[p]) * 3 + c]); };
  auto interpolated = [&](long p, int l, int c) {
    double r_hat = 0;
    for (int k = 0; k < count[l]; ++k) r_hat += nw[l][k] * residual(p, nb[l][k], c);
    return r_hat;
  };
  // Per pixel the weighted least-squares sums for lambda.
  Image num(obs.width, obs.height, 1), den(obs.width, obs.height, 1);
  ParallelFor(P, o.threads, [&](long p) {
    double sn = 0, sd = 0;
    for (int l = 0; l < L; ++l)
      for (int c = 0; c < 3; ++c) {
        const size_t i = obs.At(p, l) + c;
        if (obs.weight[i] <= 0) continue;
        const double r_hat = interpolated(p, l, c), w2 = double(obs.weight[i]) * obs.weight[i];
        sn += w2 * residual(p, l, c) * r_hat, sd += w2 * r_hat * r_hat;
      }
    num.pixels[obs.pixel[p]] = float(sn), den.pixels[obs.pixel[p]] = float(sd);
  }, 64);
  // lambda from the sums pooled over the window (object pixels only: the
  // others hold zeros).
  const int r = o.residual_window;
  out.share = Image(obs.width, obs.height, 1);
  ParallelFor(P, o.threads, [&](long p) {
    const int x = obs.pixel[p] % obs.width, y = obs.pixel[p] / obs.width;
    double sn = 0, sd = 0;
    for (int v = std::max(0, y - r); v <= std::min(obs.height - 1, y + r); ++v)
      for (int u = std::max(0, x - r); u <= std::min(obs.width - 1, x + r); ++u) sn += num.at(u, v, 0), sd += den.at(u, v, 0);
    out.share.at(x, y, 0) = sd > 0 ? float(std::clamp(sn / sd, 0.0, 1.0)) : 0.0f;
  }, 256);
  std::vector<double> e0(P, 0.0), e1(P, 0.0);
  ParallelFor(P, o.threads, [&](long p) {
    const double lambda = out.share.pixels[obs.pixel[p]];
    for (int l = 0; l < L; ++l)
      for (int c = 0; c < 3; ++c) {
        const size_t i = obs.At(p, l) + c;
        if (obs.weight[i] <= 0) continue;
        const double w = obs.weight[i], r0 = residual(p, l, c), d = r0 - lambda * interpolated(p, l, c);
        e0[p] += (w * r0) * (w * r0);
        e1[p] += (w * d) * (w * d);
      }
  }, 256);
  for (long p = 0; p < P; ++p) out.loo_error_without += e0[p], out.loo_error_with += e1[p];
  out.kept = out.loo_error_with < (1.0 - o.min_gain) * out.loo_error_without;
  if (!out.kept) return out;
  ParallelFor(L, o.threads, [&](long l) {
    for (long p = 0; p < P; ++p) {
      const float lambda = out.share.pixels[obs.pixel[p]];
      for (int c = 0; c < 3; ++c) maps[l].pixels[size_t(obs.pixel[p]) * 3 + c] *= lambda;
    }
  }, 1);
  out.maps = std::move(maps);
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
    auto fit = [&](const std::vector<char>& in, int terms) {
      return FitTransferTerms(obs, p, direct, phi, in, terms, ridge);
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

ResidualField FitResidualField(const PsObservations& obs, const std::vector<BasisMaterial>& basis,
                               const std::vector<Image>& weights, const std::vector<Image>& transfer_maps,
                               const Image& normals_cam, const std::vector<uint8_t>& shadowed,
                               const DictionaryFitOptions& o) {
  ResidualField out;
  const int L = obs.lights, P = obs.P(), T = int(transfer_maps.size());
  const Rigid3 world_from_cam = obs.cam_from_world.Inverse();
  for (int l = 0; l < L; ++l) out.directions.push_back((world_from_cam.rotation * obs.to_light[l]).normalized());
  std::vector<std::array<double, kTerms>> phi(L);
  for (int l = 0; l < L; ++l) LightTransferTerms(out.directions[l], phi[l].data());
  // Each light's neighbours with the light itself left out.
  std::vector<std::array<int, kLightResidualNeighbours>> nb(L);
  std::vector<std::array<double, kLightResidualNeighbours>> nw(L);
  std::vector<int> count(L);
  for (int l = 0; l < L; ++l) count[l] = LightResidualNeighbours(out.directions, out.directions[l], l, nb[l].data(), nw[l].data());
  // Residual maps of direct + transfer, one per light (0 where the photo is
  // unusable and outside the object).
  std::vector<Image> res(L, Image(obs.width, obs.height, 3));
  ParallelFor(P, o.threads, [&](long p) {
    const int x = obs.pixel[p] % obs.width, y = obs.pixel[p] / obs.width;
    const Vec3 n(normals_cam.at(x, y, 0), normals_cam.at(x, y, 1), normals_cam.at(x, y, 2));
    const std::vector<Rgb> direct = DirectPrediction(obs, basis, weights, n.normalized(), p, shadowed);
    for (int l = 0; l < L; ++l)
      for (int c = 0; c < 3; ++c) {
        const size_t i = obs.At(p, l) + c;
        if (obs.weight[i] <= 0) continue;
        double t = 0;
        for (int k = 0; k < T; ++k) t += phi[l][k] * transfer_maps[k].at(x, y, c);
        res[l].pixels[size_t(obs.pixel[p]) * 3 + c] = float(obs.value[i] - (direct[l][c] + t));
      }
  }, 64);
  return FinishResidualField(obs, std::move(res), nb, nw, count, o, std::move(out));
}

}  // namespace svbrdf
