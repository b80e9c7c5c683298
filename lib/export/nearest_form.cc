#include "export/nearest_form.h"

#include <cmath>
#include <limits>

#include "brdf/fresnel.h"
#include "brdf/microfacet.h"
#include "brdf/plastic.h"
#include "brdf/rough_coat.h"
#include "core/error.h"

namespace svbrdf {
double BasisParam(const BasisMaterial& b, const std::string& name) {
  const auto params = b.spec.Params();
  for (size_t i = 0; i < params.size(); ++i)
    if (params[i].name == name) return b.params[i];
  throw Error(Msg("basis material '", b.name, "' (", b.spec.Label(), ") has no parameter '", name, "'"));
}

Rgb BasisParamRgb(const BasisMaterial& b, const std::string& name) {
  return Rgb(BasisParam(b, name + "_r"), BasisParam(b, name + "_g"), BasisParam(b, name + "_b"));
}

namespace {

double Dot(const std::vector<double>& a, const std::vector<double>& b, int stride_a, int off_a, int stride_b,
           int off_b, size_t n) {
  double s = 0;
  for (size_t j = 0; j < n; ++j) s += a[j * stride_a + off_a] * b[j * stride_b + off_b];
  return s;
}

// min |x1 a + x2 b - y|^2 subject to x >= 0, from the Gram entries; returns the residual.
double Nnls2(double aa, double ab, double bb, double ay, double by, double yy, double* x1, double* x2) {
  auto residual = [&](double u, double v) { return u * u * aa + 2 * u * v * ab + v * v * bb - 2 * u * ay - 2 * v * by + yy; };
  double best = yy;
  *x1 = *x2 = 0;
  const double det = aa * bb - ab * ab;
  if (det > 1e-300 * (aa * bb + 1e-300)) {
    const double u = (ay * bb - by * ab) / det, v = (by * aa - ay * ab) / det;
    if (u >= 0 && v >= 0) {
      *x1 = u;
      *x2 = v;
      return std::max(0.0, residual(u, v));
    }
  }
  if (aa > 0 && ay > 0 && residual(ay / aa, 0) < best) {
    best = residual(ay / aa, 0);
    *x1 = ay / aa;
    *x2 = 0;
  }
  if (bb > 0 && by > 0 && residual(0, by / bb) < best) {
    best = residual(0, by / bb);
    *x1 = 0;
    *x2 = by / bb;
  }
  return std::max(0.0, best);
}

ModelSpec LobeSpec(Distribution d, bool fresnel) {
  ModelSpec s;
  s.family = Family::kCookTorrance;
  s.distribution = d;
  s.shadowing = Shadowing::kSmith;
  s.fresnel = fresnel ? FresnelMode::kExact : FresnelMode::kNone;
  return s;
}

// Least-squares fit of diffuse + F = 1 lobe to any model (see header).
NearestForm FitForm(const BasisMaterial& b, const DirectionPairs& d) {
  const std::vector<double> y = BrdfFeatures(b.spec, b.params, d);
  ModelSpec lambert;
  lambert.family = Family::kLambert;
  const std::vector<double> diffuse = BrdfFeatures(lambert, {1, 1, 1}, d);  // same in every channel
  const size_t n = d.size();
  NearestForm best;
  double best_err = std::numeric_limits<double>::infinity();
  for (Distribution dist : {Distribution::kBeckmann, Distribution::kGGX}) {
    for (int i = 0; i < 120; ++i) {
      const double alpha = 0.005 * std::pow(1.0 / 0.005, i / 119.0);  // 0.005 .. 1, log spaced
      const std::vector<double> lobe = BrdfFeatures(LobeSpec(dist, false), {0, 0, 0, 1, 1, 1, alpha, 1.5}, d);
      const double aa = Dot(diffuse, diffuse, 3, 0, 3, 0, n), ab = Dot(diffuse, lobe, 3, 0, 3, 0, n),
                   bb = Dot(lobe, lobe, 3, 0, 3, 0, n);
      NearestForm f;
      f.lobe = NearestForm::Lobe::kRoughConductor;
      f.distribution = dist;
      f.alpha = alpha;
      double err = 0;
      for (int c = 0; c < 3; ++c) {
        const double ay = Dot(diffuse, y, 3, 0, 3, c, n), by = Dot(lobe, y, 3, 0, 3, c, n), yy = Dot(y, y, 3, c, 3, c, n);
        err += Nnls2(aa, ab, bb, ay, by, yy, &f.rd[c], &f.rs[c]);
      }
      if (err < best_err) {
        best_err = err;
        best = f;
      }
    }
  }
  best.how = Msg("least-squares fit of diffuse + ", best.distribution == Distribution::kGGX ? "GGX" : "Beckmann",
                 " rough conductor (F = 1) to ", b.spec.Label());
  return best;
}


// Our conductor's Fresnel (Schlick or F82-tint form) for one channel.
struct OurConductorF {
  double f0, tint;
  bool f82;
  OurConductorF(const BasisMaterial& b, int ch)
      : f0(BasisParamRgb(b, "f0")[ch]),
        tint(b.spec.fresnel == FresnelMode::kF82Tint ? BasisParamRgb(b, "f82_tint")[ch] : 1.0),
        f82(b.spec.fresnel == FresnelMode::kF82Tint) {}
  double operator()(double c) const { return f82 ? brdf::FresnelF82Tint(c, f0, tint) : brdf::FresnelSchlickF0(c, f0); }
};

// The complex index eta + i k with normal-incidence reflectance f0 (kappa
// from ConductorKappaFromF0) whose exact Fresnel is closest to `ours` at
// `cosine`: min over eta of sum_j weight_j (ours_j - F(cosine_j))^2, eta on
// a log grid over our range [0.02, 6]; kappa must stay in [0, 10]. Without
// a reachable eta: (0.02, 10).
void ClosestConductorIndex(double f0, const std::vector<double>& cosine, const std::vector<double>& weight,
                           const std::vector<double>& ours, double* eta_out, double* k_out) {
  double best = std::numeric_limits<double>::infinity();
  *eta_out = 0.02;
  *k_out = 10;
  for (int i = 0; i < 400; ++i) {
    const double eta = 0.02 * std::pow(6.0 / 0.02, i / 399.0);
    const double k = brdf::ConductorKappaFromF0(f0, eta);
    if (k > 10 || std::abs(brdf::ConductorF0(eta, k) - f0) > 1e-9) continue;  // F0 not reachable with this eta
    double e = 0;
    for (size_t j = 0; j < cosine.size(); ++j) {
      const double diff = ours[j] - brdf::FresnelConductor(cosine[j], eta, k);
      e += weight[j] * diff * diff;
    }
    if (e < best) best = e, *eta_out = eta, *k_out = k;
  }
}

// Schlick / F82 conductor -> the complex index per channel with the same F0
// (kappa from ConductorKappaFromF0) whose exact Fresnel is closest to ours
// where the lobe reflects: min over eta of sum_j L_j^2 (F_ours - F)^2(<h|wo>_j),
// L_j the lobe's feature without Fresnel. eta on a log grid over our range
// [0.02, 6]; kappa must stay in [0, 10]. F0 above 0.9992 (eta 0.02, kappa 10)
// cannot be reached and is clamped there (stated in `how`).
void FitConductorIndex(const BasisMaterial& b, const DirectionPairs& d, NearestForm* f) {
  std::vector<double> lobe2(d.size()), cosine(d.size());
  for (size_t j = 0; j < d.size(); ++j) {
    const Vec3 h = (d.wi[j] + d.wo[j]).normalized();
    const double l = std::sqrt(d.weight[j]) * d.wi[j].z() * brdf::SmithMicrofacet(f->distribution, d.wi[j], d.wo[j], h, f->alpha);
    lobe2[j] = l * l;
    cosine[j] = h.dot(d.wo[j]);
  }
  const double kF0Max = brdf::ConductorF0(0.02, 10.0);
  bool clamped = false;
  std::vector<double> ours(d.size());
  for (int ch = 0; ch < 3; ++ch) {
    const OurConductorF our_f(b, ch);
    for (size_t j = 0; j < d.size(); ++j) ours[j] = our_f(cosine[j]);
    const double f0 = std::min(our_f(1.0), kF0Max);
    clamped |= f0 < our_f(1.0) - 1e-12;
    ClosestConductorIndex(f0, cosine, lobe2, ours, &f->eta[ch], &f->k[ch]);
    for (int i = 0; i <= 900; ++i) {
      const double c = std::cos(i * kPi / 1800);  // 0 .. 90 degrees in 0.1 degree steps
      f->max_fresnel_error = std::max(f->max_fresnel_error,
                                      std::abs(brdf::FresnelConductor(c, f->eta[ch], f->k[ch]) - our_f(c)));
    }
  }
  f->how = Msg("nearest: roughconductor with the eta + i k per channel that keeps F0 and fits ",
               b.spec.fresnel == FresnelMode::kF82Tint ? "the F82-tint" : "Schlick's", " curve best (max |dF| ",
               f->max_fresnel_error, clamped ? "; F0 clamped to 0.9992" : "", ")");
}

std::vector<double> FormFeatures(const NearestForm& f, const DirectionPairs& d) {
  std::vector<double> out(3 * d.size());
  for (size_t j = 0; j < d.size(); ++j) {
    const Rgb v = f.Eval(d.wi[j], d.wo[j]);
    const double s = std::sqrt(d.weight[j]) * d.wi[j].z();
    for (int c = 0; c < 3; ++c) out[3 * j + c] = s * v[c];
  }
  return out;
}

// Mitsuba 3's fresnel_diffuse_reflectance(eta) for eta < 1 (fresnel.h: the
// fit of Egan & Hilgeman 1973), which its `plastic` takes as F_int with
// eta = 1 / int_ior.
double MitsubaDiffuseFresnel(double eta) { return -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta; }

}  // namespace

BasisMaterial NearestForm::AsBasis(const std::string& name) const {
  BasisMaterial b;
  b.name = name;
  switch (lobe) {
    case Lobe::kNone:
      b.spec.family = Family::kLambert;
      b.params = {rd[0], rd[1], rd[2]};
      break;
    case Lobe::kRoughConductor:
      if (fresnel && rd.isZero() && (rs == Rgb::Ones()).all()) {  // a metal: our conductor model
        b.spec.family = Family::kConductor;
        b.spec.distribution = distribution;
        b.spec.fresnel = FresnelMode::kExact;
        b.params = {eta[0], eta[1], eta[2], k[0], k[1], k[2], alpha};
      } else {
        if (fresnel && (k.maxCoeff() > 0 || eta.maxCoeff() != eta.minCoeff()))
          throw Error(Msg("basis material '", name, "': a coloured conductor lobe with a diffuse part has no model of ours"));
        b.spec = LobeSpec(distribution, fresnel);
        b.params = {rd[0], rd[1], rd[2], rs[0], rs[1], rs[2], alpha, fresnel ? eta[0] : 1.5};
      }
      break;
    case Lobe::kConductor:
      b.spec.family = Family::kMirror;
      b.params = {brdf::ConductorF0(eta[0], k[0]), brdf::ConductorF0(eta[1], k[1]), brdf::ConductorF0(eta[2], k[2])};
      break;
    case Lobe::kPlastic: {
      b.spec.family = Family::kPlastic;
      const double f_int = brdf::DielectricInternalDiffuseReflectance(ior);
      Rgb rd_ours;
      for (int c = 0; c < 3; ++c)
        rd_ours[c] = BaseForCoupling(base[c] / (1 - base[c] * smooth_internal_reflectance), f_int);
      b.params = {rd_ours[0], rd_ours[1], rd_ours[2], ior};
      break;
    }
    case Lobe::kRoughPlastic: {
      // Invert BaseForCoupling twice: Mitsuba's coupling / base_scale = our g, then our rd with rd / (1 - rd F_int) = g.
      b.spec.family = Family::kCoated;
      b.spec.distribution = distribution;
      const double f_int = brdf::CoatInternalReflectance(distribution, alpha, ior);
      Rgb rd_ours;
      for (int c = 0; c < 3; ++c) {
        const double g = base[c] / (1 - base[c] * plastic.internal_reflectance) / base_scale;
        rd_ours[c] = BaseForCoupling(g, f_int);
      }
      b.params = {rd_ours[0], rd_ours[1], rd_ours[2], alpha, ior};
      break;
    }
  }
  return b;
}

Rgb NearestForm::Eval(const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0 || wo.z() <= 0) return Rgb::Zero();
  Rgb f = rd / kPi;
  if (lobe == Lobe::kRoughConductor) {
    const Vec3 h = (wi + wo).normalized();
    const double l = brdf::SmithMicrofacet(distribution, wi, wo, h, alpha);
    for (int c = 0; c < 3; ++c) f[c] += rs[c] * l * (fresnel ? brdf::FresnelConductor(h.dot(wo), eta[c], k[c]) : 1.0);
  } else if (lobe == Lobe::kRoughPlastic) {
    f += plastic.Eval(base, /*nonlinear=*/true, wi, wo);
  } else if (lobe == Lobe::kPlastic) {  // Mitsuba's plastic.cpp, the delta reflection left out
    // Our model with Mitsuba's F_int (its fit) in place of the exact one.
    brdf::Plastic<double> coat{base, ior};
    coat.prepared_f_int = smooth_internal_reflectance;
    coat.prepared = true;
    f += coat.f(wi, wo);
  }
  return f;
}

