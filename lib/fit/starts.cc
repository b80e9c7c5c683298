#include "fit/starts.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "brdf/fresnel.h"
#include "core/error.h"

namespace svbrdf {
namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

int ParamIndex(const std::vector<ParamInfo>& info, const std::string& name) {
  for (int i = 0; i < static_cast<int>(info.size()); ++i)
    if (info[i].name == name) return i;
  throw Error(Msg("starts: no parameter '", name, "'"));
}

// Colour parameter groups the model is affine in (ParamInfo::linear): index
// of the _r, _g, _b parameter of each group.
std::vector<std::array<int, 3>> ColourGroups(const std::vector<ParamInfo>& info) {
  static const char* kSuffix[3] = {"_r", "_g", "_b"};
  std::vector<std::array<int, 3>> groups;
  for (int i = 0; i < static_cast<int>(info.size()); ++i) {
    if (!info[i].linear || !EndsWith(info[i].name, kSuffix[0])) continue;
    const std::string stem = info[i].name.substr(0, info[i].name.size() - 2);
    std::array<int, 3> g{i, -1, -1};
    for (int j = 0; j < static_cast<int>(info.size()); ++j)
      for (int c = 1; c < 3; ++c)
        if (info[j].name == stem + kSuffix[c]) g[c] = j;
    if (g[1] >= 0 && g[2] >= 0) groups.push_back(g);
  }
  return groups;
}

// Shape parameters varied across starts, in Params() order (lobe order).
std::vector<int> ShapeParams(const ModelSpec& spec, const std::vector<ParamInfo>& info) {
  std::vector<int> out;
  for (int i = 0; i < static_cast<int>(info.size()); ++i) {
    const std::string& n = info[i].name;
    switch (spec.family) {
      case Family::kLafortune:
        if (n == "n" || EndsWith(n, ".n") || EndsWith(n, "_n")) out.push_back(i);  // lobe exponents
        break;
      case Family::kPhong:
      case Family::kBlinnPhong:
      case Family::kCosineLobe:
        if (n == "n" || n == "m" || n == "exponent" || n == "shininess") out.push_back(i);
        break;
      case Family::kCookTorrance:
      case Family::kConductor:
      case Family::kCoated:
      case Family::kGltf:
      case Family::kPrincipled:
        if (n == "roughness" || n == "m" || n == "alpha") out.push_back(i);
        break;
      default:
        break;
    }
  }
  return out;
}

}  // namespace

void ClampToBounds(const ModelSpec& spec, std::vector<double>* params) {
  const std::vector<ParamInfo> info = spec.Params();
  for (size_t i = 0; i < info.size(); ++i) (*params)[i] = std::clamp((*params)[i], info[i].lower, info[i].upper);
}

namespace {

// A conductor with the exact Fresnel is not linear in (eta, kappa). Its start
// comes from the linear f0 of its Schlick twin (same distribution and
// roughness), turned into an index that reproduces f0 at normal incidence:
// eta = 1 - f0 (metals that reflect strongly have small eta: silver, gold
// and copper in the red) and the matching kappa. The colour of the start
// thus follows the data instead of a guessed list of metals.
void ConductorStartFromF0(const ModelSpec& spec, const PackedSamples& packed, int64_t count,
                          std::vector<double>* params) {
  const std::vector<ParamInfo> info = spec.Params();
  ModelSpec twin = spec;
  twin.fresnel = FresnelMode::kSchlick;
  const std::vector<ParamInfo> twin_info = twin.Params();
  std::vector<double> tp = twin.InitialParams();
  tp[ParamIndex(twin_info, "roughness")] = (*params)[ParamIndex(info, "roughness")];
  FitAmplitudes(twin, packed, count, &tp);
  for (const char* c : {"_r", "_g", "_b"}) {
    const double f0 = std::min(tp[ParamIndex(twin_info, std::string("f0") + c)], 0.995);
    const double eta = std::clamp(1.0 - f0, 0.05, 1.0);
    (*params)[ParamIndex(info, std::string("eta") + c)] = eta;
    (*params)[ParamIndex(info, std::string("kappa") + c)] = brdf::ConductorKappaFromF0(f0, eta);
  }
  ClampToBounds(spec, params);
}

// The index a real metal would have for normal-incidence reflectance f0:
// kappa large (the metals of metals.h have kappa 1.8..7.6 in the visible),
// eta from f0. ConductorStartFromF0's eta = 1 - f0 has kappa small. Along
// a curve of equal F0 the two give different Fresnel curves off normal
// incidence, and the exact fit is not convex there, so the screen of
// starts (fit.cc) tries both families and keeps what fits the data.
// kappa = min(3, 2 sqrt(f0 / (1 - f0))), the smaller eta of
// ConductorF0(eta, kappa) = f0 (eta = 1 where kappa is below 3).
void MetalLikeIndex(double f0, double* eta, double* kappa) {
  f0 = std::clamp(f0, 0.0, 0.995);
  const double k_eta1 = brdf::ConductorKappaFromF0(f0, 1.0);  // 2 sqrt(f0 / (1 - f0))
  if (k_eta1 <= 3.0) {
    *eta = 1.0;
    *kappa = k_eta1;
    return;
  }
  *kappa = 3.0;
  const double a = (1.0 + f0) / (1.0 - f0);
  *eta = a - std::sqrt(std::max(0.0, a * a - (1.0 + *kappa * *kappa)));
}

}  // namespace

