// Physical properties (reciprocity, positivity, energy conservation), special
// cases, optics and autodiff of the reflectance models in lib/brdf.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <map>
#include <random>
#include <set>

#include "brdf/fresnel.h"
#include "brdf/metals.h"
#include "brdf/model.h"
#include "brdf/model_eval.h"
#include "brdf/optics.h"
#include "core/error.h"
#include "core/rng.h"

namespace svbrdf {
namespace {

using brdf::Dot;

Vec3 FromAngles(double theta, double phi) {
  return Vec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
}

// Uniform on the upper hemisphere, kept slightly above the horizon where
// 1/<N|L> style terms would make relative comparisons meaningless.
Vec3 RandomDir(Rng& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double z = 0.01 + 0.99 * u(rng);
  const double phi = 2 * kPi * u(rng);
  const double r = std::sqrt(1 - z * z);
  return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

// Uniform within each parameter's documented range; log-uniform for wide
// positive ranges (exponents, roughness) so both ends get exercised.
std::vector<double> RandomParams(const ModelSpec& spec, Rng& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> p;
  for (const ParamInfo& info : spec.Params()) {
    const double t = u(rng);
    if (info.lower > 0 && info.upper / info.lower > 50)
      p.push_back(info.lower * std::pow(info.upper / info.lower, t));
    else
      p.push_back(info.lower + t * (info.upper - info.lower));
  }
  return p;
}

// The mirror's reflection is all delta (brdf/mirror.h): f = 0.
bool HasBrdfPart(const ModelSpec& spec) { return spec.family != Family::kMirror; }

int ParamIndex(const ModelSpec& spec, const std::string& name) {
  const std::vector<ParamInfo> params = spec.Params();
  for (int i = 0; i < static_cast<int>(params.size()); ++i)
    if (params[i].name == name) return i;
  ADD_FAILURE() << "no parameter " << name << " in " << spec.Label();
  return 0;
}

// The lecture's Oren-Nayar albedo reaches rd (A + B/2) <= 1.0152 rd at grazing
// incidence (see oren_nayar.h), so it conserves energy only for rd <= 0.985.
constexpr double kOrenNayarMaxRd = 0.985;

// Largest deviation of the F82-tint curve from the exact Fresnel of the
// published metals: measured 0.022 (aluminium, red), where Schlick's curve is
// off by 0.13.
constexpr double kF82MaxError = 0.03;

// Rescales random parameters to the edge of where the model conserves energy
// (max over channels of rd + rs equal to the limit, so the bound is tested
// tightly) and restricts them to where the quadrature below resolves the lobe
// (exponent <= 1000, roughness >= 0.05).
// Conductors have no amplitudes to rescale (F <= 1 by construction); a
// coated or plastic material's base albedo is scaled to a white maximum.
void MakeEnergyConserving(const ModelSpec& spec, std::vector<double>* p) {
  const std::vector<ParamInfo> params = spec.Params();
  if (spec.family == Family::kConductor || spec.family == Family::kGltf) return;  // bounded by their ranges
  const bool has_rs = spec.family != Family::kLambert && spec.family != Family::kOrenNayar &&
                      spec.family != Family::kCoated && spec.family != Family::kPlastic;
  double max_sum = 0;
  for (int i = 0; i < static_cast<int>(params.size()); ++i) {
    if (params[i].name == "exponent") (*p)[i] = std::min((*p)[i], 1000.0);
    if (params[i].name == "roughness") (*p)[i] = std::max((*p)[i], 0.05);
  }
  for (const char* c : {"_r", "_g", "_b"})
    max_sum = std::max(max_sum, (*p)[ParamIndex(spec, std::string("rd") + c)] +
                                    (has_rs ? (*p)[ParamIndex(spec, std::string("rs") + c)] : 0.0));
  const double scale = (spec.family == Family::kOrenNayar ? kOrenNayarMaxRd : 1.0) / max_sum;
  for (int i = 0; i < static_cast<int>(params.size()); ++i)
    if (params[i].name.rfind("rd_", 0) == 0 || params[i].name.rfind("rs_", 0) == 0) (*p)[i] *= scale;
}

// Directional albedo on a fine 256 x 512 grid (DirectionalAlbedo).
Rgb Albedo(const ModelSpec& spec, const std::vector<double>& p, const Vec3& wi) {
  return DirectionalAlbedo(spec, p.data(), wi, 256, 512);
}

bool IsReciprocal(const ModelSpec& spec) {
  return spec.family != Family::kPhong && spec.family != Family::kBlinnPhong;
}

// Principled: Burley's retro-reflection is an empirical fit that reflects a
// little more than it receives at grazing light (Principled.AlbedoStaysNearOne).
bool ConservesEnergy(const ModelSpec& spec) {
  return spec.family != Family::kPhong && spec.family != Family::kBlinnPhong && spec.family != Family::kLafortune &&
         spec.family != Family::kPrincipled;
}

// ---------------------------------------------------------------- ModelSpec

TEST(ModelSpec, LabelsRoundTripAndAreUnique) {
  std::set<std::string> labels;
  for (const ModelSpec& spec : AllModelSpecs()) {
    EXPECT_TRUE(labels.insert(spec.Label()).second) << spec.Label();
    EXPECT_EQ(ModelSpec::FromLabel(spec.Label()), spec);
    EXPECT_EQ(ModelSpec::FromLabel(spec.Label()).Label(), spec.Label());
  }
  for (const char* l : {"lambert", "oren_nayar", "phong", "blinn_phong", "cosine_lobe", "lafortune-1", "lafortune-2",
                        "lafortune-3", "lafortune-1-aniso", "lafortune-2-aniso", "lafortune-3-aniso",
                        "cook_torrance-beckmann", "cook_torrance-ggx", "cook_torrance-blinn",
                        "cook_torrance-ggx-smith-schlick", "cook_torrance-beckmann-nofresnel"})
    EXPECT_EQ(labels.count(l), 1u) << l;
  for (const char* l : {"conductor-ggx", "conductor-beckmann", "conductor-ggx-schlick", "conductor-beckmann-f82",
                        "coated-ggx", "coated-beckmann", "plastic", "mirror", "gltf", "principled",
                        "principled-clearcoat"})
    EXPECT_EQ(labels.count(l), 1u) << l;
  EXPECT_EQ(labels.size(), 5u + 6u + 18u + 6u + 2u + 1u + 1u + 1u + 2u);
}

TEST(ModelSpec, NamesAreFamilies) {
  EXPECT_EQ(ModelSpec::FromLabel("lafortune-2-aniso").Name(), "lafortune");
  EXPECT_EQ(ModelSpec::FromLabel("cook_torrance-ggx-smith").Name(), "cook_torrance");
  EXPECT_EQ(ModelSpec::FromLabel("oren_nayar").Name(), "oren_nayar");
  const ModelSpec s = ModelSpec::FromLabel("cook_torrance-blinn-smith-schlick");
  EXPECT_EQ(s.distribution, Distribution::kBlinnGaussian);
  EXPECT_EQ(s.shadowing, Shadowing::kSmith);
  EXPECT_EQ(s.fresnel, FresnelMode::kSchlick);
}

TEST(ModelSpec, UnknownLabelThrowsListingValidOnes) {
  try {
    ModelSpec::FromLabel("torrance");
    FAIL() << "no exception";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("torrance"), std::string::npos);
    EXPECT_NE(what.find("lafortune-3-aniso"), std::string::npos);
    EXPECT_NE(what.find("cook_torrance-ggx-smith"), std::string::npos);
  }
}

TEST(ModelSpec, ParamLayouts) {
  auto names = [](const std::string& label) {
    std::vector<std::string> n;
    for (const ParamInfo& i : ModelSpec::FromLabel(label).Params()) n.push_back(i.name);
    return n;
  };
  using V = std::vector<std::string>;
  EXPECT_EQ(names("lambert"), (V{"rd_r", "rd_g", "rd_b"}));
  EXPECT_EQ(names("oren_nayar"), (V{"rd_r", "rd_g", "rd_b", "sigma"}));
  EXPECT_EQ(names("phong"), (V{"rd_r", "rd_g", "rd_b", "rs_r", "rs_g", "rs_b", "exponent"}));
  EXPECT_EQ(names("cook_torrance-ggx-smith"),
            (V{"rd_r", "rd_g", "rd_b", "rs_r", "rs_g", "rs_b", "roughness", "ior"}));
  EXPECT_EQ(names("conductor-ggx"),
            (V{"eta_r", "eta_g", "eta_b", "kappa_r", "kappa_g", "kappa_b", "roughness"}));
  EXPECT_EQ(names("conductor-beckmann-schlick"), (V{"f0_r", "f0_g", "f0_b", "roughness"}));
  EXPECT_EQ(names("conductor-ggx-f82"),
            (V{"f0_r", "f0_g", "f0_b", "f82_tint_r", "f82_tint_g", "f82_tint_b", "roughness"}));
  EXPECT_EQ(names("coated-ggx"), (V{"rd_r", "rd_g", "rd_b", "roughness", "ior"}));
  EXPECT_EQ(names("plastic"), (V{"rd_r", "rd_g", "rd_b", "ior"}));
  EXPECT_EQ(names("lafortune-1"),
            (V{"rd_r", "rd_g", "rd_b", "lobe0.rho_r", "lobe0.rho_g", "lobe0.rho_b", "lobe0.cx", "lobe0.cz", "lobe0.n"}));
  const V aniso = names("lafortune-2-aniso");
  ASSERT_EQ(aniso.size(), 3u + 2 * 7u);
  EXPECT_EQ(aniso[10], "lobe1.rho_r");
  EXPECT_EQ(aniso[14], "lobe1.cy");
}

TEST(ModelSpec, ParamInfoIsConsistent) {
  for (const ModelSpec& spec : AllModelSpecs()) {
    const std::vector<ParamInfo> params = spec.Params();
    const std::vector<double> init = spec.InitialParams();
    ASSERT_EQ(spec.NumParams(), static_cast<int>(params.size())) << spec.Label();
    ASSERT_EQ(init.size(), params.size());
    std::set<std::string> names;
    for (size_t i = 0; i < params.size(); ++i) {
      EXPECT_TRUE(names.insert(params[i].name).second) << params[i].name;
      EXPECT_FALSE(params[i].description.empty());
      EXPECT_LT(params[i].lower, params[i].upper);
      EXPECT_GE(init[i], params[i].lower) << spec.Label() << " " << params[i].name;
      EXPECT_LE(init[i], params[i].upper) << spec.Label() << " " << params[i].name;
    }
  }
}

// Exactly the colour amplitudes are marked linear (FitAmplitudes solves them).
TEST(ModelSpec, LinearFlagMarksAmplitudes) {
  for (const ModelSpec& spec : AllModelSpecs())
    for (const ParamInfo& p : spec.Params()) {
      const std::string stem = p.name.substr(p.name.find('.') + 1);  // drop "lobeK."
      const bool amplitude = (stem.rfind("rd_", 0) == 0 && spec.family != Family::kCoated &&
                              spec.family != Family::kPlastic) ||
                             stem.rfind("rs_", 0) == 0 || stem.rfind("rho_", 0) == 0 || stem.rfind("f0_", 0) == 0 ||
                             stem.rfind("base_color_", 0) == 0;
      EXPECT_EQ(p.linear, amplitude) << spec.Label() << " " << p.name;
    }
}

// A colour parameter must act on its own channel only: catches layout slips
// between the names and the evaluation order. Amplitudes increase the value;
// other colour parameters (eta, kappa) only change it.
TEST(ModelSpec, ColourParamsActOnTheirChannel) {
  const Vec3 wi = FromAngles(0.5, 0.3), wo = FromAngles(0.45, 0.3 + kPi);  // near mirror: lobes are lit
  for (const ModelSpec& spec : AllModelSpecs()) {
    if (!HasBrdfPart(spec)) continue;  // the mirror: its F0 acts on MaterialShader::Mirror (relight_test)
    const std::vector<ParamInfo> params = spec.Params();
    const std::vector<double> p0 = spec.InitialParams();
    const Rgb f0 = EvalModelD(spec, p0.data(), wi, wo);
    for (size_t j = 0; j < params.size(); ++j) {
      const std::string& n = params[j].name;
      const char last = n.back();
      if (n.size() < 2 || n[n.size() - 2] != '_') continue;
      const int channel = last == 'r' ? 0 : last == 'g' ? 1 : 2;
      std::vector<double> p = p0;
      p[j] += 0.1;
      const Rgb d = EvalModelD(spec, p.data(), wi, wo) - f0;
      for (int c = 0; c < 3; ++c) {
        if (c == channel && params[j].linear)
          EXPECT_GT(d[c], 0) << spec.Label() << " " << n;
        else if (c == channel)
          EXPECT_NE(d[c], 0) << spec.Label() << " " << n;
        else
          EXPECT_EQ(d[c], 0) << spec.Label() << " " << n;
      }
    }
  }
}

TEST(EvalModel, ZeroBelowHorizon) {
  const Vec3 up(0, 0, 1), below = FromAngles(1.7, 0.2);
  for (const ModelSpec& spec : AllModelSpecs()) {
    const std::vector<double> p = spec.InitialParams();
    EXPECT_TRUE((EvalModelD(spec, p.data(), below, up) == 0).all()) << spec.Label();
    EXPECT_TRUE((EvalModelD(spec, p.data(), up, below) == 0).all()) << spec.Label();
  }
}

// ---------------------------------------------------- reciprocity, positivity

TEST(Properties, ReciprocityAndPositivity) {
  for (const ModelSpec& spec : AllModelSpecs()) {
    if (!IsReciprocal(spec)) continue;
    Rng rng(StreamSeed(1, std::hash<std::string>()(spec.Label())));
    for (int k = 0; k < 1000; ++k) {
      const std::vector<double> p = RandomParams(spec, rng);
      const Vec3 a = RandomDir(rng), b = RandomDir(rng);
      const Rgb fab = EvalModelD(spec, p.data(), a, b), fba = EvalModelD(spec, p.data(), b, a);
      ASSERT_TRUE(fab.allFinite()) << spec.Label();
      ASSERT_TRUE((fab >= 0).all()) << spec.Label();
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(fab[c], fba[c], 1e-10 * (std::abs(fab[c]) + 1e-300)) << spec.Label();
    }
  }
}

TEST(Properties, PhongAndBlinnPhongArePositiveButNotReciprocal) {
  for (const char* label : {"phong", "blinn_phong"}) {
    const ModelSpec spec = ModelSpec::FromLabel(label);
    Rng rng(7);
    int asymmetric = 0;
    for (int k = 0; k < 1000; ++k) {
      const std::vector<double> p = RandomParams(spec, rng);
      const Vec3 a = RandomDir(rng), b = RandomDir(rng);
      const Rgb fab = EvalModelD(spec, p.data(), a, b), fba = EvalModelD(spec, p.data(), b, a);
      ASSERT_TRUE(fab.allFinite() && (fab >= 0).all()) << label;
      if (((fab - fba).abs() > 1e-6 * fab.abs()).any()) ++asymmetric;
    }
    EXPECT_GT(asymmetric, 100) << label;
  }
  // Explicit pair: the specular term differs by the ratio of the cosines.
  const ModelSpec phong = ModelSpec::FromLabel("phong");
  const std::vector<double> p = {0, 0, 0, 1, 1, 1, 10};
  const Vec3 a = FromAngles(0.2, 0), b = FromAngles(1.2, kPi);
  const double ratio = EvalModelD(phong, p.data(), a, b)[0] / EvalModelD(phong, p.data(), b, a)[0];
  EXPECT_NEAR(ratio, b.z() / a.z(), 1e-12);
}

// ------------------------------------------------------- energy conservation

// A Lafortune lobe with |C| > 1 and a large exponent (the armadillo scan's
// fit: Cx -1.5, Cz -0.78, n 33) reflects orders of magnitude more light than
// it receives at grazing incidence; a lobe inside the unit ball does not, and
// the physically based families are never flagged.
TEST(Energy, ExplodingLafortuneLobesAreRecognised) {
  const ModelSpec spec = ModelSpec::FromLabel("lafortune-2");
  const std::vector<ParamInfo> info = spec.Params();
  auto params = [&](double cx, double cz, double n) {
    std::vector<double> p(info.size(), 0.0);
    for (size_t i = 0; i < info.size(); ++i) {
      const std::string& name = info[i].name;
      if (name.rfind("rd_", 0) == 0) p[i] = 0.3;
      else if (name.find("rho") != std::string::npos) p[i] = 0.2;
      else if (name.find(".cx") != std::string::npos) p[i] = cx;
      else if (name.find(".cz") != std::string::npos) p[i] = cz;
      else if (name.find(".n") != std::string::npos) p[i] = n;
    }
    return p;
  };
  double albedo = 0;
  EXPECT_TRUE(ReflectsMoreThanItReceives(spec, params(-1.5, -0.78, 33), &albedo));
  EXPECT_GT(albedo, 100);
  EXPECT_FALSE(ReflectsMoreThanItReceives(spec, params(-0.9, 0.9, 20), &albedo));
  EXPECT_LT(albedo, 1.0);
  const ModelSpec ct = ModelSpec::FromLabel("cook_torrance-ggx");
  EXPECT_FALSE(ReflectsMoreThanItReceives(ct, ct.InitialParams()));
}

TEST(Energy, AlbedoAtMostOne) {
  const double thetas[] = {0.0, 0.5, 1.0, 1.3, 1.5, 1.56};  // up to ~89.4 deg
  for (const ModelSpec& spec : AllModelSpecs()) {
    if (!ConservesEnergy(spec) || !HasBrdfPart(spec)) continue;
    Rng rng(StreamSeed(2, std::hash<std::string>()(spec.Label())));
    for (int k = 0; k < 3; ++k) {
      std::vector<double> p = RandomParams(spec, rng);
      MakeEnergyConserving(spec, &p);
      for (double theta : thetas) {
        const Rgb a = Albedo(spec, p, FromAngles(theta, 0.7));
        EXPECT_LE(a.maxCoeff(), 1 + 2e-3) << spec.Label() << " theta " << theta << " params k=" << k;
      }
    }
  }
}

// The bound above is tight: these configurations reflect all light.
TEST(Energy, TightCases) {
  const Vec3 normal(0, 0, 1);
  const std::vector<double> white = {1, 1, 1};
  EXPECT_NEAR(Albedo(ModelSpec::FromLabel("lambert"), white, FromAngles(1.2, 0))[0], 1, 1e-4);
  EXPECT_NEAR(Albedo(ModelSpec::FromLabel("oren_nayar"), {1, 1, 1, 0.0}, FromAngles(1.2, 0))[0], 1, 1e-4);
  // Lewis: albedo at normal incidence is exactly rs.
  EXPECT_NEAR(Albedo(ModelSpec::FromLabel("cosine_lobe"), {0, 0, 0, 1, 1, 1, 500}, normal)[0], 1, 1e-3);
}

// White furnace: with F = 1 and rs = 1, a smooth normalised microfacet lobe at
// normal incidence reflects almost everything. What is lost is shadowing and
// the reflections of steep facets (theta_h > 45 deg) sent below the horizon,
// about m^2 / (1 + m^2) for GGX's long tail.
TEST(Energy, MicrofacetWhiteFurnace) {
  for (const char* label : {"cook_torrance-ggx-smith-nofresnel", "cook_torrance-ggx-nofresnel",
                            "cook_torrance-beckmann-smith-nofresnel", "cook_torrance-beckmann-nofresnel",
                            "cook_torrance-blinn-nofresnel"}) {
    const std::vector<double> p = {0, 0, 0, 1, 1, 1, 0.05, 1.5};
    const double albedo = Albedo(ModelSpec::FromLabel(label), p, Vec3(0, 0, 1))[0];
    EXPECT_LE(albedo, 1 + 1e-3) << label;  // midpoint-rule error on the narrow lobe is ~3e-4
    EXPECT_GE(albedo, 0.99) << label;
  }
}

// The lecture's (qualitative) Oren-Nayar model reflects slightly more than it
// receives at grazing incidence: albedo -> rd (A + B/2), up to 1.0152 rd.
TEST(Energy, OrenNayarSlightlyExceedsOneAtGrazingIncidence) {
  const double sigma = 0.2, s2 = sigma * sigma;
  const double a = 1 - 0.5 * s2 / (s2 + 0.33), b = 0.45 * s2 / (s2 + 0.09);
  const double albedo = Albedo(ModelSpec::FromLabel("oren_nayar"), {1, 1, 1, sigma}, FromAngles(1.5695, 0))[0];
  EXPECT_GT(albedo, 1.01);
  EXPECT_NEAR(albedo, a + b / 2, 2e-3);
  EXPECT_LE(kOrenNayarMaxRd * (a + b / 2), 1.0);
}

TEST(Energy, PhongExceedsOneAtGrazingIncidence) {
  const Vec3 grazing = FromAngles(89.0 * kPi / 180, 0);
  for (const char* label : {"phong", "blinn_phong"}) {
    const std::vector<double> p = {0, 0, 0, 0.5, 0.5, 0.5, 10};
    EXPECT_GT(Albedo(ModelSpec::FromLabel(label), p, grazing)[0], 1.5) << label;
  }
}

// ---------------------------------------------------------- special cases

TEST(SpecialCases, LafortuneGeneralisesLewisCosineLobe) {
  const ModelSpec lewis = ModelSpec::FromLabel("cosine_lobe"), laf = ModelSpec::FromLabel("lafortune-1");
  Rng rng(3);
  for (double m : {0.5, 1.0, 7.0, 20.0, 300.0}) {
    const double c = std::pow((m + 2) / (2 * kPi), 1 / m);
    const std::vector<double> pl = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, m};
    const std::vector<double> pf = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, -c, c, m};  // rd, rho, cx = cy, cz, n
    for (int k = 0; k < 200; ++k) {
      const Vec3 a = RandomDir(rng), b = RandomDir(rng);
      const Rgb fl = EvalModelD(lewis, pl.data(), a, b), ff = EvalModelD(laf, pf.data(), a, b);
      for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(fl[ch], ff[ch], 1e-12 * fl[ch]) << "m=" << m;
    }
  }
}

