#include "photometric/observations.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "raytrace/raytracer.h"

namespace svbrdf {

namespace {

// d sRGB / d linear at v, from the darkest step of an 8-bit photo up (below
// it the slope would reward fitting quantisation noise).
double SrgbSlopeFloored(double v) {
  v = std::max(v, 1.0 / 255);
  if (v >= 1.0) return 1.055 / 2.4;
  if (v <= 0.0031308) return 12.92;
  return 1.055 / 2.4 * std::pow(v, 1.0 / 2.4 - 1.0);
}

}  // namespace

bool IsPhotometricCapture(const Scene& scene) {
  if (scene.images.empty()) return false;
  const ImageEntry& first = scene.images.front();
  if (!scene.CameraById(first.camera).IsOrthographic()) return false;
  for (const ImageEntry& e : scene.images) {
    if (e.camera != first.camera) return false;
    if (!e.cam_from_world.rotation.isApprox(first.cam_from_world.rotation, 1e-9) ||
        !e.cam_from_world.translation.isApprox(first.cam_from_world.translation, 1e-9))
      return false;
    if (scene.LightById(e.light).type != LightType::kDirectional) return false;
  }
  return true;
}

PsObservations LoadObservations(const Scene& scene, const Mesh& mesh, double srgb_weight_exponent, int threads,
                                bool progress) {
  if (!IsPhotometricCapture(scene))
    throw Error("photometric: the capture is not one fixed ORTHOGRAPHIC view under directional lights");
  PsObservations o;
  const ImageEntry& first = scene.images.front();
  o.cam = scene.CameraById(first.camera);
  o.cam_from_world = first.cam_from_world;
  o.width = o.cam.width, o.height = o.cam.height;
  o.lights = int(scene.images.size());
  const Rigid3 world_from_cam = o.cam_from_world.Inverse();
  // Region: pixel centres whose ray meets the mesh.
  RayTracer tracer(mesh);
  o.region = Image(o.width, o.height, 1);
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      Vec3 origin, dir;
      o.cam.PixelRay(Vec2(x + 0.5, y + 0.5), &origin, &dir);
      Hit hit;
      if (tracer.Intersect(world_from_cam * origin, world_from_cam.rotation * dir.normalized(), &hit)) {
        o.region.at(x, y, 0) = 1.0f;
        o.pixel.push_back(y * o.width + x);
        o.depth.push_back((o.cam_from_world * tracer.Position(hit)).z());
      }
    }
  if (o.pixel.empty()) throw Error(Msg(scene.mesh, ": the mesh covers no pixel of the photometric view"));
  const long P = o.P();
  o.value.assign(size_t(P) * o.lights * 3, 0.0f);
  o.weight.assign(size_t(P) * o.lights * 3, 0.0f);
  for (const ImageEntry& e : scene.images) {
    const Light& l = scene.LightById(e.light);
    o.to_light.push_back((o.cam_from_world.rotation * l.to_light).normalized());
  }
  Progress bar("read photos", o.lights, progress);
  ParallelFor(o.lights, threads, [&](long l) {
    const ImageEntry& e = scene.images[l];
    const std::string view = Msg("images[", l, "] (", e.file, ")");
    const Image img = ReadImage(scene.Resolve(e.file), scene.images_color_space);
    if (img.width != o.width || img.height != o.height)
      throw Error(Msg(view, ": image is ", img.width, "x", img.height, " but camera ", o.cam.id, " is ", o.width, "x",
                      o.height));
    Image mask;
    if (!e.mask.empty()) {
      mask = ReadImage(scene.Resolve(e.mask));
      if (mask.width != o.width || mask.height != o.height)
        throw Error(Msg(view, ": mask ", e.mask, " is ", mask.width, "x", mask.height, " but the photo is ", o.width,
                        "x", o.height));
    }
    const Rgb irradiance = scene.LightById(e.light).irradiance * e.exposure;
    for (long p = 0; p < P; ++p) {
      const int x = o.pixel[p] % o.width, y = o.pixel[p] / o.width;
      if (mask.width && mask.at(x, y, 0) <= 0) continue;
      bool saturated = false;
      for (int c = 0; c < 3; ++c) saturated |= img.at(x, y, std::min(c, img.channels - 1)) >= img.saturation_level;
      if (saturated) continue;
      for (int c = 0; c < 3; ++c) {
        if (!(irradiance[c] > 0)) continue;
        const double v = img.at(x, y, std::min(c, img.channels - 1));
        o.value[o.At(p, int(l)) + c] = float(v / irradiance[c]);
        o.weight[o.At(p, int(l)) + c] = float(std::pow(SrgbSlopeFloored(v), srgb_weight_exponent) * irradiance[c]);
      }
    }
    bar.Tick();
  });
  o.valid = Image(o.width, o.height, 1);
  for (long p = 0; p < P; ++p)
    for (int l = 0; l < o.lights; ++l)
      if (o.weight[o.At(p, l)] > 0) o.valid.at(o.pixel[p] % o.width, o.pixel[p] / o.width, 0) = 1.0f;
  return o;
}

