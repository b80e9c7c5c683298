// How a material's normal map encodes its normals (material.json
// "normal_map_space", docs/reference/formats.md, "material.json: a result"):
//   world   (absent = world, the files written before the field existed): RGB
//           = the world-space unit normal, which replaces the mesh's
//           interpolated normal;
//   tangent (Mitsuba 3's `normalmap`, glTF's normalTexture): RGB = the
//           normal's components in the frame (T, B, N) of the shading point,
//           N = the mesh's interpolated shading normal, T = the face's dP/du
//           made orthogonal to N, B = N x T. The frame is taken where the
//           surface is shaded, so the mesh's own turn within a texel is kept
//           (a world map holds the normal of the texel centre across the
//           texel: on a scanned mesh whose normal turns within a texel this
//           costs held-out accuracy; bench_results/bump_default.md).
// Values are stored as unit vectors in [-1, 1] (not remapped to [0, 1]; the
// exporters remap). An all-zero value (outside the atlas) means "the mesh
// normal" in both spaces.
#pragma once
#include <string>

#include "core/types.h"

namespace svbrdf {

enum class NormalMapSpace { kWorld, kTangent };

const char* NormalMapSpaceName(NormalMapSpace space);  // "world" / "tangent"
// False (and `out` untouched) for any other name.
bool ParseNormalMapSpace(const std::string& name, NormalMapSpace* out);

// The tangent-space frame at a surface point with unit shading normal `n`
// and the face's dP/du `dpdu` (Gram-Schmidt; any zero or parallel dP/du
// falls back to Frame::FromNormal, the same everywhere the frame is built).
inline Frame TangentFrame(const Vec3& n, const Vec3& dpdu) { return Frame::FromNormalTangent(n, dpdu); }

// World-space unit shading normal from a (bilinearly interpolated) map value
// at a point whose mesh shading normal is `n` and face dP/du `dpdu`; `n` when
// the value is (near) zero.
Vec3 NormalFromMapValue(const Vec3& value, NormalMapSpace space, const Vec3& n, const Vec3& dpdu);
// The map value encoding the world-space `normal` at that point (unit).
Vec3 MapValueFromNormal(const Vec3& normal, NormalMapSpace space, const Vec3& n, const Vec3& dpdu);

}  // namespace svbrdf
