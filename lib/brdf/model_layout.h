// The one definition of every model's parameter vector. VisitParams walks the
// fields of a value class in ModelSpec::Params() order, handing each to a
// visitor together with its name, meaning, range and initial value:
// ParamReader (below) fills the fields from a flat array for evaluation, and
// model.cc collects the ParamInfo list. Keeping both on one walk means the
// order cannot drift apart.
//
// Visitor interface:
//   void Lobe(int i);  // following names belong to Lafortune lobe i
//   void Scalar(T& field, const char* name, const char* description,
//               double lower, double upper, double initial);
//   void Rgb(RgbT<T>& field, <same>, bool linear = true);  // three parameters name_r, name_g, name_b;
//                                     // linear: the model is affine in them (ParamInfo::linear)
#pragma once
#include "brdf/blinn_phong.h"
#include "brdf/coated.h"
#include "brdf/mirror.h"
#include "brdf/plastic.h"
#include "brdf/conductor.h"
#include "brdf/cook_torrance.h"
#include "brdf/cosine_lobe.h"
#include "brdf/gltf_pbr.h"
#include "brdf/lafortune.h"
#include "brdf/lambert.h"
#include "brdf/model.h"
#include "brdf/oren_nayar.h"
#include "brdf/phong.h"
#include "brdf/principled.h"