TEST(SpecialCases, OrenNayarWithSmoothFacetsIsLambert) {
  const std::vector<double> on = {0.2, 0.5, 0.8, 0.0}, lam = {0.2, 0.5, 0.8};
  Rng rng(4);
  for (int k = 0; k < 100; ++k) {
    const Vec3 a = RandomDir(rng), b = RandomDir(rng);
    EXPECT_TRUE(EvalModelD(ModelSpec::FromLabel("oren_nayar"), on.data(), a, b)
                    .isApprox(EvalModelD(ModelSpec::FromLabel("lambert"), lam.data(), a, b), 1e-14));
  }
}

// -------------------------------------------------------------------- optics

TEST(Optics, ReflectionIsHouseholder) {
  Rng rng(5);
  for (int k = 0; k < 100; ++k) {
    const Vec3 n = Vec3::Random().normalized();
    const Vec3 l = 3.0 * Vec3::Random();
    const Vec3 r = brdf::Reflect(l, n);
    EXPECT_NEAR(r.norm(), l.norm(), 1e-12);
    EXPECT_NEAR(Dot(r, n), Dot(l, n), 1e-12);
    EXPECT_NEAR((r + l).cross(n).norm(), 0, 1e-12);        // R + L along N
    EXPECT_NEAR(l.cross(n).dot(r), 0, 1e-12);              // coplanar with L, N
    EXPECT_TRUE(brdf::Reflect(r, n).isApprox(l, 1e-12));  // involution
    EXPECT_TRUE(r.isApprox((2 * n * n.transpose() - Mat3::Identity()) * l, 1e-12));
  }
  const Vec3 l = RandomDir(rng);
  EXPECT_TRUE(brdf::ReflectLocal(l).isApprox(brdf::Reflect(l, Vec3(0, 0, 1)), 1e-15));
}

