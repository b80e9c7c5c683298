// Per-pixel SVBRDF of a photometric capture as non-negative mixtures of a few
// basis BRDFs chosen from a dictionary (Goldman et al. 2005; Alldrin et al.
// 2008; Hui & Sankaranarayanan 2017 fit normals against such a dictionary):
//
//   f_p(wi, wo) = sum_k w_pk (per channel) f_k(wi, wo),   w_pk >= 0,
//
// with f_0 Lambert (rd = 1) and the others unit-scale specular lobes:
// Cook-Torrance with a Beckmann distribution and the V-cavity term, or a GGX
// distribution with Smith shadowing (lib/brdf/cook_torrance.h, rd = 0, rs = 1,
// no Fresnel factor: its colour and angular trend go into the weights), and
// Oren-Nayar (rd = 1) for rough diffuse surfaces. Which of them a capture
// gets is chosen from its photos (SelectBasis): each addition must lower the
// error on photos left out of the fit. A pixel's weights then carry its
// diffuse colour, specular colour and (by mixing lobes) roughness.
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Dense>

#include "io/material.h"
#include "photometric/observations.h"

namespace svbrdf {

// The dictionary the basis is chosen from: Lambert first.
std::vector<BasisMaterial> DictionaryCandidates();

// Options of the per-pixel stage.
//   folds               light folds of the cross-validation in SelectBasis  [2, 10]
//   selection_pixels    pixels (evenly spread) SelectBasis scores on        >= 50
//   min_gain            relative cross-validated error drop an added basis
//                       BRDF must bring                                     [0, 1)
//   max_basis           most basis BRDFs, Lambert included                  [1, 8]
//   outlier_sigmas      a photo whose weighted residual exceeds this many
//                       robust standard deviations of its pixel is refitted
//                       without (shadows the height field misses,
//                       interreflection)                                    > 1 (0 = off)
//   prior_rows          final weights are pulled towards the object's median
//                       weights as strongly as this many average photos
//                       (pixels whose photos leave a lobe undetermined, e.g.
//                       mostly in shadow, take the typical one)            >= 0
//   min_cos             photos lighting the pixel at a cosine below this
//                       are left out (grazing light: mesh and normal errors
//                       dominate)                                           [0, 0.5]
//   search_misfit       the normal search runs on pixels whose Lambertian
//                       start misfits its inlier photos by more than this
//                       (relative RMS, median over a 15 x 15 window: metals,
//                       lobe-dominated paint); elsewhere the Lambertian
//                       start is kept, which the search's BRDF bias would
//                       only move away from a scan's normals (0 = all)     >= 0
//   one_lobe_diffuse_etas  the one-lobe normal search's diffuse candidates:
//                       a body under a smooth interface of each index
//                       (1 - F both ways; 1 = Lambert), each paired with
//                       every lobe, chosen by residual                     each in [1, 3]
struct DictionaryFitOptions {
  int folds = 5;
  int selection_pixels = 2000;
  double min_gain = 0.01;
  int max_basis = 5;
  double outlier_sigmas = 3.0;
  double min_cos = 0.05;
  double prior_rows = 0.0;
  double search_misfit = 0.15;
  // Plastics, glazes and paint binders (1.5) to dense coatings (2).
  std::vector<double> one_lobe_diffuse_etas = {1.0, 1.5, 2.0};
  double srgb_weight_exponent = 0.5;  // see PsObservations::weight
  // Light residuals (transfer.h FitResidualField): pixels pooled for each
  // pixel's carry-over share, (2 r + 1)^2 of them; -1 = none fitted.    [-1, 10]
  int residual_window = 2;
  int threads = 0;
  // Dictionary models allowed (null: all); Lambert, the first, must be
  // (`reconstruct --for` keeps only what the export target renders exactly).
  std::function<bool(const ModelSpec&)> allow_model;
  void Check() const;
};

struct PixelSolve {
  Eigen::MatrixXd w;  // K x channels
  double sse = 0;     // weighted squared residual over the photos used
  int used = 0;       // photo x channel values used
};

// Non-negative weights of `basis` for one pixel with camera-frame normal n.
// channels = 3 (RGB) or 1 (luminance). `use` (size lights) selects photos
// (null = all); `shadowed` (size lights) excludes cast shadows (null: none).
PixelSolve SolvePixel(const PsObservations& obs, const std::vector<BasisMaterial>& basis, long p, const Vec3& n,
                      int channels, const std::vector<uint8_t>* use, const uint8_t* shadowed,
                      const DictionaryFitOptions& o, const Eigen::MatrixXd* prior = nullptr);

struct BasisSelection {
  std::vector<BasisMaterial> basis;
  std::vector<double> cv_error;  // cross-validated error after each accepted step (first: Lambert alone)
  std::vector<std::string> log;  // one line per round: the best candidate and its gain
};

// Forward selection from DictionaryCandidates() by cross-validated error over
// light folds on luminance, starting from Lambert.
BasisSelection SelectBasis(const PsObservations& obs, const Image& normals_cam, const std::vector<uint8_t>& shadowed,
                           const DictionaryFitOptions& o);

// Per-pixel normal search under the basis: pattern search on the pixel's
// luminance fit (steps of 4 degrees halved down to 0.25), from `normals_cam`
// and from the half vector of the pixel's brightest photo (the specular
// cue), each kept only if it predicts the pixel's photos left out of the fit
// (light folds) better. Only pixels set in `search` (1 channel; null: all)
// are searched; the others keep their normal. Returns the camera-frame
// normals.
Image RefineNormals(const PsObservations& obs, const std::vector<BasisMaterial>& basis, const Image& normals_cam,
                    const std::vector<uint8_t>& shadowed, const DictionaryFitOptions& o,
                    const Image* search = nullptr);

// RGB weights of every pixel: one 3-channel map per basis BRDF (photo-sized,
// zero outside the object), plus the share of usable photos per pixel.
void SolveWeights(const PsObservations& obs, const std::vector<BasisMaterial>& basis, const Image& normals_cam,
                  const std::vector<uint8_t>& shadowed, const DictionaryFitOptions& o, std::vector<Image>* weights,
                  Image* confidence);

// Normals searched per pixel under a diffuse term plus one specular lobe
// that the whole object shares, with per-pixel non-negative weights of the
// two. The pair is the dictionary's Cook-Torrance lobe and the diffuse
// (Lambert, or a body under a smooth interface: `one_lobe_diffuse_etas`)
// with the lowest total relative residual after the search on pixels
// spread over `where`, fitted to each pixel's usable photos outside cast
// shadows without its darkest quarter (unweighted luminance). The search
// then fits the photos the chosen pair describes at the start (shadows the
// height field missed left out: dictionary_fit.cc, LitLobeRows). A
// response sharper than the cosine makes a Lambertian fit tilt near-frontal
// normals too far and grazing ones too little; one shape for the object
// takes that out, where a shape free per pixel (several lobes mixed)
// absorbs the tilt instead. A normal moves at most 15 degrees from its
// start. Only the pixels where `where` (1 channel) is set move; `chosen`
// gets the pair.
Image RefineNormalsUnderOneLobe(const PsObservations& obs, const Image& normals_cam,
                                const std::vector<uint8_t>& shadowed, const DictionaryFitOptions& o,
                                const Image& where, std::string* chosen);

}  // namespace svbrdf
