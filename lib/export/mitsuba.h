// Mitsuba 3 export of a material folder: a scene that renders the
// reconstructed object with the same reflectance as `relight`.
//
// Written into the output folder:
//   mesh.obj            the material's mesh with its UVs and relight's vertex normals (vn)
//   textures/*.exr      per-texel reflectance textures (see below), linear
//   object.xml          <bsdf id="material"> + <shape> (included by every scene file)
//   scene.xml           object + the first view's sensor and light (or, without a
//                       capture, a default camera under a constant white environment)
//   view_NNNN.xml       one file per image entry of the capture's scene.json: its
//                       camera (perspective sensor, fov and principal point), pose,
//                       light (point / directional / spot; emitter scaled by the
//                       entry's exposure, so a render equals the photo), direct-light
//                       integrator
//   views.json          view file -> the scene.json image entry (file, mask, exposure)
//   export_report.json  how each basis material was mapped, its error, warnings
//   as_rendered/        a material folder with every basis material replaced by
//                       its Mitsuba form: `svbrdf relight` of it renders what
//                       the Mitsuba scene holds (used to check the export)
//
// Reflectance: each basis material k is mapped to its NearestForm (diffuse +
// optional roughconductor, roughplastic or plastic lobe, exact where a Mitsuba plugin
// matches). Instead of blending by the weight maps (blendbsdf weights are
// scalar and assume sum_k w_k = 1, neither of which holds for our
// per-channel NNLS weights), the weights are baked into the reflectance
// textures and the parts are summed exactly:
//   diffuse texture   sum_k w_k,c(x) rd_k,c          (one diffuse BSDF)
//   lobe k texture    w_k,c(x) rs_k,c                (specular_reflectance of one roughconductor
//                                                     per lobe; of the coat for roughplastic, rs = 1)
//   base k texture    d with d / (1 - d F_int) = w_k,c(x) g_k,c (roughplastic's nonlinear
//                     diffuse_reflectance: the base term is linear in the coupling g,
//                     not in d; g = base / (1 - base F_int) of the form)
// and the M parts are combined with nested blendbsdf of constant weights
// (weight (M-i-1)/(M-i) at level i, i.e. the average of the parts) with every
// texture multiplied by M. This equals f_c(x) = sum_k w_k,c(x) f_k,c per
// channel and texel, up to the per-model NearestForm error.
// With a normal map, the sum is wrapped in Mitsuba's `normalmap` BSDF, whose
// tangent frame (interpolated normal, s = dP/du orthogonalised, t = n x s) is
// our tangent space (io/normal_map_space.h): a tangent map is copied, a
// world-space one converted at the texel centres.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

#include "io/material.h"
#include "io/scene.h"

namespace svbrdf {

struct MitsubaExportOptions {
  int spp = 64;  // sample_count of every sensor's sampler
  void Check() const;
};

// Writes the files above into `dir` (which must exist and be empty); `scene`
// may be null (no views). Returns the export report (also written).
nlohmann::json ExportMitsuba(const Material& material, const Scene* scene, const MitsubaExportOptions& options,
                             const std::string& dir);

// Mitsuba spot lights fall off linearly in angle from 1 at beam_width to 0 at
// cutoff_angle; our spot is cos^exponent inside a hard cutoff. Returns the
// beam width (radians) minimising the squared intensity difference over the
// cone's solid angle, and the relative RMS intensity error in `error`.
double SpotBeamWidth(double exponent, double cutoff_rad, double* error);

}  // namespace svbrdf
