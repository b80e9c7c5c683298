// COLMAP camera projection templated on the scalar, so Ceres Jets flow
// through (lib/camera's Camera::Project is the double version; the two are
// compared in tests/registration_test.cc).
#pragma once
#include "camera/camera.h"

namespace svbrdf {

// Camera-frame point -> pixel (COLMAP convention) for `model` with `params`
// in COLMAP's order.
template <class T>
void ProjectT(CameraModelId model, const T* params, const T* x_cam, T* pixel) {
  const T u = x_cam[0] / x_cam[2], v = x_cam[1] / x_cam[2];
  const T r2 = u * u + v * v;
  T du = u, dv = v, fx = T(0), fy = T(0), cx = T(0), cy = T(0);
  switch (model) {
    case CameraModelId::kSimplePinhole: fx = fy = params[0], cx = params[1], cy = params[2]; break;
    case CameraModelId::kPinhole:
    case CameraModelId::kOrthographic:  // never reaches here: board bundles reject it (board_bundle.cc)
      fx = params[0], fy = params[1], cx = params[2], cy = params[3];
      break;
    case CameraModelId::kSimpleRadial:
      fx = fy = params[0], cx = params[1], cy = params[2];
      du = u * (T(1) + params[3] * r2), dv = v * (T(1) + params[3] * r2);
      break;
    case CameraModelId::kRadial: {
      fx = fy = params[0], cx = params[1], cy = params[2];
      const T s = T(1) + params[3] * r2 + params[4] * r2 * r2;
      du = u * s, dv = v * s;
      break;
    }
    case CameraModelId::kOpenCV: {
      fx = params[0], fy = params[1], cx = params[2], cy = params[3];
      const T k1 = params[4], k2 = params[5], p1 = params[6], p2 = params[7];
      const T radial = k1 * r2 + k2 * r2 * r2, uv = u * v;
      du = u + u * radial + T(2) * p1 * uv + p2 * (r2 + T(2) * u * u);
      dv = v + v * radial + T(2) * p2 * uv + p1 * (r2 + T(2) * v * v);
      break;
    }
  }
  pixel[0] = fx * du + cx;
  pixel[1] = fy * dv + cy;
}

}  // namespace svbrdf