TEST(Optics, SnellAndTotalInternalReflection) {
  const Vec3 n(0, 0, 1);
  for (double n1 : {1.0, 1.33, 1.5, 2.4}) {
    for (double n2 : {1.0, 1.33, 1.5, 2.4}) {
      const double critical = n1 > n2 ? std::asin(n2 / n1) : kPi / 2;
      for (double theta = 0; theta < kPi / 2; theta += 0.01) {
        const Vec3 l = FromAngles(theta, 0.4);
        Vec3 t;
        const bool ok = brdf::Refract(l, n, n1, n2, &t);
        if (std::abs(theta - critical) < 1e-9) continue;
        ASSERT_EQ(ok, theta < critical) << n1 << " " << n2 << " " << theta;
        if (!ok) continue;
        EXPECT_NEAR(t.norm(), 1, 1e-12);
        EXPECT_LT(t.z(), 0);  // into the far medium
        const double sin_t = std::sqrt(t.x() * t.x() + t.y() * t.y());
        EXPECT_NEAR(n1 * std::sin(theta), n2 * sin_t, 1e-12);
        EXPECT_NEAR(t.cross(l).dot(n), 0, 1e-12);  // in the plane of incidence
      }
    }
  }
}

// Unpolarised reflectance from Snell and the s/p amplitudes, the reference
// for the closed form.
double FresnelFromAmplitudes(double cos_i, double n_i, double n_t) {
  const Vec3 l = FromAngles(std::acos(cos_i), 0);
  Vec3 t;
  if (!brdf::Refract(l, Vec3(0, 0, 1), n_i, n_t, &t)) return 1;
  const auto r = brdf::FresnelReflectedAmplitudes(cos_i, -t.z(), n_i, n_t);
  return 0.5 * (r.r_perp * r.r_perp + r.r_par * r.r_par);
}

