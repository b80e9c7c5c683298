// Runtime description of a reflectance model and its parameter vector, so
// that fitting, rendering and material.json can treat every model of
// lib/brdf alike. The formulas themselves live in one small header per model
// (lambert.h, lafortune.h, cook_torrance.h, ...), templated on the scalar.
//
// Parameter vectors are flat arrays of T in the order given by Params(); the
// names are what material.json stores. Colour parameters come as _r,_g,_b.
#pragma once
#include <string>
#include <vector>

#include "core/types.h"

namespace svbrdf {

enum class Family {
  kLambert,       // rd/pi
  kOrenNayar,     // rd/pi (A + B max(0,cos(phi_i-phi_r)) sin(alpha) tan(beta))
  kPhong,         // rd/pi + rs <R|E>^m / <N|L>          (not reciprocal, not energy conserving)
  kBlinnPhong,    // rd/pi + rs <H|N>^m / <N|L>          (not reciprocal, not energy conserving)
  kCosineLobe,    // Lewis 1993: rd/pi + rs (m+2)/(2 pi) <R|E>^m
  kLafortune,     // rd/pi + sum_i rho_i (Cx Ex Lx + Cy Ey Ly + Cz Ez Lz)^n_i
  kCookTorrance,  // rd/pi + rs/pi D G F / (4 <N|L><N|E>)
  kConductor,     // metal: D G1 G1 F / (4 <N|L><N|E>), coloured (complex-index / Schlick / F82) Fresnel, no diffuse
  kCoated,        // coat: D G1 G1 F / (4 <N|L><N|E>) + Lambertian base seen through the coat (coated.h)
  kGltf,          // glTF 2.0 metallic-roughness: baseColor, metallic, roughness (gltf_pbr.h)
  kPlastic,       // smooth coat: Lambertian base seen through a flat dielectric coat, delta reflection (plastic.h)
  kMirror,        // smooth conductor: no BRDF part, a delta reflection of Schlick reflectance F0 (mirror.h)
  kPrincipled,    // Burley's principled BRDF as Mitsuba 3 evaluates it: base, metallic, specular, roughness (principled.h)
};

enum class Distribution { kBeckmann, kBlinnGaussian, kGGX };
enum class Shadowing { kVCavity, kSmith };  // V-cavity min(1,Gm,Gs) or Smith (GGX/Beckmann)
// kExact: dielectric (ior) for Cook-Torrance, complex eta + i kappa for
// conductors; kSchlick: from ior (Cook-Torrance) or a per-channel f0
// (conductors); kF82Tint: conductors only (fresnel.h).
enum class FresnelMode { kExact, kSchlick, kNone, kF82Tint };

struct ParamInfo {
  std::string name;         // e.g. "rd_r", "lobe0.cx", "roughness"
  std::string description;  // meaning and unit
  double lower, upper;      // documented valid range (also the fit bounds)
  double initial;           // a sensible starting value for fits
  // The model is affine in this parameter (colour amplitudes such as rd, rs,
  // rho, f0), so fits may start it from a linear least-squares estimate.
  bool linear = false;
};

struct ModelSpec {
  Family family = Family::kLambert;
  int lobes = 1;                 // Lafortune only: 1..3
  bool anisotropic = false;      // Lafortune only: Cx != Cy allowed
  Distribution distribution = Distribution::kBeckmann;  // Cook-Torrance, conductor, coated
  Shadowing shadowing = Shadowing::kVCavity;            // Cook-Torrance only (conductor, coated: Smith)
  FresnelMode fresnel = FresnelMode::kExact;            // Cook-Torrance, conductor
  bool clearcoat = false;        // Principled only: the second, clear specular lobe (clearcoat, clearcoat_gloss)

  // Stable name used in material.json "model", e.g. "lambert", "lafortune",
  // "cook_torrance". Options (lobes, distribution, ...) are separate fields.
  std::string Name() const;
  // Human-readable short label, e.g. "lafortune-2-aniso", "cook_torrance-ggx",
  // "conductor-ggx" (exact Fresnel), "conductor-beckmann-f82", "coated-ggx".
  std::string Label() const;
  int NumParams() const;
  std::vector<ParamInfo> Params() const;
  std::vector<double> InitialParams() const;
  // Parses a label as produced by Label() (also the CLI's --model values);
  // throws Error listing the valid labels.
  static ModelSpec FromLabel(const std::string& label);
  bool operator==(const ModelSpec& o) const;
};

// Evaluates the model with parameters p (NumParams() values) for unit
// directions in the local shading frame (z = normal): wi towards the light,
// wo towards the viewer. Writes the BRDF value per channel into rgb[3] (1/sr).
// Returns zeros when either direction is below the horizon.
// Defined in model_eval.h for any scalar T (double, ceres::Jet).
template <class T>
void EvalModel(const ModelSpec& spec, const T* p, const Vec3T<T>& wi, const Vec3T<T>& wo, T* rgb);

// double instantiation, compiled once (model.cc).
Rgb EvalModelD(const ModelSpec& spec, const double* p, const Vec3& wi, const Vec3& wo);

// Directional albedo int f(wi, wo) cos(theta_o) dwo, midpoint rule on an
// n_theta x n_phi grid in (theta, phi): uniform in angle, so narrow lobes
// near the normal get as many cells as anywhere else.
Rgb DirectionalAlbedo(const ModelSpec& spec, const double* p, const Vec3& wi, int n_theta, int n_phi);
// The largest directional albedo (reflected over incident light, any
// channel) at incident angles 0, 46, 69 and 85 degrees, on a 32 x 64 grid
// (coarse for lobes sharper than about exponent 500, so compare it with a
// bar well above 1).
// Physically based models stay below 1 by construction; Lafortune lobes
// with |C| > 1 and a large exponent do not (ReflectsMoreThanItReceives).
double MaxDirectionalAlbedo(const ModelSpec& spec, const double* p);
// A fit that reflects far more light than it receives (MaxDirectionalAlbedo
// above 1.5): a Lafortune lobe fitted to the photos' directions that grows
// by orders of magnitude where no photo saw it (grazing mirror directions),
// which clamped display-unit errors do not see and a relit view does.
bool ReflectsMoreThanItReceives(const ModelSpec& spec, const std::vector<double>& p, double* albedo = nullptr);

// Every distinct model, one per label accepted by FromLabel, in a fixed order.
std::vector<ModelSpec> AllModelSpecs();

}  // namespace svbrdf
