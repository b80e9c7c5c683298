// Analytic test geometry: a tessellated unit sphere shared by the ray-tracer
// tests and benchmark (and usable for synthetic scenes), so they agree on the
// shape whose exact intersections they compare against.
#pragma once
#include <cmath>

#include "io/mesh.h"

namespace svbrdf {

// Latitude/longitude sphere of radius 1 at the origin: counter-clockwise
// (outward) winding, exact normals, 2 * segments * (rings - 1) triangles and
// no degenerate ones (pole caps use one triangle per segment).
inline Mesh MakeUvSphere(int rings, int segments) {
  Mesh m;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double th = kPi * i / rings, ph = 2 * kPi * j / segments;
      m.positions.emplace_back(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
    }
  const auto id = [&](int i, int j) { return i * segments + j % segments; };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      if (i > 0) m.faces.emplace_back(id(i, j), id(i + 1, j), id(i, j + 1));
      if (i + 1 < rings) m.faces.emplace_back(id(i, j + 1), id(i + 1, j), id(i + 1, j + 1));
    }
  m.normals = m.positions;
  return m;
}

}  // namespace svbrdf