TEST(Fresnel, NormalIncidence) {
  for (double n : {1.05, 1.33, 1.5, 2.0, 3.0, 0.7}) {
    const double f0 = std::pow((n - 1) / (n + 1), 2);
    EXPECT_NEAR(brdf::FresnelDielectric(1.0, n), f0, 1e-14) << n;
    EXPECT_NEAR(brdf::FresnelSchlick(1.0, n), f0, 1e-14) << n;
    EXPECT_NEAR(FresnelFromAmplitudes(1.0, 1.0, n), f0, 1e-14) << n;
  }
}

TEST(Fresnel, TotalInternalReflectionInsideDenseMedium) {
  for (double n : {1 / 1.5, 1 / 1.33, 1 / 2.4}) {
    const double cos_critical = std::sqrt(1 - n * n);
    for (double c = 0.001; c < cos_critical; c += 0.01) EXPECT_EQ(brdf::FresnelDielectric(c, n), 1.0);
    EXPECT_LT(brdf::FresnelDielectric(cos_critical + 0.05, n), 1.0);
  }
}

TEST(Fresnel, ClosedFormMatchesAmplitudes) {
  for (double n : {1.05, 1.33, 1.5, 2.4, 3.0, 1 / 1.5, 1 / 1.33}) {
    for (double c = 0.001; c <= 1.0; c += 0.0049) {
      EXPECT_NEAR(brdf::FresnelDielectric(c, n), FresnelFromAmplitudes(c, 1.0, n), 1e-12) << "n=" << n << " c=" << c;
    }
  }
}

// The lecture's (c(g+c)+1)^2 in the last denominator does not match the
// amplitudes, confirming it is a typo for (c(g-c)+1)^2.
TEST(Fresnel, LectureDenominatorIsATypo) {
  const double n = 1.5, c = 0.2;
  const double g = std::sqrt(n * n + c * c - 1);
  const double lecture =
      (g - c) * (g - c) / (2 * (g + c) * (g + c)) * (1 + std::pow(c * (g + c) - 1, 2) / std::pow(c * (g + c) + 1, 2));
  EXPECT_GT(std::abs(lecture - FresnelFromAmplitudes(c, 1.0, n)), 1e-2);
}

