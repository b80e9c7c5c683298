// Published optical constants (complex index eta + i kappa) of a few metals
// at one red, green and blue wavelength each, for ground truth (synth) and
// physics tests of the conductor Fresnel. Values are rows of the tables at
// refractiveindex.info (database/data-nk/main/<metal>/<source>.yml), taken
// without interpolation at the tabulated wavelength nearest to 650/550/450 nm:
//   gold, copper: P. B. Johnson and R. W. Christy, "Optical constants of the
//     noble metals", Phys. Rev. B 6, 4370 (1972): 659.5, 548.6, 450.9 nm.
//   aluminium: A. D. Rakic, "Algorithm for the determination of intrinsic
//     optical constants of metal films: application to aluminum",
//     Appl. Opt. 34, 4755 (1995): 652.3, 563.6, 442.8 nm.
#pragma once
#include <string>
#include <vector>

#include "core/types.h"

namespace svbrdf::brdf {

struct MetalConstants {
  const char* name;
  Rgb eta, kappa;
  Vec3 wavelength_nm;  // of the r, g, b values
  const char* source;
};

inline const std::vector<MetalConstants>& PublishedMetals() {
  static const std::vector<MetalConstants> metals = {
      {"gold", Rgb(0.14, 0.43, 1.38), Rgb(3.697, 2.455, 1.914), Vec3(659.5, 548.6, 450.9), "Johnson & Christy 1972"},
      {"copper", Rgb(0.22, 1.02, 1.24), Rgb(3.747, 2.577, 2.397), Vec3(659.5, 548.6, 450.9), "Johnson & Christy 1972"},
      {"aluminium", Rgb(1.5724, 1.0728, 0.6079), Rgb(7.7354, 6.7839, 5.3676), Vec3(652.25, 563.57, 442.80),
       "Rakic 1995"},
  };
  return metals;
}

// The metal of that name; nullptr when unknown.
inline const MetalConstants* FindMetal(const std::string& name) {
  for (const MetalConstants& m : PublishedMetals())
    if (name == m.name) return &m;
  return nullptr;
}

}  // namespace svbrdf::brdf
