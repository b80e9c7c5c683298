#include "export/nearest_form.h"

#include <cmath>
#include <limits>

#include "core/error.h"

namespace svbrdf {
namespace {

double Param(const BasisMaterial& b, const std::string& name) {
  const auto params = b.spec.Params();
  for (size_t i = 0; i < params.size(); ++i)
    if (params[i].name == name) return b.params[i];
  throw Error(Msg("basis material '", b.name, "' (", b.spec.Label(), ") has no parameter '", name, "'"));
}

Rgb ParamRgb(const BasisMaterial& b, const std::string& name) {
  return Rgb(Param(b, name + "_r"), Param(b, name + "_g"), Param(b, name + "_b"));
}

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
      f.has_lobe = true;
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

}  // namespace

BasisMaterial NearestForm::AsBasis(const std::string& name) const {
  BasisMaterial b;
  b.name = name;
  if (!has_lobe) {
    b.spec.family = Family::kLambert;
    b.params = {rd[0], rd[1], rd[2]};
  } else {
    b.spec = LobeSpec(distribution, fresnel);
    b.params = {rd[0], rd[1], rd[2], rs[0], rs[1], rs[2], alpha, eta};
  }
  return b;
}

NearestForm MapToNearestForm(const BasisMaterial& b, const DirectionPairs& d) {
  NearestForm f;
  switch (b.spec.family) {
    case Family::kLambert:
      f.rd = ParamRgb(b, "rd");
      f.exact = true;
      f.how = "exact: diffuse";
      break;
    case Family::kCookTorrance: {
      f.rd = ParamRgb(b, "rd");
      f.has_lobe = true;
      f.rs = ParamRgb(b, "rs");
      f.alpha = Param(b, "roughness");
      f.eta = Param(b, "ior");
      f.fresnel = b.spec.fresnel != FresnelMode::kNone;
      f.distribution = b.spec.distribution == Distribution::kGGX ? Distribution::kGGX : Distribution::kBeckmann;
      std::string approx;
      if (b.spec.distribution == Distribution::kBlinnGaussian) approx += "Blinn Gaussian -> Beckmann with alpha = m; ";
      if (b.spec.shadowing == Shadowing::kVCavity) approx += "V-cavity G -> Smith G; ";
      if (b.spec.fresnel == FresnelMode::kSchlick) approx += "Schlick -> exact dielectric Fresnel of the same ior; ";
      f.exact = approx.empty();
      f.how = f.exact ? "exact: diffuse + roughconductor" : "nearest: " + approx.substr(0, approx.size() - 2);
      break;
    }
    default:
      f = FitForm(b, d);
      break;
  }
  f.error = RelativeFeatureError(BrdfFeatures(b.spec, b.params, d), [&] {
    const BasisMaterial m = f.AsBasis(b.name);
    return BrdfFeatures(m.spec, m.params, d);
  }());
  return f;
}

}  // namespace svbrdf
