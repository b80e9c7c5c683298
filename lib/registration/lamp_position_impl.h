// Template body of SpecularPoint (lamp_position.h).
#pragma once
#include <cmath>

namespace svbrdf {

// Fixed point of x = c + r n, n = bisector of (eye - x) and (lamp - x): a
// contraction with factor about r / distance, so a dozen rounds reach double
// precision for lamps and cameras a few radii away.
template <class T>
void SpecularPoint(const T* eye, const T* lamp, const T* c, double radius, T* x) {
  using std::sqrt;
  auto unit = [](T* v) {
    const T n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int k = 0; k < 3; ++k) v[k] /= n;
  };
  T n[3];
  for (int k = 0; k < 3; ++k) x[k] = c[k];
  for (int round = 0; round < 16; ++round) {
    T a[3], b[3];
    for (int k = 0; k < 3; ++k) a[k] = eye[k] - x[k], b[k] = lamp[k] - x[k];
    unit(a);
    unit(b);
    for (int k = 0; k < 3; ++k) n[k] = a[k] + b[k];
    unit(n);
    for (int k = 0; k < 3; ++k) x[k] = c[k] + T(radius) * n[k];
  }
}

}  // namespace svbrdf
