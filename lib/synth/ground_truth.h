// Ground-truth SVBRDFs for synthetic captures: K basis materials of any model
// of lib/brdf, painted onto the surface as soft-edged regions (a smooth
// Voronoi partition of the surface around K well-spread seeds), optionally
// with per-texel variation of the weights and a bump normal map.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "io/material.h"

namespace svbrdf {

// Parameters of one basis material that replace the built-in library's.
struct MaterialParams {
  std::string metal;                     // conductors: "gold", "copper", "aluminium" (brdf/metals.h) sets
                                         // eta/kappa, or f0 (and f82_tint) matching them; "" = library
  std::map<std::string, double> values;  // parameter name -> value (applied after `metal`)
};

struct GroundTruthOptions {
  int num_materials = 3;
  std::vector<std::string> models;  // labels per material; empty = the built-in library in order
  std::vector<MaterialParams> params;  // per material (empty, or one per material): overrides
  int texture_size = 128;
  double blend = 0.02;              // width of the soft region borders (metres)
  double variation = 0.0;           // amplitude of smooth per-texel weight variation (0.1 = +-10 %)
  double bump = 0.0;                // normal-map bump slope (0 = no normal map)
  uint64_t seed = 1;
  // Not a preset field: set for meshes whose UVs are a generated chart atlas
  // (triangles smaller than a texel still get painted; atlas/atlas.h).
  bool cover_small_triangles = false;
  void Check() const;
};

// The i-th built-in basis material with the given model label (or its own
// default model when label is empty): parameters set by name.
BasisMaterial LibraryMaterial(int i, const std::string& label = "");

// Sets a parameter by its name; throws Error listing the valid names.
void SetParam(BasisMaterial* b, const std::string& name, double value);
// Sets a conductor's Fresnel parameters from a published metal (brdf/metals.h):
// eta/kappa for the exact form; f0 = ConductorF0 and f82_tint for the others.
// Throws Error for an unknown metal or a model that is not a conductor.
void SetMetal(BasisMaterial* b, const std::string& metal);
// Applies `p` to `b`; throws Error naming the material when a value is
// outside the parameter's documented range.
void ApplyParams(BasisMaterial* b, const MaterialParams& p);
double GetParam(const BasisMaterial& b, const std::string& name);
// Whether b's model has the named parameter.
bool HasParam(const BasisMaterial& b, const std::string& name);

// Builds the material folder contents for `mesh` (which must have UVs).
Material MakeGroundTruth(const Mesh& mesh, const GroundTruthOptions& options);

}  // namespace svbrdf