Image MeshNormalsCamera(const PsObservations& obs, const Mesh& mesh) {
  RayTracer tracer(mesh);
  const Rigid3 world_from_cam = obs.cam_from_world.Inverse();
  Image out(obs.width, obs.height, 3);
  for (long p = 0; p < obs.P(); ++p) {
    const int x = obs.pixel[p] % obs.width, y = obs.pixel[p] / obs.width;
    Vec3 origin, dir;
    obs.cam.PixelRay(Vec2(x + 0.5, y + 0.5), &origin, &dir);
    Hit hit;
    Vec3 n(0, 0, -1);
    if (tracer.Intersect(world_from_cam * origin, world_from_cam.rotation * dir.normalized(), &hit))
      n = obs.cam_from_world.rotation * tracer.ShadingNormal(hit);
    for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(n[c]);
  }
  return out;
}

std::vector<uint8_t> CastShadows(const PsObservations& obs, const Mesh& mesh, int threads) {
  RayTracer tracer(mesh);
  const Rigid3 world_from_cam = obs.cam_from_world.Inverse();
  const double pixel = obs.cam.MetresPerPixel(1.0);
  std::vector<uint8_t> shadowed(size_t(obs.P()) * obs.lights, 0);
  ParallelFor(obs.P(), threads, [&](long p) {
    const int x = obs.pixel[p] % obs.width, y = obs.pixel[p] / obs.width;
    Vec3 origin, dir;
    obs.cam.PixelRay(Vec2(x + 0.5, y + 0.5), &origin, &dir);
    Hit hit;
    const Vec3 d = world_from_cam.rotation * dir.normalized();
    if (!tracer.Intersect(world_from_cam * origin, d, &hit)) return;
    // Leave the surface by half a pixel towards the viewer: the height field's
    // facets are a pixel wide, and a smaller step lets a point shadow itself.
    const Vec3 x0 = tracer.Position(hit) - 0.5 * pixel * d;
    for (int l = 0; l < obs.lights; ++l) {
      const Vec3 wi = world_from_cam.rotation * obs.to_light[l];
      shadowed[size_t(p) * obs.lights + l] = tracer.Occluded(x0, wi, 0.0, 1e30) ? 1 : 0;
    }
  }, 64);
  return shadowed;
}

Image LambertianNormals(const PsObservations& obs, const std::vector<uint8_t>& shadowed, int threads,
                        Image* determined, Image* misfit) {
  Image out(obs.width, obs.height, 3);
  if (determined) *determined = Image(obs.width, obs.height, 1);
  if (misfit) *misfit = Image(obs.width, obs.height, 1);
  ParallelFor(obs.P(), threads, [&](long p) {
    std::vector<std::pair<double, int>> lum;
    for (int l = 0; l < obs.lights; ++l) {
      const size_t i = obs.At(p, l);
      if (!obs.UsableRgb(i)) continue;
      if (!shadowed.empty() && shadowed[size_t(p) * obs.lights + l]) continue;
      lum.emplace_back(0.2126 * obs.value[i] + 0.7152 * obs.value[i + 1] + 0.0722 * obs.value[i + 2], l);
    }
    Vec3 n(0, 0, -1);
    std::sort(lum.begin(), lum.end());
    // The interquartile photos: cast and attached shadows, interreflection
    // and 8-bit quantisation live in the darkest quarter, highlights in the
    // brightest; too few left (a pixel mostly in shadow), then all of them.
    size_t lo = lum.size() / 4, hi = (3 * lum.size()) / 4;
    if (hi < lo + 6) lo = 0, hi = lum.size();
    std::vector<std::pair<double, int>> in(lum.begin() + lo, lum.begin() + hi);
    bool solved = false;
    Vec3 g(0, 0, 0);
    for (int round = 0; round < 2 && in.size() >= 3; ++round) {
      Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
      Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
      for (const auto& [v, l] : in) {
        AtA += obs.to_light[l] * obs.to_light[l].transpose();
        Atb += v * obs.to_light[l];
      }
      const Vec3 fit = AtA.ldlt().solve(Atb);
      if (!(fit.norm() > 0) || !fit.allFinite()) break;
      g = fit;
      n = g.normalized();
      solved = true;
      // Photos in attached shadow of this estimate carry no information on it.
      std::vector<std::pair<double, int>> kept;
      for (const auto& e : in)
        if (n.dot(obs.to_light[e.second]) > 0.05) kept.push_back(e);
      if (kept.size() == in.size()) break;
      in.swap(kept);
    }
    if (n.z() > -0.05) n = Vec3(n.x(), n.y(), -0.05).normalized();  // must face the camera
    const int x = obs.pixel[p] % obs.width, y = obs.pixel[p] / obs.width;
    const long lit = std::count_if(in.begin(), in.end(), [](const auto& e) { return e.first > 0; });
    if (determined && solved && lit >= kMinDeterminingPhotos) determined->at(x, y, 0) = 1.0f;
    if (misfit && solved) {
      double sse = 0, sum = 0;
      for (const auto& [v, l] : in) {
        const double r = v - g.dot(obs.to_light[l]);
        sse += r * r, sum += v;
      }
      misfit->at(x, y, 0) = sum > 0 ? float(std::sqrt(sse / in.size()) / (sum / in.size())) : 0.0f;
    }
    for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(n[c]);
  }, 256);
  return out;
}

}  // namespace svbrdf