TEST(Fresnel, SchlickCloseToExactNearNormal) {
  for (double n : {1.33, 1.5, 2.0}) {
    for (double c = 0.8; c <= 1.0; c += 0.01)
      EXPECT_NEAR(brdf::FresnelSchlick(c, n), brdf::FresnelDielectric(c, n), 0.01) << n << " " << c;
    EXPECT_NEAR(brdf::FresnelSchlick(0.0, n), 1.0, 1e-14);  // both reach 1 at grazing
    EXPECT_NEAR(brdf::FresnelDielectric(0.0, n), 1.0, 1e-14);
  }
}

// ---------------------------------------------------------------- conductors

// |r_s|^2, |r_p|^2 with complex arithmetic: the independent reference for the
// real-arithmetic closed form.
double ConductorFresnelComplex(double c, double eta, double kappa) {
  const std::complex<double> n(eta, kappa), n2 = n * n;
  const std::complex<double> w = std::sqrt(n2 - (1 - c * c));  // n cos(theta_t)
  const std::complex<double> rs = (c - w) / (c + w), rp = (n2 * c - w) / (n2 * c + w);
  return 0.5 * (std::norm(rs) + std::norm(rp));
}

TEST(Conductor, FresnelMatchesComplexAmplitudes) {
  for (const auto& [eta, kappa] : std::vector<std::pair<double, double>>{
           {0.14, 3.697}, {1.5724, 7.7354}, {1.38, 1.914}, {0.02, 10.0}, {6.0, 0.0}, {1.5, 0.0}, {3.0, 3.3}}) {
    for (double c = 0.0; c <= 1.0; c += 0.0049)
      EXPECT_NEAR(brdf::FresnelConductor(c, eta, kappa), ConductorFresnelComplex(c, eta, kappa), 1e-12)
          << eta << "+" << kappa << "i, c=" << c;
    if (kappa == 0) {  // a dielectric
      for (double c = 0.01; c <= 1.0; c += 0.01)
        EXPECT_NEAR(brdf::FresnelConductor(c, eta, kappa), brdf::FresnelDielectric(c, eta), 1e-12);
    }
  }
}

// Published optical constants (brdf/metals.h: Johnson & Christy 1972 for gold
// and copper, Rakic 1995 for aluminium, as tabulated at refractiveindex.info).
// Normal incidence must give ((n-1)^2 + k^2) / ((n+1)^2 + k^2), whose values
// (computed by hand from the tables) are listed here; grazing incidence gives 1.
TEST(Conductor, PublishedMetalsAtNormalAndGrazingIncidence) {
  const std::map<std::string, Rgb> expected_f0 = {{"gold", Rgb(0.9626, 0.7869, 0.4082)},
                                                  {"copper", Rgb(0.9433, 0.6195, 0.5392)},
                                                  {"aluminium", Rgb(0.9054, 0.9147, 0.9226)}};
  ASSERT_EQ(brdf::PublishedMetals().size(), expected_f0.size());
  for (const brdf::MetalConstants& m : brdf::PublishedMetals()) {
    for (int c = 0; c < 3; ++c) {
      const double n = m.eta[c], k = m.kappa[c];
      const double f0 = ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
      EXPECT_NEAR(brdf::FresnelConductor(1.0, n, k), f0, 1e-14) << m.name << " " << c;
      EXPECT_NEAR(brdf::ConductorF0(n, k), f0, 1e-14) << m.name;
      EXPECT_NEAR(f0, expected_f0.at(m.name)[c], 5e-5) << m.name << " " << c;
      EXPECT_NEAR(brdf::FresnelConductor(0.0, n, k), 1.0, 1e-14) << m.name;
      EXPECT_GT(brdf::FresnelConductor(1e-4, n, k), 0.999) << m.name;
      EXPECT_NEAR(brdf::FresnelConductor(1.0, n, k), ConductorFresnelComplex(1.0, n, k), 1e-14);
    }
  }
  // Colours: gold and copper reflect red best and blue least; aluminium is
  // almost neutral and above 0.9 everywhere.
  const brdf::MetalConstants& gold = *brdf::FindMetal("gold");
  EXPECT_GT(brdf::ConductorF0(gold.eta[0], gold.kappa[0]), brdf::ConductorF0(gold.eta[1], gold.kappa[1]));
  EXPECT_GT(brdf::ConductorF0(gold.eta[1], gold.kappa[1]), brdf::ConductorF0(gold.eta[2], gold.kappa[2]));
  EXPECT_EQ(brdf::FindMetal("silver"), nullptr);
}

TEST(Conductor, KappaFromF0InvertsF0) {
  for (double eta : {0.05, 0.3, 1.0, 2.0})
    for (double f0 : {0.3, 0.6, 0.9, 0.99}) {
      const double kappa = brdf::ConductorKappaFromF0(f0, eta);
      if (f0 < std::pow((eta - 1) / (eta + 1), 2)) continue;
      EXPECT_NEAR(brdf::ConductorF0(eta, kappa), f0, 1e-12) << eta << " " << f0;
    }
  EXPECT_EQ(brdf::ConductorKappaFromF0(0.01, 2.0), 0.0);  // below the dielectric value: kappa 0
}

// F82-tint form: Schlick at tint 1, the prescribed dip at 82 deg, f0 and 1 at
// the ends, and with the tint of a real metal close to its exact curve.
TEST(Conductor, F82TintForm) {
  const double mu = 1.0 / 7.0;
  for (double f0 : {0.0, 0.4, 0.9, 1.0})
    for (double tint : {0.0, 0.5, 0.9, 1.0}) {
      EXPECT_NEAR(brdf::FresnelF82Tint(1.0, f0, tint), f0, 1e-14);
      EXPECT_NEAR(brdf::FresnelF82Tint(0.0, f0, tint), 1.0, 1e-14);
      EXPECT_NEAR(brdf::FresnelF82Tint(mu, f0, tint), std::max(tint * brdf::FresnelSchlickF0(mu, f0), 0.0), 1e-12);
      for (double c = 0; c <= 1; c += 0.01) {
        const double f = brdf::FresnelF82Tint(c, f0, tint);
        EXPECT_GE(f, 0.0);
        EXPECT_LE(f, 1.0 + 1e-15);
        if (tint == 1.0) {
          EXPECT_NEAR(f, brdf::FresnelSchlickF0(c, f0), 1e-14);
        }
      }
    }
  for (const brdf::MetalConstants& m : brdf::PublishedMetals())
    for (int ch = 0; ch < 3; ++ch) {
      const double f0 = brdf::ConductorF0(m.eta[ch], m.kappa[ch]);
      const double tint = brdf::ConductorF82Tint(m.eta[ch], m.kappa[ch]);
      EXPECT_GT(tint, 0.8) << m.name;
      EXPECT_LE(tint, 1.0) << m.name;
      double worst_f82 = 0, worst_schlick = 0;
      for (double c = 0; c <= 1; c += 0.005) {
        const double exact = brdf::FresnelConductor(c, m.eta[ch], m.kappa[ch]);
        worst_f82 = std::max(worst_f82, std::abs(brdf::FresnelF82Tint(c, f0, tint) - exact));
        worst_schlick = std::max(worst_schlick, std::abs(brdf::FresnelSchlickF0(c, f0) - exact));
      }
      EXPECT_LT(worst_f82, kF82MaxError) << m.name << " " << ch;
      EXPECT_LE(worst_f82, worst_schlick + 1e-12) << m.name << " " << ch;
    }
}

