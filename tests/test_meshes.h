// Small meshes shared by the unit tests of several modules.
#pragma once
#include "io/mesh.h"

namespace svbrdf::test_meshes {

// Two unit squares side by side in 3D (x in [0, 1] and [1, 2]) as two
// charts: A on the left of the texture, B mirrored on the right, so that
// their shared edge x = 1 lies at A's right border and at B's right border,
// 20 texels apart in a 40^2 texture.
inline Mesh TwoChartStrip() {
  Mesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), Vec3(2, 0, 0), Vec3(2, 1, 0)};
  m.faces = {Vec3i(0, 1, 2), Vec3i(0, 2, 3), Vec3i(1, 4, 5), Vec3i(1, 5, 2)};
  // A: x -> u in [0.05, 0.45]; B: x = 1 -> u 0.95, x = 2 -> u 0.55 (mirrored).
  m.texcoords = {Vec2(0.05, 0.3), Vec2(0.45, 0.3), Vec2(0.45, 0.7), Vec2(0.05, 0.7),
                 Vec2(0.95, 0.3), Vec2(0.55, 0.3), Vec2(0.55, 0.7), Vec2(0.95, 0.7)};
  m.face_uvs = {Vec3i(0, 1, 2), Vec3i(0, 2, 3), Vec3i(4, 5, 6), Vec3i(4, 6, 7)};
  m.ComputeNormals();
  return m;
}

}  // namespace svbrdf::test_meshes
