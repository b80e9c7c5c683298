// Which of our reflectance models another renderer reproduces exactly, so
// that `reconstruct --for TARGET` can fit only those and an export of the
// result renders like the reconstruction.
//
//   target   exact models (the forms in nearest_form.h / gltf_brdf.h)
//   mitsuba  lambert; cook_torrance-{beckmann,ggx}-smith with the exact
//            dielectric Fresnel or none (diffuse + roughconductor);
//            conductor-{beckmann,ggx} with the exact complex-index Fresnel
//   gltf     gltf (the glTF 2.0 metallic-roughness BRDF itself)
#pragma once
#include <string>
#include <vector>

#include "brdf/model.h"

namespace svbrdf {

enum class RenderTarget { kAny, kMitsuba, kGltf };

// "" or "any" -> kAny, "mitsuba", "gltf"; anything else throws naming the value.
RenderTarget ParseRenderTarget(const std::string& name);
std::string RenderTargetName(RenderTarget t);

// True when the target renders the model exactly (always for kAny).
bool RendersExactly(const ModelSpec& spec, RenderTarget t);

// The candidate models for a reconstruction aimed at `t`: each of `wanted`
// replaced by its exact twin on the target (Cook-Torrance -> Smith shadowing
// and exact Fresnel, conductor -> exact Fresnel, coat -> dielectric lobe;
// glTF: every microfacet or Lambert model -> gltf), those without one left
// out (Lafortune, Phong, Oren-Nayar), duplicates once; when none is left,
// the target's own exact set.
// kAny returns `wanted` unchanged.
std::vector<std::string> CandidatesFor(RenderTarget t, const std::vector<std::string>& wanted);

}  // namespace svbrdf