// ---------------------------------------------------------- coated dielectric

TEST(Coated, DiffuseFresnelReflectanceClosedForm) {
  for (double n : {1.1, 1.33, 1.5, 2.0, 2.5}) {
    const int steps = 200000;
    double ext = 0, in = 0;
    for (int i = 0; i < steps; ++i) {
      const double mu = (i + 0.5) / steps;
      ext += 2 * mu * brdf::FresnelDielectric(mu, n) / steps;
      in += 2 * mu * brdf::FresnelDielectric(mu, 1 / n) / steps;  // from inside, with total internal reflection
    }
    EXPECT_NEAR(brdf::DielectricDiffuseReflectance(n), ext, 1e-9) << n;
    EXPECT_NEAR(brdf::DielectricInternalDiffuseReflectance(n), in, 1e-5) << n;  // kink at the critical angle
  }
}

// A white base under a nearly smooth coat reflects almost everything: the
// coat F(theta) and, through it, the base. What is missing is what a
// single-scattering microfacet interface loses to masking (the coat's lobe,
// and light refracted into a facet that a neighbour then blocks, on the way
// in and out), more with GGX's long tail, and what Mitsuba's average of the
// internal reflectance (which the model follows, rough_coat.h) leaves out
// (about 1/64 of it): 4-5 % at GGX 0.05.
TEST(Coated, WhiteBaseUnderSmoothCoatReflectsAll) {
  for (const char* label : {"coated-ggx", "coated-beckmann"}) {
    const ModelSpec spec = ModelSpec::FromLabel(label);
    for (double theta : {0.0, 0.6, 1.1}) {
      const double albedo = Albedo(spec, {1, 1, 1, 0.05, 1.5}, FromAngles(theta, 0.3))[0];
      EXPECT_LE(albedo, 1 + 2e-3) << label << " " << theta;
      EXPECT_GE(albedo, 0.95) << label << " " << theta;
    }
    // A black base leaves the coat's reflection only: about F0 = 0.04 at normal incidence.
    EXPECT_NEAR(Albedo(spec, {0, 0, 0, 0.05, 1.5}, Vec3(0, 0, 1))[0], 0.04, 1e-3) << label;
  }
}

// Smooth plastic (plastic.h) against its closed form: at normal incidence
// rd (1 - F0)^2 / (pi n^2 (1 - rd F_int)); towards grazing light it falls
// with 1 - F; a white base reflects, with the coat's mirror reflection F
// (left out of f), all light: albedo + F(mu) = 1 when nothing is absorbed.
TEST(Plastic, ClosedFormAndWhiteFurnace) {
  const ModelSpec spec = ModelSpec::FromLabel("plastic");
  const double n = 1.5, f0 = 0.04, f_int = brdf::DielectricInternalDiffuseReflectance(n);
  EXPECT_NEAR(f_int, 0.5963, 1e-3);  // 1 - (1 - 0.0918) / 2.25
  const Rgb f = EvalModelD(spec, std::vector<double>{0.8, 0.4, 0.0, n}.data(), Vec3(0, 0, 1), Vec3(0, 0, 1));
  EXPECT_NEAR(f[0], 0.8 * (1 - f0) * (1 - f0) / (kPi * n * n * (1 - 0.8 * f_int)), 1e-12);
  EXPECT_NEAR(f[1], 0.4 * (1 - f0) * (1 - f0) / (kPi * n * n * (1 - 0.4 * f_int)), 1e-12);
  EXPECT_EQ(f[2], 0.0);
  const Vec3 grazing = FromAngles(1.4, 0.0);
  const Rgb g = EvalModelD(spec, std::vector<double>{0.8, 0.8, 0.8, n}.data(), grazing, Vec3(0, 0, 1));
  EXPECT_NEAR(g[0] / f[0], (1 - brdf::FresnelDielectric(grazing.z(), n)) / (1 - f0), 1e-12);
  for (double theta : {0.0, 0.7, 1.2}) {
    const Vec3 wi = FromAngles(theta, 0.3);
    const double albedo = Albedo(spec, {1, 1, 1, n}, wi)[0];
    EXPECT_NEAR(albedo + brdf::FresnelDielectric(wi.z(), n), 1.0, 2e-3) << theta;
  }
}

// The mirror has no BRDF part, whatever its F0 and directions.
TEST(Mirror, HasNoBrdfPart) {
  const ModelSpec spec = ModelSpec::FromLabel("mirror");
  EXPECT_EQ(spec.NumParams(), 3);
  const Vec3 wi = FromAngles(0.4, 0.0);
  for (const Vec3& wo : {brdf::ReflectLocal(wi), Vec3(0, 0, 1), FromAngles(1.2, 2.0)})
    EXPECT_TRUE(EvalModelD(spec, std::vector<double>{0.9, 0.6, 0.3}.data(), wi, wo).isZero());
}

// A white-furnace conductor (f0 = 1) reflects all light at normal incidence
// up to shadowing; gold reflects its F0 per channel.
TEST(Conductor, AlbedoIsF0AtNormalIncidence) {
  for (const char* label : {"conductor-ggx-schlick", "conductor-beckmann-schlick"}) {
    const double a = Albedo(ModelSpec::FromLabel(label), {1, 1, 1, 0.05}, Vec3(0, 0, 1))[0];
    EXPECT_LE(a, 1 + 1e-3) << label;
    EXPECT_GE(a, 0.99) << label;
  }
  const brdf::MetalConstants& gold = *brdf::FindMetal("gold");
  const std::vector<double> p = {gold.eta[0],   gold.eta[1],   gold.eta[2], gold.kappa[0],
                                 gold.kappa[1], gold.kappa[2], 0.05};
  const Rgb a = Albedo(ModelSpec::FromLabel("conductor-ggx"), p, Vec3(0, 0, 1));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], brdf::ConductorF0(gold.eta[c], gold.kappa[c]), 0.01) << c;
}

// ------------------------------------------------------------------ autodiff

constexpr int kJetSize = 32;
using Jet = ceres::Jet<double, kJetSize>;

// Evaluates with Jets seeded on every parameter; returns value and gradients.
void EvalJet(const ModelSpec& spec, const std::vector<double>& p, const Vec3& wi, const Vec3& wo, Jet out[3]) {
  std::vector<Jet> pj;
  for (size_t j = 0; j < p.size(); ++j) pj.emplace_back(p[j], static_cast<int>(j));
  const Vec3T<Jet> wij(Jet(wi.x()), Jet(wi.y()), Jet(wi.z()));
  const Vec3T<Jet> woj(Jet(wo.x()), Jet(wo.y()), Jet(wo.z()));
  EvalModel<Jet>(spec, pj.data(), wij, woj, out);
}