void FitAmplitudes(const ModelSpec& spec, const PackedSamples& packed, int64_t count, std::vector<double>* params) {
  if (spec.family == Family::kConductor && spec.fresnel == FresnelMode::kExact) {
    ConductorStartFromF0(spec, packed, count, params);
    return;
  }
  const std::vector<ParamInfo> info = spec.Params();
  const auto groups = ColourGroups(info);
  const int g_count = static_cast<int>(groups.size());
  if (g_count == 0 || count <= 0) return;

  // Basis responses: model with all amplitudes 0 (offset), then group g at 1.
  std::vector<std::vector<double>> probes(g_count + 1, *params);
  for (auto& probe : probes)
    for (const auto& g : groups)
      for (int c = 0; c < 3; ++c) probe[g[c]] = 0.0;
  for (int g = 0; g < g_count; ++g)
    for (int c = 0; c < 3; ++c) probes[g + 1][groups[g][c]] = 1.0;

  using Mat = Eigen::MatrixXd;
  std::array<Mat, 3> normal;
  std::array<Eigen::VectorXd, 3> rhs;
  for (int c = 0; c < 3; ++c) {
    normal[c] = Mat::Zero(g_count, g_count);
    rhs[c] = Eigen::VectorXd::Zero(g_count);
  }
  std::vector<Rgb> response(g_count + 1);
  for (int64_t s = 0; s < count; ++s) {
    const double* row = packed.row(s);
    const Vec3 wi(row[0], row[1], row[2]), wo(row[3], row[4], row[5]);
    const double geom = row[6];
    for (int k = 0; k <= g_count; ++k) response[k] = EvalModelD(spec, probes[k].data(), wi, wo) * geom;
    for (int c = 0; c < 3; ++c) {
      const double target = row[7 + c] - response[0][c];
      for (int a = 0; a < g_count; ++a) {
        const double ba = response[a + 1][c] - response[0][c];
        rhs[c][a] += ba * target;
        for (int b = 0; b < g_count; ++b) normal[c](a, b) += ba * (response[b + 1][c] - response[0][c]);
      }
    }
  }
  for (int c = 0; c < 3; ++c) {
    // Tiny ridge: lobes that no sample sees, or identical lobes, make the system singular.
    const double ridge = 1e-9 * std::max(normal[c].trace(), 1e-300);
    normal[c].diagonal().array() += ridge;
    const Eigen::VectorXd a = normal[c].ldlt().solve(rhs[c]);
    if (!a.allFinite()) continue;
    for (int g = 0; g < g_count; ++g) (*params)[groups[g][c]] = a[g];
  }
  ClampToBounds(spec, params);
}

std::vector<std::vector<double>> ShapeStarts(const ModelSpec& spec, const std::vector<double>& base) {
  const std::vector<ParamInfo> info = spec.Params();
  const std::vector<int> shape = ShapeParams(spec, info);
  std::vector<std::vector<double>> starts{base};
  if (shape.empty()) return starts;
  static const std::vector<double> kExponents{5, 30, 200};
  static const std::vector<double> kRoughness{0.05, 0.15, 0.4};
  // Metals are often polished: start one fit near a mirror.
  static const std::vector<double> kMetalRoughness{0.02, 0.08, 0.3};
  // glTF's roughness is perceptual (alpha = r^2): the same alphas.
  static const std::vector<double> kPerceptualRoughness{0.22, 0.39, 0.63};
  const std::vector<double>& values = spec.family == Family::kConductor ? kMetalRoughness
                                      : spec.family == Family::kCookTorrance || spec.family == Family::kCoated
                                          ? kRoughness
                                      : spec.family == Family::kGltf || spec.family == Family::kPrincipled ? kPerceptualRoughness
                                                                     : kExponents;
  for (size_t s = 0; s < values.size(); ++s) {
    std::vector<double> p = base;
    // Lobe k of start s takes value (s + k) mod 3: lobes start apart and every
    // value appears once per lobe across the starts.
    for (size_t k = 0; k < shape.size(); ++k) p[shape[k]] = values[(s + k) % values.size()];
    ClampToBounds(spec, &p);
    if (std::find(starts.begin(), starts.end(), p) == starts.end()) starts.push_back(p);
  }
  return starts;
}

std::vector<double> MetalLikeStart(const ModelSpec& spec, const std::vector<double>& start) {
  if (spec.family != Family::kConductor || spec.fresnel != FresnelMode::kExact) return {};
  const std::vector<ParamInfo> info = spec.Params();
  std::vector<double> out = start;
  for (const char* c : {"_r", "_g", "_b"}) {
    const int ie = ParamIndex(info, std::string("eta") + c), ik = ParamIndex(info, std::string("kappa") + c);
    MetalLikeIndex(brdf::ConductorF0(start[ie], start[ik]), &out[ie], &out[ik]);
  }
  ClampToBounds(spec, &out);
  return out == start ? std::vector<double>{} : out;
}

}  // namespace svbrdf
