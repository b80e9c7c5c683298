#include "io/normal_map_space.h"

namespace svbrdf {

const char* NormalMapSpaceName(NormalMapSpace space) { return space == NormalMapSpace::kTangent ? "tangent" : "world"; }

bool ParseNormalMapSpace(const std::string& name, NormalMapSpace* out) {
  if (name == "world") *out = NormalMapSpace::kWorld;
  else if (name == "tangent") *out = NormalMapSpace::kTangent;
  else return false;
  return true;
}

Vec3 NormalFromMapValue(const Vec3& value, NormalMapSpace space, const Vec3& n, const Vec3& dpdu) {
  if (!(value.squaredNorm() > 1e-12)) return n;
  const Vec3 w = space == NormalMapSpace::kTangent ? TangentFrame(n, dpdu).ToWorld(value) : value;
  return w.squaredNorm() > 1e-12 ? Vec3(w.normalized()) : n;
}

Vec3 MapValueFromNormal(const Vec3& normal, NormalMapSpace space, const Vec3& n, const Vec3& dpdu) {
  const Vec3 u = normal.normalized();
  return space == NormalMapSpace::kTangent ? TangentFrame(n, dpdu).ToLocal(u) : u;
}

}  // namespace svbrdf