TEST(Autodiff, MatchesCentralDifferences) {
  for (const ModelSpec& spec : AllModelSpecs()) {
    if (!HasBrdfPart(spec)) continue;
    ASSERT_LE(spec.NumParams(), kJetSize);
    Rng rng(StreamSeed(6, std::hash<std::string>()(spec.Label())));
    int checks = 0, nonzero = 0;  // guards against a vacuous comparison of zeros
    for (int k = 0; k < 40; ++k) {
      std::vector<double> p = RandomParams(spec, rng);
      const Vec3 wi = RandomDir(rng);
      Vec3 wo = RandomDir(rng);
      if (k % 2 == 0) {  // near the mirror direction, with forward Lafortune lobes, so lobes are lit
        do wo = (brdf::ReflectLocal(wi) + 0.15 * Vec3::Random()).normalized();
        while (wo.z() < 0.02);
        const std::vector<ParamInfo> params = spec.Params();
        for (size_t j = 0; j < p.size(); ++j) {
          const std::string& n = params[j].name;
          if (n.size() > 3 && (n.substr(n.size() - 3) == ".cx" || n.substr(n.size() - 3) == ".cy")) p[j] = -std::abs(p[j]);
          if (n.size() > 3 && n.substr(n.size() - 3) == ".cz") p[j] = std::abs(p[j]);
        }
      }
      Jet f[3];
      EvalJet(spec, p, wi, wo, f);
      for (size_t j = 0; j < p.size(); ++j) {
        const double h = 1e-6 * std::max(std::abs(p[j]), 1e-2);
        std::vector<double> pp = p, pm = p;
        pp[j] += h;
        pm[j] -= h;
        const Rgb fd = (EvalModelD(spec, pp.data(), wi, wo) - EvalModelD(spec, pm.data(), wi, wo)) / (2 * h);
        ++checks;
        nonzero += (fd != 0).any();
        for (int c = 0; c < 3; ++c) {
          const double ad = f[c].v[j];
          ASSERT_TRUE(std::isfinite(ad)) << spec.Label();
          // Relative tolerance plus the rounding error of the difference quotient.
          const double tol = 1e-5 * std::max(std::abs(ad), std::abs(fd[c])) + 1e-12 * std::abs(f[c].a) / h;
          EXPECT_NEAR(ad, fd[c], tol) << spec.Label() << " param " << spec.Params()[j].name << " k=" << k;
        }
      }
    }
    EXPECT_GT(nonzero, checks / 3) << spec.Label();
  }
}

// ---------------------------------------------------------------- principled

// Values of Mitsuba 3.9.1's `principled` plugin (scalar_rgb; bsdf.eval / cos
// of wo), for the principled materials of four benchmark scenes
// (scripts/mitsuba_scenes.py seeds 7, 8, 9, 16): coats, metals, a rough
// dielectric, directions from near-normal to grazing mirror. Mitsuba
// computes in float: 1e-4 relative, except where H = N for a glossy coat:
// there GTR1's denominator 1 + (a^2 - 1) <N|H>^2 cancels to a^2 (1e-6 at
// gloss 1), which float holds to about 1 % (checked against Mitsuba at
// several glosses); ours is computed in double.
TEST(Principled, MatchesMitsubasPrincipledPlugin) {
  struct Case {
    bool coat;
    std::vector<double> p;  // base_color rgb, metallic, specular, roughness[, clearcoat, clearcoat_gloss]
    Vec3 wi, wo;
    Rgb mitsuba;
  };
  const std::vector<Case> cases = {
      {true, {0.7821, 0.0421, 0.3829, 0.9154, 0.5364, 0.1456, 0.8645, 0.9883}, Vec3(0.28962947762551555, 0.058710801693826517, 0.95533648912560598), Vec3(-0.33606268070212919, -0.068123277938268292, 0.93937271284737889), Rgb(25.2358955, 1.81342254, 12.6004189)},
      {true, {0.7821, 0.0421, 0.3829, 0.9154, 0.5364, 0.1456, 0.8645, 0.9883}, Vec3(0, 0, 1), Vec3(0, 0, 1), Rgb(175.645752, 55.6794434, 110.92878)},
      {true, {0.7821, 0.0421, 0.3829, 0.9154, 0.5364, 0.1456, 0.8645, 0.9883}, Vec3(0.92738277273931413, 0.093048646400494983, 0.36235775447667362), Vec3(-0.16205521124517713, 0.3540970966199784, 0.9210609940028851), Rgb(0.0217224583, 0.00177947868, 0.0109640288)},
      {true, {0.7821, 0.0421, 0.3829, 0.9154, 0.5364, 0.1456, 0.8645, 0.9883}, Vec3(0.64421768723769102, 0, 0.7648421872844885), Vec3(-0.95391537360096179, 0.1359773388922253, 0.26749882862458735), Rgb(0.0354815714, 0.0050718052, 0.0190767346)},
      {true, {0.7821, 0.0421, 0.3829, 0.9154, 0.5364, 0.1456, 0.8645, 0.9883}, Vec3(0.99271299103758848, 0, 0.12050276936736662), Vec3(-0.99271299103758848, 1.2157227869461778e-16, 0.12050276936736662), Rgb(10620.5974, 6765.66401, 8541.01789)},
      {false, {0.2315, 0.3894, 0.4388, 0, 0.5981, 0.7969}, Vec3(0.28962947762551555, 0.058710801693826517, 0.95533648912560598), Vec3(-0.33606268070212919, -0.068123277938268292, 0.93937271284737889), Rgb(0.0840003919, 0.13426157, 0.149986099)},
      {false, {0.2315, 0.3894, 0.4388, 0, 0.5981, 0.7969}, Vec3(0, 0, 1), Vec3(0, 0, 1), Rgb(0.0831301883, 0.133391321, 0.149115831)},
      {false, {0.2315, 0.3894, 0.4388, 0, 0.5981, 0.7969}, Vec3(0.92738277273931413, 0.093048646400494983, 0.36235775447667362), Vec3(-0.16205521124517713, 0.3540970966199784, 0.9210609940028851), Rgb(0.0870256173, 0.139773521, 0.156276055)},
      {false, {0.2315, 0.3894, 0.4388, 0, 0.5981, 0.7969}, Vec3(0.64421768723769102, 0, 0.7648421872844885), Vec3(-0.95391537360096179, 0.1359773388922253, 0.26749882862458735), Rgb(0.10732522, 0.157269661, 0.172895101)},
      {false, {0.2315, 0.3894, 0.4388, 0, 0.5981, 0.7969}, Vec3(0.99271299103758848, 0, 0.12050276936736662), Vec3(-0.99271299103758848, 1.2157227869461778e-16, 0.12050276936736662), Rgb(0.746788537, 0.774990037, 0.783813053)},
      {true, {0.3294, 0.1088, 0.4175, 1, 0.3172, 0.28, 0.3551, 0.8697}, Vec3(0.28962947762551555, 0.058710801693826517, 0.95533648912560598), Vec3(-0.33606268070212919, -0.068123277938268292, 0.93937271284737889), Rgb(4.07961165, 1.45531677, 5.12766408)},
      {true, {0.3294, 0.1088, 0.4175, 1, 0.3172, 0.28, 0.3551, 0.8697}, Vec3(0, 0, 1), Vec3(0, 0, 1), Rgb(4.94870377, 2.09266901, 6.08930492)},
      {true, {0.3294, 0.1088, 0.4175, 1, 0.3172, 0.28, 0.3551, 0.8697}, Vec3(0.92738277273931413, 0.093048646400494983, 0.36235775447667362), Vec3(-0.16205521124517713, 0.3540970966199784, 0.9210609940028851), Rgb(0.0048475947, 0.00185853121, 0.00604132253)},
      {true, {0.3294, 0.1088, 0.4175, 1, 0.3172, 0.28, 0.3551, 0.8697}, Vec3(0.64421768723769102, 0, 0.7648421872844885), Vec3(-0.95391537360096179, 0.1359773388922253, 0.26749882862458735), Rgb(0.078121309, 0.0299100202, 0.0973752394)},
      {true, {0.3294, 0.1088, 0.4175, 1, 0.3172, 0.28, 0.3551, 0.8697}, Vec3(0.99271299103758848, 0, 0.12050276936736662), Vec3(-0.99271299103758848, 1.2157227869461778e-16, 0.12050276936736662), Rgb(510.586064, 432.900796, 541.61087)},
      {true, {0.594, 0.8157, 0.8375, 0.155, 0.697, 0.2145, 0.4224, 0.969}, Vec3(0.28962947762551555, 0.058710801693826517, 0.95533648912560598), Vec3(-0.33606268070212919, -0.068123277938268292, 0.93937271284737889), Rgb(3.83282857, 4.75126143, 4.84157175)},
      {true, {0.594, 0.8157, 0.8375, 0.155, 0.697, 0.2145, 0.4224, 0.969}, Vec3(0, 0, 1), Vec3(0, 0, 1), Rgb(12.7625618, 14.1139431, 14.2468243)},
      {true, {0.594, 0.8157, 0.8375, 0.155, 0.697, 0.2145, 0.4224, 0.969}, Vec3(0.92738277273931413, 0.093048646400494983, 0.36235775447667362), Vec3(-0.16205521124517713, 0.3540970966199784, 0.9210609940028851), Rgb(0.156779247, 0.215071625, 0.220803582)},
      {true, {0.594, 0.8157, 0.8375, 0.155, 0.697, 0.2145, 0.4224, 0.969}, Vec3(0.64421768723769102, 0, 0.7648421872844885), Vec3(-0.95391537360096179, 0.1359773388922253, 0.26749882862458735), Rgb(0.163254912, 0.220992903, 0.22667034)},
      {true, {0.594, 0.8157, 0.8375, 0.155, 0.697, 0.2145, 0.4224, 0.969}, Vec3(0.99271299103758848, 0, 0.12050276936736662), Vec3(-0.99271299103758848, 1.2157227869461778e-16, 0.12050276936736662), Rgb(1412.09971, 1451.49789, 1455.37201)},
  };
  for (const Case& c : cases) {
    const ModelSpec spec = ModelSpec::FromLabel(c.coat ? "principled-clearcoat" : "principled");
    ASSERT_EQ(spec.NumParams(), int(c.p.size()));
    const Rgb f = EvalModelD(spec, c.p.data(), c.wi, c.wo);
    const bool peak = c.coat && (c.wi + c.wo).normalized().z() > 1 - 1e-9;
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(f[k], c.mitsuba[k], (peak ? 1e-2 : 1e-4) * c.mitsuba[k] + 1e-7)
          << spec.Label() << " wi " << c.wi.transpose();
  }
}

