#include "export/render_target.h"

#include <algorithm>

#include "core/error.h"

namespace svbrdf {

RenderTarget ParseRenderTarget(const std::string& name) {
  if (name.empty() || name == "any") return RenderTarget::kAny;
  if (name == "mitsuba") return RenderTarget::kMitsuba;
  if (name == "gltf") return RenderTarget::kGltf;
  throw Error(Msg("--for: unknown render target '", name, "'; valid: any, mitsuba, gltf"));
}

std::string RenderTargetName(RenderTarget t) {
  switch (t) {
    case RenderTarget::kMitsuba: return "mitsuba";
    case RenderTarget::kGltf: return "gltf";
    case RenderTarget::kAny: break;
  }
  return "any";
}

bool RendersExactly(const ModelSpec& s, RenderTarget t) {
  const bool microfacet = s.distribution == Distribution::kBeckmann || s.distribution == Distribution::kGGX;
  switch (t) {
    case RenderTarget::kAny: return true;
    case RenderTarget::kMitsuba:
      if (s.family == Family::kLambert) return true;
      if (s.family == Family::kCookTorrance)
        return microfacet && s.shadowing == Shadowing::kSmith &&
               (s.fresnel == FresnelMode::kExact || s.fresnel == FresnelMode::kNone);
      if (s.family == Family::kConductor) return microfacet && s.fresnel == FresnelMode::kExact;
      return false;
    case RenderTarget::kGltf: return s.family == Family::kGltf;
  }
  return false;
}

namespace {

// The model of the same kind that the target renders exactly, if any: the
// Smith / exact-Fresnel twin of a Cook-Torrance or conductor, the dielectric
// lobe for a coat; none for lobes without a microfacet form (Lafortune, Phong).
bool ExactTwin(ModelSpec s, RenderTarget t, ModelSpec* twin) {
  if (RendersExactly(s, t)) return *twin = s, true;
  if (t == RenderTarget::kGltf) {
    if (s.family == Family::kOrenNayar || s.family == Family::kLafortune || s.family == Family::kPhong ||
        s.family == Family::kBlinnPhong || s.family == Family::kCosineLobe)
      return false;
    return *twin = ModelSpec::FromLabel("gltf"), true;
  }
  if (s.distribution == Distribution::kBlinnGaussian) s.distribution = Distribution::kBeckmann;
  switch (s.family) {
    case Family::kCoated:
      s.family = Family::kCookTorrance;
      s.fresnel = FresnelMode::kExact;
      [[fallthrough]];
    case Family::kCookTorrance:
      s.shadowing = Shadowing::kSmith;
      if (s.fresnel == FresnelMode::kSchlick) s.fresnel = FresnelMode::kExact;
      break;
    case Family::kConductor:
      s.fresnel = FresnelMode::kExact;
      break;
    default:
      return false;
  }
  if (!RendersExactly(s, t)) return false;
  return *twin = s, true;
}

}  // namespace

std::vector<std::string> CandidatesFor(RenderTarget t, const std::vector<std::string>& wanted) {
  if (t == RenderTarget::kAny) return wanted;
  std::vector<std::string> out;
  for (const std::string& label : wanted) {
    ModelSpec twin;
    if (!ExactTwin(ModelSpec::FromLabel(label), t, &twin)) continue;
    if (std::find(out.begin(), out.end(), twin.Label()) == out.end()) out.push_back(twin.Label());
  }
  if (!out.empty()) return out;
  for (const ModelSpec& s : AllModelSpecs())
    if (RendersExactly(s, t) && s.fresnel != FresnelMode::kNone) out.push_back(s.Label());
  if (out.empty()) throw Error(Msg("--for ", RenderTargetName(t), ": no model renders exactly there"));
  return out;
}

}  // namespace svbrdf
