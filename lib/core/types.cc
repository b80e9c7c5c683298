#include "core/types.h"
#include <cmath>

namespace svbrdf {

Frame Frame::FromNormal(const Vec3& n_in) {
  // Duff et al. 2017, "Building an Orthonormal Basis, Revisited": branchless, continuous except at one pole.
  Vec3 n = n_in.normalized();
  const double sign = std::copysign(1.0, n.z());
  const double a = -1.0 / (sign + n.z());
  const double b = n.x() * n.y() * a;
  Frame f;
  f.n = n;
  f.t = Vec3(1.0 + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
  f.b = Vec3(b, sign + n.y() * n.y() * a, -n.y());
  return f;
}

Frame Frame::FromNormalTangent(const Vec3& n_in, const Vec3& t_in) {
  Vec3 n = n_in.normalized();
  Vec3 t = t_in - n * n.dot(t_in);
  if (!(t.squaredNorm() > 1e-16)) return FromNormal(n);
  Frame f;
  f.n = n;
  f.t = t.normalized();
  f.b = n.cross(f.t);
  return f;
}

}  // namespace svbrdf