namespace svbrdf::brdf {

template <class T> struct ParamReader {
  const T* p;
  void Lobe(int) {}
  void Scalar(T& x, const char*, const char*, double, double, double) { x = *p++; }
  void Rgb(RgbT<T>& c, const char*, const char*, double, double, double, bool = true) {
    c = RgbT<T>(p[0], p[1], p[2]);
    p += 3;
  }
};

template <class V, class T> void VisitDiffuse(V& v, RgbT<T>& rd) {
  v.Rgb(rd, "rd", "diffuse albedo", 0.0, 1.0, 0.5);
}

template <class V, class M> void VisitPhongLike(V& v, M& m) {
  VisitDiffuse(v, m.rd);
  v.Rgb(m.rs, "rs", "specular coefficient", 0.0, 1.0, 0.3);
  v.Scalar(m.m, "exponent", "specular exponent m (sharpness)", 0.5, 10000.0, 20.0);
}

template <class V, class T> void VisitParams(V& v, const ModelSpec&, Lambert<T>& m) { VisitDiffuse(v, m.rd); }

template <class V, class T> void VisitParams(V& v, const ModelSpec&, OrenNayar<T>& m) {
  VisitDiffuse(v, m.rd);
  v.Scalar(m.sigma, "sigma", "standard deviation of facet angles (rad)", 0.0, 1.0, 0.3);
}

template <class V, class T> void VisitParams(V& v, const ModelSpec&, Phong<T>& m) { VisitPhongLike(v, m); }
template <class V, class T> void VisitParams(V& v, const ModelSpec&, BlinnPhong<T>& m) { VisitPhongLike(v, m); }
template <class V, class T> void VisitParams(V& v, const ModelSpec&, CosineLobe<T>& m) { VisitPhongLike(v, m); }

template <class V, class T> void VisitParams(V& v, const ModelSpec& spec, Lafortune<T>& m) {
  VisitDiffuse(v, m.rd);
  for (int i = 0; i < m.num_lobes; ++i) {
    LafortuneLobe<T>& l = m.lobes[i];
    v.Lobe(i);
    v.Rgb(l.rho, "rho", "lobe albedo/scale", 0.0, 100.0, 0.5);
    // Start as a forward-scattering (Phong-like) lobe; different exponents per
    // lobe break the symmetry between otherwise identical lobes in a fit.
    v.Scalar(l.cx, "cx", "tangential coefficient Cx (negative: forward lobe)", -1.5, 1.5, -1.0);
    if (spec.anisotropic) v.Scalar(l.cy, "cy", "tangential coefficient Cy", -1.5, 1.5, -1.0);
    v.Scalar(l.cz, "cz", "normal coefficient Cz", -1.5, 1.5, 1.0);
    v.Scalar(l.n, "n", "lobe exponent", 0.5, 1000.0, 20.0 * (1 << (2 * i)));
    if (!spec.anisotropic) l.cy = l.cx;
  }
}

template <class V, class T> void VisitParams(V& v, const ModelSpec&, CookTorrance<T>& m) {
  VisitDiffuse(v, m.rd);
  v.Rgb(m.rs, "rs", "specular albedo scale", 0.0, 1.0, 0.3);
  v.Scalar(m.m, "roughness", "microfacet roughness m", 0.01, 1.0, 0.3);
  v.Scalar(m.n, "ior", "index of refraction n", 1.05, 3.0, 1.5);
}

// Ranges reach real metals: F0 up to ~0.999 (eta 0.02, kappa 10), and
// mirror-like roughness down to 0.01. Fits start from a grey metal of F0 0.86.
template <class V, class T> void VisitParams(V& v, const ModelSpec& spec, Conductor<T>& m) {
  if (spec.fresnel == FresnelMode::kExact) {
    v.Rgb(m.eta, "eta", "real part of the complex index of refraction", 0.02, 6.0, 1.0, false);
    v.Rgb(m.kappa, "kappa", "imaginary part (extinction coefficient) of the index", 0.0, 10.0, 5.0, false);
  } else {
    v.Rgb(m.f0, "f0", "reflectance at normal incidence", 0.0, 1.0, 0.86);
    if (spec.fresnel == FresnelMode::kF82Tint)
      v.Rgb(m.f82_tint, "f82_tint", "reflectance at 82 deg relative to Schlick's", 0.0, 1.0, 1.0, false);
  }
  v.Scalar(m.m, "roughness", "microfacet roughness (GGX alpha or Beckmann RMS slope)", 0.01, 1.0, 0.1);
}

// rd is not linear: the base's re-reflections under the coat add 1/(1 - rd F_int).
template <class V, class T> void VisitParams(V& v, const ModelSpec&, Coated<T>& m) {
  v.Rgb(m.rd, "rd", "albedo of the diffuse base under the coat", 0.0, 1.0, 0.5, false);
  v.Scalar(m.m, "roughness", "roughness of the coat (GGX alpha or Beckmann RMS slope)", 0.01, 1.0, 0.1);
  v.Scalar(m.n, "ior", "index of refraction of the coat", 1.1, 2.5, 1.5);
}

// As the coat above: rd is not linear.
template <class V, class T> void VisitParams(V& v, const ModelSpec&, Plastic<T>& m) {
  v.Rgb(m.rd, "rd", "albedo of the diffuse base under the smooth coat", 0.0, 1.0, 0.5, false);
  v.Scalar(m.n, "ior", "index of refraction of the coat", 1.1, 2.5, 1.5);
}

template <class V, class T> void VisitParams(V& v, const ModelSpec&, Mirror<T>& m) {
  v.Rgb(m.f0, "f0", "mirror reflectance at normal incidence", 0.0, 1.0, 0.5);
}

template <class V, class T> void VisitParams(V& v, const ModelSpec&, GltfPbr<T>& m) {
  v.Rgb(m.base, "base_color", "glTF baseColor", 0.0, 1.0, 0.5);
  v.Scalar(m.metallic, "metallic", "glTF metallic (0 dielectric, 1 metal)", 0.0, 1.0, 0.0);
  v.Scalar(m.roughness, "roughness", "glTF perceptual roughness (GGX alpha = roughness^2)", 0.05, 1.0, 0.5);
}

// Mitsuba's principled parameters under their Mitsuba names (export/mitsuba.cc writes them as they are).
template <class V, class T> void VisitParams(V& v, const ModelSpec& spec, Principled<T>& m) {
  v.Rgb(m.base, "base_color", "base color", 0.0, 1.0, 0.5);
  v.Scalar(m.metallic, "metallic", "metallic (0 dielectric, 1 metal)", 0.0, 1.0, 0.0);
  v.Scalar(m.specular, "specular", "dielectric reflectance knob, eta = 2 / (1 - sqrt(0.08 specular)) - 1", 0.0, 1.0,
           0.5);
  v.Scalar(m.roughness, "roughness", "roughness r (GGX alpha = r^2; scales the diffuse retro-reflection)", 0.03, 1.0,
           0.5);
  if (spec.clearcoat) {
    v.Scalar(m.clearcoat, "clearcoat", "weight of the clear coat's lobe", 0.0, 1.0, 0.5);
    v.Scalar(m.clearcoat_gloss, "clearcoat_gloss", "coat gloss (GTR1 alpha from 0.1 at 0 to 0.001 at 1)", 0.0, 1.0,
             0.8);
  }
}

// Calls fn(model) with a default-initialised value class of the spec's family
// and options; the caller fills the parameters with VisitParams.
template <class T, class Fn> void WithModel(const ModelSpec& spec, Fn&& fn) {
  switch (spec.family) {
    case Family::kLambert: { Lambert<T> m; fn(m); return; }
    case Family::kOrenNayar: { OrenNayar<T> m; fn(m); return; }
    case Family::kPhong: { Phong<T> m; fn(m); return; }
    case Family::kBlinnPhong: { BlinnPhong<T> m; fn(m); return; }
    case Family::kCosineLobe: { CosineLobe<T> m; fn(m); return; }
    case Family::kLafortune: {
      Lafortune<T> m;
      m.num_lobes = spec.lobes;
      fn(m);
      return;
    }
    case Family::kCookTorrance: {
      CookTorrance<T> m;
      m.distribution = spec.distribution;
      m.shadowing = spec.shadowing;
      m.fresnel = spec.fresnel;
      fn(m);
      return;
    }
    case Family::kConductor: {
      Conductor<T> m;
      m.distribution = spec.distribution;
      m.fresnel = spec.fresnel;
      fn(m);
      return;
    }
    case Family::kCoated: {
      Coated<T> m;
      m.distribution = spec.distribution;
      fn(m);
      return;
    }
    case Family::kGltf: { GltfPbr<T> m; fn(m); return; }
    case Family::kPlastic: { Plastic<T> m; fn(m); return; }
    case Family::kMirror: { Mirror<T> m; fn(m); return; }
    case Family::kPrincipled: { Principled<T> m; fn(m); return; }
  }
}

}  // namespace svbrdf::brdf
