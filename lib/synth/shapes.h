// Procedural test objects with a texture atlas (UVs in [0,1]^2, seams carry
// separate texture coordinates). Sizes are in metres, centred at the origin.
// Their vertex normals are area-weighted (NormalWeighting::kArea): the
// synthetic presets and the regression thresholds measured on them were made
// with those; the captures write them into mesh.obj (vn), so every reader
// shades with exactly the generator's normals.
#pragma once
#include <string>

#include "io/mesh.h"

namespace svbrdf {

Mesh MakeSphere(double radius, int rings, int segments);                        // lat-long UVs
Mesh MakeTorus(double major_radius, double minor_radius, int rings, int segments);  // (u, v) angles
Mesh MakeBlob(double radius, double bump, int rings, int segments);             // bumpy sphere, lat-long UVs
Mesh MakeBevelledCube(double half_size, double bevel, int cells);               // six faces in a 3x2 atlas

// Builds the named shape ("sphere", "torus", "blob", "cube") at a resolution
// suited to `detail` (number of segments around); throws Error for unknown names.
Mesh MakeShape(const std::string& name, int detail);

// Loads a mesh file (OBJ/PLY, e.g. a scan), centres its bounding box at the
// origin and scales it to a bounding sphere of radius 0.5 m (the size of the
// procedural shapes). A mesh without texture coordinates gets a chart atlas
// (atlas/charts.h) filling about half of a `texture_size`^2 texture, so that
// the ground truth can be painted on it.
Mesh LoadShapeFromFile(const std::string& path, int texture_size);

}  // namespace svbrdf