// At normal incidence (H = N, no Schlick weights) the lobes reduce to
// F0 / (4 pi alpha^2) + base / pi for a dielectric without a coat, with
// F0 = ((eta - 1) / (eta + 1))^2 and eta 1.5 at specular 0.5.
TEST(Principled, NormalIncidenceClosedForm) {
  const ModelSpec spec = ModelSpec::FromLabel("principled");
  const std::vector<double> p = {0.3, 0.5, 0.7, 0.0, 0.5, 0.4};
  const Vec3 n(0, 0, 1);
  const Rgb f = EvalModelD(spec, p.data(), n, n);
  EXPECT_NEAR(brdf::PrincipledEta(0.5), 1.5, 1e-12);
  const double alpha = 0.4 * 0.4, f0 = 0.04;
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(f[k], f0 / (4 * kPi * alpha * alpha) + p[k] / kPi, 1e-12);
  // A metal: F = base, no diffuse.
  const std::vector<double> metal = {0.9, 0.6, 0.3, 1.0, 0.5, 0.4};
  const Rgb fm = EvalModelD(spec, metal.data(), n, n);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(fm[k], metal[k] / (4 * kPi * alpha * alpha), 1e-12);
}

// Burley's diffuse is not energy conserving: white, rough, without a
// specular lobe it reflects up to ~1.4 of grazing light (its retro-
// reflection: R = 2 r <L|H>^2 reaches 2); smooth it stays below 1. The bound guards the formulas
// against slips that would make it grow further (a missing 1/2, a c^2 -> c).
TEST(Principled, AlbedoStaysNearOne) {
  const ModelSpec spec = ModelSpec::FromLabel("principled-clearcoat");
  double worst_rough = 0, worst_smooth = 0;
  for (const double incident : {0.0, 0.8, 1.2, 1.48}) {
    const Vec3 wi(std::sin(incident), 0, std::cos(incident));
    const std::vector<double> rough = {1, 1, 1, 0.0, 0.0, 1.0, 0.0, 0.5};
    const std::vector<double> smooth = {1, 1, 1, 0.0, 0.0, 0.2, 0.0, 0.5};
    worst_rough = std::max(worst_rough, Albedo(spec, rough, wi).maxCoeff());
    worst_smooth = std::max(worst_smooth, Albedo(spec, smooth, wi).maxCoeff());
  }
  EXPECT_GT(worst_rough, 1.0);
  EXPECT_LT(worst_rough, 1.45);
  EXPECT_LT(worst_smooth, 1.0);
  // A full metal with a full coat: the coat adds a little to F <= 1.
  const std::vector<double> metal = {1, 1, 1, 1.0, 0.5, 0.3, 1.0, 0.5};
  for (const double incident : {0.0, 0.8, 1.2})
    EXPECT_LT(Albedo(spec, metal, Vec3(std::sin(incident), 0, std::cos(incident))).maxCoeff(), 1.1);
}

// sqrt and pow at 0 have infinite derivatives; the models must not turn them
// into NaN at the normal, where sin(theta) = 0 and H = N.
TEST(Autodiff, FiniteAtNormalIncidence) {
  const Vec3 normal(0, 0, 1);
  for (const ModelSpec& spec : AllModelSpecs()) {
    const std::vector<double> p = spec.InitialParams();
    for (const Vec3& wo : {normal, FromAngles(0.8, 1.0)}) {
      Jet f[3];
      EvalJet(spec, p, normal, wo, f);
      for (int c = 0; c < 3; ++c) {
        EXPECT_TRUE(std::isfinite(f[c].a)) << spec.Label();
        for (int j = 0; j < spec.NumParams(); ++j) EXPECT_TRUE(std::isfinite(f[c].v[j])) << spec.Label() << " " << j;
      }
    }
  }
}

}  // namespace
}  // namespace svbrdf
