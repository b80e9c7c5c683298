#include "brdf/model.h"

#include "brdf/model_eval.h"
#include "core/error.h"

namespace svbrdf {
namespace {

const char* FamilyName(Family f) {
  switch (f) {
    case Family::kLambert: return "lambert";
    case Family::kOrenNayar: return "oren_nayar";
    case Family::kPhong: return "phong";
    case Family::kBlinnPhong: return "blinn_phong";
    case Family::kCosineLobe: return "cosine_lobe";
    case Family::kLafortune: return "lafortune";
    case Family::kCookTorrance: return "cook_torrance";
    case Family::kConductor: return "conductor";
    case Family::kCoated: return "coated";
    case Family::kGltf: return "gltf";
    case Family::kPlastic: return "plastic";
    case Family::kMirror: return "mirror";
    case Family::kPrincipled: return "principled";
  }
  return "?";
}

const char* DistributionName(Distribution d) {
  switch (d) {
    case Distribution::kBeckmann: return "beckmann";
    case Distribution::kBlinnGaussian: return "blinn";
    case Distribution::kGGX: return "ggx";
  }
  return "?";
}

// Visitor for brdf::VisitParams that records the ParamInfo list.
struct ParamCollector {
  std::vector<ParamInfo> params;
  std::string prefix;
  void Lobe(int i) { prefix = Msg("lobe", i, "."); }
  void Scalar(double&, const char* name, const char* desc, double lo, double hi, double init) {
    params.push_back({prefix + name, desc, lo, hi, init, false});
  }
  void Rgb(brdf::RgbT<double>&, const char* name, const char* desc, double lo, double hi, double init,
           bool linear = true) {
    for (const char* c : {"_r", "_g", "_b"})
      params.push_back({prefix + name + c, Msg(desc, " (", c + 1, ")"), lo, hi, init, linear});
  }
};

// Counts without building strings: NumParams is called per pixel by fits.
struct ParamCounter {
  int n = 0;
  void Lobe(int) {}
  void Scalar(double&, const char*, const char*, double, double, double) { n += 1; }
  void Rgb(brdf::RgbT<double>&, const char*, const char*, double, double, double, bool = true) { n += 3; }
};

}  // namespace

std::string ModelSpec::Name() const { return FamilyName(family); }

std::string ModelSpec::Label() const {
  std::string label = Name();
  if (family == Family::kLafortune) {
    label += Msg("-", lobes);
    if (anisotropic) label += "-aniso";
  } else if (family == Family::kCookTorrance) {
    label += Msg("-", DistributionName(distribution));
    if (shadowing == Shadowing::kSmith) label += "-smith";
    if (fresnel == FresnelMode::kSchlick) label += "-schlick";
    if (fresnel == FresnelMode::kNone) label += "-nofresnel";
  } else if (family == Family::kConductor) {
    label += Msg("-", DistributionName(distribution));
    if (fresnel == FresnelMode::kSchlick) label += "-schlick";
    if (fresnel == FresnelMode::kF82Tint) label += "-f82";
  } else if (family == Family::kCoated) {
    label += Msg("-", DistributionName(distribution));
  } else if (family == Family::kPrincipled && clearcoat) {
    label += "-clearcoat";
  }
  return label;
}

std::vector<ParamInfo> ModelSpec::Params() const {
  ParamCollector collector;
  brdf::WithModel<double>(*this, [&](auto& model) { brdf::VisitParams(collector, *this, model); });
  return collector.params;
}

int ModelSpec::NumParams() const {
  ParamCounter counter;
  brdf::WithModel<double>(*this, [&](auto& model) { brdf::VisitParams(counter, *this, model); });
  return counter.n;
}

std::vector<double> ModelSpec::InitialParams() const {
  std::vector<double> p;
  for (const ParamInfo& info : Params()) p.push_back(info.initial);
  return p;
}

std::vector<ModelSpec> AllModelSpecs() {
  std::vector<ModelSpec> all;
  for (Family f : {Family::kLambert, Family::kOrenNayar, Family::kPhong, Family::kBlinnPhong, Family::kCosineLobe}) {
    ModelSpec s;
    s.family = f;
    all.push_back(s);
  }
  for (bool aniso : {false, true}) {
    for (int lobes = 1; lobes <= 3; ++lobes) {
      ModelSpec s;
      s.family = Family::kLafortune;
      s.lobes = lobes;
      s.anisotropic = aniso;
      all.push_back(s);
    }
  }
  for (Distribution d : {Distribution::kBeckmann, Distribution::kGGX, Distribution::kBlinnGaussian}) {
    for (Shadowing g : {Shadowing::kVCavity, Shadowing::kSmith}) {
      for (FresnelMode fr : {FresnelMode::kExact, FresnelMode::kSchlick, FresnelMode::kNone}) {
        ModelSpec s;
        s.family = Family::kCookTorrance;
        s.distribution = d;
        s.shadowing = g;
        s.fresnel = fr;
        all.push_back(s);
      }
    }
  }
  for (Distribution d : {Distribution::kBeckmann, Distribution::kGGX}) {
    for (FresnelMode fr : {FresnelMode::kExact, FresnelMode::kSchlick, FresnelMode::kF82Tint}) {
      ModelSpec s;
      s.family = Family::kConductor;
      s.distribution = d;
      s.shadowing = Shadowing::kSmith;
      s.fresnel = fr;
      all.push_back(s);
    }
  }
  for (Distribution d : {Distribution::kBeckmann, Distribution::kGGX}) {
    ModelSpec s;
    s.family = Family::kCoated;
    s.distribution = d;
    s.shadowing = Shadowing::kSmith;
    all.push_back(s);
  }
  ModelSpec plastic;
  plastic.family = Family::kPlastic;
  all.push_back(plastic);
  ModelSpec mirror;
  mirror.family = Family::kMirror;
  all.push_back(mirror);
  ModelSpec gltf;
  gltf.family = Family::kGltf;
  gltf.distribution = Distribution::kGGX;
  gltf.shadowing = Shadowing::kSmith;
  gltf.fresnel = FresnelMode::kSchlick;
  all.push_back(gltf);
  for (bool coat : {false, true}) {
    ModelSpec s;
    s.family = Family::kPrincipled;
    s.distribution = Distribution::kGGX;
    s.shadowing = Shadowing::kSmith;
    s.clearcoat = coat;
    all.push_back(s);
  }
  return all;
}

// Parsing by matching against the enumerated labels keeps FromLabel the exact
// inverse of Label() without a second grammar.
ModelSpec ModelSpec::FromLabel(const std::string& label) {
  const std::vector<ModelSpec> all = AllModelSpecs();
  for (const ModelSpec& s : all)
    if (s.Label() == label) return s;
  std::string valid;
  for (const ModelSpec& s : all) valid += (valid.empty() ? "" : ", ") + s.Label();
  throw Error(Msg("unknown reflectance model '", label, "'; valid models: ", valid));
}

// Options that do not apply to a family (e.g. lobes for Cook-Torrance) are
// ignored, which is exactly what comparing labels does.
bool ModelSpec::operator==(const ModelSpec& o) const { return Label() == o.Label(); }

Rgb EvalModelD(const ModelSpec& spec, const double* p, const Vec3& wi, const Vec3& wo) {
  Rgb rgb;
  EvalModel<double>(spec, p, wi, wo, rgb.data());
  return rgb;
}

Rgb DirectionalAlbedo(const ModelSpec& spec, const double* p, const Vec3& wi, int n_theta, int n_phi) {
  Rgb sum = Rgb::Zero();
  for (int i = 0; i < n_theta; ++i) {
    const double t = (i + 0.5) * (kPi / 2) / n_theta;
    for (int j = 0; j < n_phi; ++j) {
      const double ph = (j + 0.5) * 2 * kPi / n_phi;
      const Vec3 wo(std::sin(t) * std::cos(ph), std::sin(t) * std::sin(ph), std::cos(t));
      sum += EvalModelD(spec, p, wi, wo) * (std::cos(t) * std::sin(t));
    }
  }
  return sum * (kPi / 2 / n_theta) * (2 * kPi / n_phi);
}

double MaxDirectionalAlbedo(const ModelSpec& spec, const double* p) {
  double worst = 0;
  for (const double incident : {0.0, 0.8, 1.2, 1.48})
    worst = std::max(worst, DirectionalAlbedo(spec, p, Vec3(std::sin(incident), 0, std::cos(incident)), 32, 64).maxCoeff());
  return worst;
}

bool ReflectsMoreThanItReceives(const ModelSpec& spec, const std::vector<double>& p, double* albedo) {
  if (spec.family != Family::kLafortune) return false;  // the others are bounded by their form
  const double a = MaxDirectionalAlbedo(spec, p.data());
  if (albedo) *albedo = a;
  return a > 1.5;
}

}  // namespace svbrdf
