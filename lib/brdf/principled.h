// The principled BRDF of Burley 2012 ("Physically Based Shading at Disney")
// as Mitsuba 3's `principled` plugin evaluates it without transmission,
// sheen, specular tint, anisotropy or flatness (src/bsdfs/principled.cpp and
// principledhelpers.h), so that a material fitted with it renders the same
// in Mitsuba (`reconstruct --for mitsuba`) and its parameters mean what
// artists' principled materials mean.
//
//   base        base_color per channel                            [0, 1]
//   metallic    0 dielectric, 1 metal                              [0, 1]
//   specular    dielectric reflectance knob; Mitsuba's            [0, 1]
//               eta = 2 / (1 - sqrt(0.08 specular)) - 1 (0.5: eta 1.5, F0 4 %)
//   roughness   r; GGX alpha = max(0.001, r^2); also scales the   [0.03, 1]
//               diffuse retro-reflection
//   clearcoat   weight of the second, clear specular lobe          [0, 1]
//   clearcoat_gloss  g; the coat's GTR1 alpha = 0.1 (1 - g) + 0.001 g  [0, 1]
//               (principled-clearcoat only; 0 otherwise)
//
// With H the half vector, c = <L|H> = <E|H>, s(x) = (1 - x)^5:
//   specular = F D G1(L) G1(E) / (4 <N|L><N|E>),   GGX D and Smith G1 of alpha
//              F = (1 - metallic) F_dielectric(c, eta) + metallic (base + (1 - base) s(c))
//   coat     = clearcoat / 4 (0.04 + 0.96 s(c)) D_GTR1(<N|H>) G1(L) G1(E)  (G1 of GGX alpha 0.25)
//              D_GTR1 = (a^2 - 1) / (pi ln(a^2) (1 + (a^2 - 1) <N|H>^2))
//              (no 1 / (4 <N|L><N|E>): Burley's and Mitsuba's clearcoat)
//   diffuse  = (1 - metallic) base / pi [(1 - s(<N|L>)/2)(1 - s(<N|E>)/2)
//              + R (s_L + s_E + s_L s_E (R - 1))],  R = 2 r c^2  (retro-reflection)
//
// Reciprocal (every term is symmetric in L and E). Not energy conserving in
// general: the retro-reflection of a rough base reflects slightly more than
// it receives at grazing light (Burley's diffuse is an empirical fit;
// brdf_test bounds the directional albedo). Affine in base, so fits may
// start it linearly.
#pragma once
#include <cmath>

#include "brdf/common.h"
#include "brdf/fresnel.h"
#include "brdf/microfacet.h"

namespace svbrdf::brdf {

// Mitsuba's mapping of the `specular` knob to the index of refraction
// (SafeSqrt: a fit at the bound specular = 0 gets a finite derivative).
template <class T> T PrincipledEta(const T& specular) {
  return T(2) / (T(1) - SafeSqrt(T(0.08) * specular)) - T(1);
}

template <class T> struct Principled {
  RgbT<T> base;
  T metallic = T(0);
  T specular = T(0.5);
  T roughness = T(0.5);
  T clearcoat = T(0);
  T clearcoat_gloss = T(0);

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    using std::log;
    const Vec3T<T> h = HalfVector(wi, wo);
    const T c = Dot(wo, h);
    const auto schlick_weight = [](const T& x) {
      const T k = Min(Max(T(1) - x, T(0)), T(1));
      const T k2 = k * k;
      return k2 * k2 * k;
    };
    const T sc = schlick_weight(c);
    const T alpha = Max(roughness * roughness, T(0.001));
    const T dg = SmithMicrofacet(Distribution::kGGX, wi, wo, h, alpha);
    const T f_dielectric = FresnelDielectric(c, PrincipledEta(specular));
    // The clear coat's lobe (zero without a coat).
    T coat = T(0);
    if (clearcoat > T(0)) {
      const T a = T(0.1) * (T(1) - clearcoat_gloss) + T(0.001) * clearcoat_gloss;
      const T a2 = a * a;
      const T d = (a2 - T(1)) / (T(kPi) * log(a2) * (T(1) + (a2 - T(1)) * h.z() * h.z()));
      coat = T(0.25) * clearcoat * (T(0.04) + T(0.96) * sc) * d * SmithG1Ggx(wi.z(), T(0.25)) *
             SmithG1Ggx(wo.z(), T(0.25));
    }
    const T sl = schlick_weight(wi.z()), se = schlick_weight(wo.z());
    const T retro_r = T(2) * roughness * c * c;
    const T diffuse = ((T(1) - T(0.5) * sl) * (T(1) - T(0.5) * se) + retro_r * (sl + se + sl * se * (retro_r - T(1)))) *
                      (T(1) - metallic) * InvPi<T>();
    RgbT<T> out;
    for (int k = 0; k < 3; ++k) {
      const T fresnel = (T(1) - metallic) * f_dielectric + metallic * (base[k] + (T(1) - base[k]) * sc);
      out[k] = fresnel * dg + coat + base[k] * diffuse;
    }
    return out;
  }
};

}  // namespace svbrdf::brdf