NearestForm MapToNearestForm(const BasisMaterial& b, const DirectionPairs& d) {
  NearestForm f;
  const Distribution dist = b.spec.distribution == Distribution::kGGX ? Distribution::kGGX : Distribution::kBeckmann;
  switch (b.spec.family) {
    case Family::kLambert:
      f.rd = BasisParamRgb(b, "rd");
      f.exact = true;
      f.how = "exact: diffuse";
      break;
    case Family::kCookTorrance: {
      f.rd = BasisParamRgb(b, "rd");
      f.lobe = NearestForm::Lobe::kRoughConductor;
      f.rs = BasisParamRgb(b, "rs");
      f.alpha = BasisParam(b, "roughness");
      f.eta = Rgb::Constant(BasisParam(b, "ior"));
      f.fresnel = b.spec.fresnel != FresnelMode::kNone;
      f.distribution = dist;
      std::string approx;
      if (b.spec.distribution == Distribution::kBlinnGaussian) approx += "Blinn Gaussian -> Beckmann with alpha = m; ";
      if (b.spec.shadowing == Shadowing::kVCavity) approx += "V-cavity G -> Smith G; ";
      if (b.spec.fresnel == FresnelMode::kSchlick) approx += "Schlick -> exact dielectric Fresnel of the same ior; ";
      f.exact = approx.empty();
      f.how = f.exact ? "exact: diffuse + roughconductor" : "nearest: " + approx.substr(0, approx.size() - 2);
      break;
    }
    case Family::kConductor:
      f.lobe = NearestForm::Lobe::kRoughConductor;
      f.rs = Rgb::Ones();
      f.fresnel = true;
      f.distribution = dist;
      f.alpha = BasisParam(b, "roughness");
      if (b.spec.fresnel == FresnelMode::kExact) {
        f.eta = BasisParamRgb(b, "eta");
        f.k = BasisParamRgb(b, "kappa");
        f.exact = true;
        f.how = "exact: roughconductor with eta, k per channel";
      } else {
        FitConductorIndex(b, d, &f);
      }
      break;
    case Family::kCoated:
      f.lobe = NearestForm::Lobe::kRoughPlastic;
      f.distribution = dist;
      f.alpha = BasisParam(b, "roughness");
      f.ior = BasisParam(b, "ior");
      f.plastic = RoughPlastic::Make(dist, f.alpha, f.ior);
      {
        // Least-squares scale of Mitsuba's base term t(mu_i) t(mu_o) onto ours
        // (the same t, from our tables) over the direction pairs (the coats
        // are equal): 1 up to the tables' interpolation.
        const brdf::RoughCoat<double> coat(dist, f.alpha, f.ior);
        double tt = 0, to = 0;
        for (size_t j = 0; j < d.size(); ++j) {
          const double w = d.weight[j] * d.wi[j].z() * d.wi[j].z();
          const double mi = f.plastic.Transmittance(d.wi[j].z()) * f.plastic.Transmittance(d.wo[j].z());
          const double ours = coat.Transmittance(d.wi[j].z()) * coat.Transmittance(d.wo[j].z());
          tt += w * mi * mi;
          to += w * mi * ours;
        }
        f.base_scale = tt > 0 ? to / tt : 1.0;
        const Rgb rd = BasisParamRgb(b, "rd");
        for (int c = 0; c < 3; ++c)
          f.base[c] = BaseForCoupling(f.base_scale * rd[c] / (1 - rd[c] * coat.f_int), f.plastic.internal_reflectance);
        f.how = Msg("nearest: roughplastic (nonlinear); the same model, its transmittance computed for this material "
                    "instead of interpolated (base scaled by ", f.base_scale, "; F_int ", f.plastic.internal_reflectance,
                    " vs ours ", coat.f_int, ")");
      }
      break;
    case Family::kMirror: {
      // The index per channel that keeps F0 and is closest to Schlick's
      // curve over cosines 0..1 (eta on a log grid, kappa from F0).
      f.lobe = NearestForm::Lobe::kConductor;
      f.rs = Rgb::Ones();
      f.fresnel = true;
      const Rgb f0 = BasisParamRgb(b, "f0");
      std::vector<double> cosine(101), weight(101, 1.0), ours(101);
      for (int j = 0; j <= 100; ++j) cosine[j] = j / 100.0;
      for (int ch = 0; ch < 3; ++ch) {
        const double target = std::min(f0[ch], brdf::ConductorF0(0.02, 10.0));
        for (int j = 0; j <= 100; ++j) ours[j] = brdf::FresnelSchlickF0(cosine[j], target);
        ClosestConductorIndex(target, cosine, weight, ours, &f.eta[ch], &f.k[ch]);
      }
      f.how = "nearest: conductor (smooth) with the eta + i k per channel that keeps F0 and is closest to Schlick's curve";
      break;
    }
    case Family::kPlastic: {
      f.lobe = NearestForm::Lobe::kPlastic;
      f.ior = BasisParam(b, "ior");
      f.smooth_internal_reflectance = MitsubaDiffuseFresnel(1 / f.ior);
      const double f_int = brdf::DielectricInternalDiffuseReflectance(f.ior);
      const Rgb rd = BasisParamRgb(b, "rd");
      for (int c = 0; c < 3; ++c)
        f.base[c] = BaseForCoupling(rd[c] / (1 - rd[c] * f_int), f.smooth_internal_reflectance);
      f.how = Msg("nearest: plastic (nonlinear), the same model up to F_int (Mitsuba's fit ",
                  f.smooth_internal_reflectance, " vs ours ", f_int, ")");
      break;
    }
    default:
      f = FitForm(b, d);
      break;
  }
  f.error = RelativeFeatureError(BrdfFeatures(b.spec, b.params, d), FormFeatures(f, d));
  return f;
}

}  // namespace svbrdf
