#include "gather/gather.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/error.h"
#include "core/parallel.h"
#include "atlas/charts.h"
#include "core/progress.h"
#include "gather/footprint_quadrature.h"
#include "gather/lookup_rays.h"
#include "raytrace/raytracer.h"

namespace svbrdf {

void GatherOptions::Check() const {
  if (texture_size != 0 && (texture_size < 4 || texture_size > 8192))
    throw Error(Msg("gather: texture size must be 0 (automatic) or in [4, 8192], got ", texture_size));
  if (!(min_cos >= 0 && min_cos < 1)) throw Error(Msg("gather: min_cos must be in [0, 1), got ", min_cos));
  if (!(noise_floor >= 0 && std::isfinite(noise_floor))) throw Error(Msg("gather: noise floor must be finite and >= 0, got ", noise_floor));
  if (!(min_signal_fraction >= 0 && min_signal_fraction <= 1))
    throw Error(Msg("gather: min signal fraction must be in [0, 1], got ", min_signal_fraction));
  if (!(texel_footprint > 0 && texel_footprint <= 1000))
    throw Error(Msg("gather: texel footprint must be in (0, 1000] pixels, got ", texel_footprint));
  if (footprint_rays < 0 || footprint_rays > 8)
    throw Error(Msg("gather: footprint rays must be in [0, 8] per pixel side, got ", footprint_rays));
  if (!(max_footprint_turn_deg >= 0 && max_footprint_turn_deg <= 180))
    throw Error(Msg("gather: max footprint turn must be in [0, 180] degrees, got ", max_footprint_turn_deg));
  if (!(max_foreign_share >= 0 && max_foreign_share <= 1))
    throw Error(Msg("gather: max foreign share must be in [0, 1], got ", max_foreign_share));
  if (!(border_texel_max_offset >= 0 && std::isfinite(border_texel_max_offset)))
    throw Error(Msg("gather: border texel max offset must be finite and >= 0 texels, got ", border_texel_max_offset));
  if (!(footprint_min_tilt_deg >= 0 && footprint_min_tilt_deg <= 90))
    throw Error(Msg("gather: footprint min tilt must be in [0, 90] degrees, got ", footprint_min_tilt_deg));
  if (footprint_subsamples < 0 || footprint_subsamples > 8)
    throw Error(Msg("gather: footprint subsamples must be in [0, 8] rays per pixel side, got ", footprint_subsamples));
  if (probe_rays < 0 || probe_rays > 8)
    throw Error(Msg("gather: probe rays must be in [0, 8] per pixel side, got ", probe_rays));
  if (!(max_unlit_share >= 0 && max_unlit_share <= 1))
    throw Error(Msg("gather: max unlit share must be in [0, 1], got ", max_unlit_share));
  if (!(max_probe_foreign_share >= 0 && max_probe_foreign_share <= 1))
    throw Error(Msg("gather: max probe foreign share must be in [0, 1], got ", max_probe_foreign_share));
  if (!(contrast_min_turn_deg >= 0 && contrast_min_turn_deg <= 180))
    throw Error(Msg("gather: contrast min turn must be in [0, 180] degrees, got ", contrast_min_turn_deg));
  if (!(max_lookup_contrast >= 0 && max_lookup_contrast <= 1))
    throw Error(Msg("gather: max lookup contrast must be in [0, 1], got ", max_lookup_contrast));
  if (max_atlas_size < 16 || max_atlas_size > 16384)
    throw Error(Msg("gather: max atlas size must be in [16, 16384], got ", max_atlas_size));
}

std::string GatherStats::Report(bool with_warnings) const {
  std::ostringstream os;
  os << "samples kept " << kept << " of " << candidates << " texel-views (" << texels << " texels); rejected: "
     << border_texel << " on chart-border texels, " << outside_image << " outside image, " << back_facing << " back-facing/grazing view, " << occluded
     << " occluded, " << outside_mask << " outside mask, " << unlit << " unlit/grazing light, " << shadowed
     << " shadowed, " << saturated << " saturated, " << invalid << " non-finite/negative pixel";
  if (turning > 0) os << ", " << turning << " normal turning within the pixel";
  if (footprint_median_tilt_deg > 0)
    os << "; footprint sub-samples " << (footprint_kept ? "kept" : "off") << " (median pixel-normal tilt "
       << footprint_median_tilt_deg << " deg)";
  if (probe_foreign > 0) os << ", " << probe_foreign << " footprint on another surface";
  if (probe_unlit > 0) os << ", " << probe_unlit << " footprint partly unlit";
  if (contrast > 0) os << ", " << contrast << " photo changing steeply within the lookup";
  if (with_warnings)
    for (const std::string& w : warnings) os << "\n  warning: " << w;
  return os.str();
}

namespace {

enum Reason : uint8_t { kKept, kNotRequested, kBorderTexel, kOutsideImage, kBackFacing, kOccluded, kOutsideMask, kUnlit, kShadowed, kSaturated, kInvalid, kTurning, kProbeUnlit, kProbeForeign, kContrast };

// How fast the smooth normal turns on texel t's triangle: the largest angle
// between two of its vertex normals over the length of its longest edge (rad/m).
double NormalTurnRate(const Mesh& mesh, const Texel& t) {
  if (mesh.normals.size() != mesh.positions.size()) return 0.0;
  const Vec3i& f = mesh.faces[t.prim];
  double angle = 0, edge = 0;
  for (int k = 0; k < 3; ++k) {
    const int a = f[k], b = f[(k + 1) % 3];
    angle = std::max(angle, std::acos(std::clamp(mesh.normals[a].dot(mesh.normals[b]), -1.0, 1.0)));
    edge = std::max(edge, (mesh.positions[a] - mesh.positions[b]).norm());
  }
  return edge > 0 ? angle / edge : 0.0;
}

struct Record {
  uint8_t reason = kOutsideImage;
  bool signal = false;  // a channel above the noise floor
  float wi[3], wo[3], geom, y[3];
  float footprint[3 * SampleSet::kFootprintSubsamples] = {};  // GatherOptions::footprint_subsamples
  float pixel_tilt = 0;  // the largest tilt of the lookup pixels' mean normals (footprint_min_tilt_deg)
  SampleProbe probe;
};

// GatherOptions::probe_rays: the lookup's rays (ForEachLookupRay). A ray
// that misses or hits farther than `tolerance` from x is foreign; on the
// others the light is tested as at the texel centre (facing, shadow ray from
// the hit, offset along its geometric normal).
SampleProbe ProbeFootprint(const RayTracer& tracer, const Camera& cam, const Rigid3& world_from_cam, const Vec3& eye,
                           const Light& light, const Vec3& x, const Vec3& n, double tolerance, double eps, double px,
                           double py, int rays) {
  double foreign = 0, unlit = 0, total = 0, min_cos = 1;
  ForEachLookupRay(tracer, cam, world_from_cam, eye, px, py, rays, [&](double w, bool hit, const Hit& h, int) {
    total += w;
    const Vec3 q = hit ? tracer.Position(h) : Vec3::Zero();
    if (!hit || (q - x).norm() > tolerance) {
      foreign += w;
      return;
    }
    const Vec3 ns = tracer.ShadingNormal(h);
    Vec3 ng = h.geometric_normal;
    if (ng.dot(ns) < 0) ng = -ng;
    min_cos = std::min(min_cos, ns.dot(n));
    const LightSample ls = SampleLight(light, q, world_from_cam.rotation, eye);
    if (!(ns.dot(ls.wi) > 0) ||
        tracer.Occluded(q + ng * eps, ls.wi, 0.0, std::isinf(ls.distance) ? 1e30 : ls.distance - 2 * eps))
      unlit += w;
  });
  SampleProbe out;
  if (!(total > 0)) return out;
  out.foreign = static_cast<float>(foreign / total);
  out.unlit = static_cast<float>(total - foreign > 0 ? unlit / (total - foreign) : 0.0);
  out.spread_deg = static_cast<float>(std::acos(std::clamp(min_cos, -1.0, 1.0)) * 180 / kPi);
  return out;
}

// The mean shading normal seen by the lookup's rays (ForEachLookupRay).
// Rays that miss, or hit farther than `tolerance` from x (another surface in
// front or behind: an occluding edge), count as foreign. Returns false when
// their share exceeds max_foreign_share; otherwise *mean is the
// (unnormalised) weighted mean of the others.
bool FootprintNormal(const RayTracer& tracer, const Camera& cam, const Rigid3& world_from_cam, const Vec3& eye,
                     const Vec3& x, double tolerance, double px, double py, int n, double max_foreign_share,
                     Vec3* mean) {
  Vec3 sum = Vec3::Zero();
  double foreign = 0, total = 0;
  ForEachLookupRay(tracer, cam, world_from_cam, eye, px, py, n, [&](double w, bool hit, const Hit& h, int) {
    total += w;
    if (!hit || (tracer.Position(h) - x).norm() > tolerance) {
      foreign += w;
      return;
    }
    sum += w * tracer.ShadingNormal(h);
  });
  if (!(total > 0) || foreign > max_foreign_share * total) return false;
  *mean = sum / (total - foreign);
  return mean->norm() > 1e-6;
}

// GatherOptions::footprint_subsamples: the lookup's rays (ForEachLookupRay)
// that meet this patch (within `tolerance` of x), each as the tilt of its
// shading normal in `frame`, reduced to SampleSet::footprint's entries of
// one sample (footprint_quadrature.h), and the largest tilt of the pixels'
// mean normals (`pixel_tilt`, what GatherOptions::footprint_min_tilt_deg
// compares). Rays whose normal faces away from the frame's are left out.
// Returns false when no ray is left.
bool FootprintSubsamples(const RayTracer& tracer, const Camera& cam, const Rigid3& world_from_cam, const Vec3& eye,
                         const Vec3& x, const Frame& frame, double tolerance, double px, double py, int n,
                         float* out, float* pixel_tilt) {
  static_assert(SampleSet::kFootprintSubsamples <= kMaxFootprintEntries);
  FootprintRay rays[kMaxFootprintRays];  // GatherOptions::Check: n <= 8
  int count = 0;
  ForEachLookupRay(tracer, cam, world_from_cam, eye, px, py, n, [&](double w, bool hit, const Hit& h, int p) {
    if (!hit || (tracer.Position(h) - x).norm() > tolerance) return;
    const Vec3 m = frame.ToLocal(tracer.ShadingNormal(h));
    if (m.z() > 0.2 * m.norm()) rays[count++] = {m.x() / m.z(), m.y() / m.z(), w, p};
  });
  *pixel_tilt = float(LargestEntryTilt(rays, count, SampleSet::kFootprintSubsamples));
  return ReduceFootprintRays(rays, count, SampleSet::kFootprintSubsamples, out);
}

}  // namespace

double MedianPixelFootprint(const Scene& scene, const Mesh& mesh, double min_cos) {
  std::vector<double> footprints;
  const size_t step = std::max<size_t>(1, mesh.positions.size() / 2000);
  for (const ImageEntry& e : scene.images) {
    const Camera& cam = scene.CameraById(e.camera);
    const Vec3 eye = e.cam_from_world.CentreInWorld();
    for (size_t v = 0; v < mesh.positions.size(); v += step) {
      const Vec3& x = mesh.positions[v];
      const Vec3 xc = e.cam_from_world * x;
      if (xc.z() <= 1e-9) continue;
      if (v < mesh.normals.size() && mesh.normals[v].dot((eye - x).normalized()) < min_cos) continue;
      const Vec2 px = cam.Project(xc);
      if (!(px.x() >= 0 && px.y() >= 0 && px.x() <= cam.width && px.y() <= cam.height)) continue;
      // Length per pixel head-on: a small step across the ray, in pixels.
      const double d = 1e-3 * xc.z();
      const double pixels = (cam.Project(xc + Vec3(d, 0, 0)) - px).norm();
      if (pixels > 0) footprints.push_back(d / pixels);
    }
  }
  if (footprints.empty()) return 0.0;
  std::nth_element(footprints.begin(), footprints.begin() + footprints.size() / 2, footprints.end());
  return footprints[footprints.size() / 2];
}

int UvTextureSize(const Mesh& mesh, double texel_size, int max_size) {
  std::vector<std::pair<double, double>> ratio;  // (sqrt(surface / UV area), surface area)
  double total = 0;
  for (size_t f = 0; f < mesh.faces.size() && f < mesh.face_uvs.size(); ++f) {
    const Vec3i& v = mesh.faces[f];
    const Vec3i& t = mesh.face_uvs[f];
    const double a3 = 0.5 * (mesh.positions[v[1]] - mesh.positions[v[0]]).cross(mesh.positions[v[2]] - mesh.positions[v[0]]).norm();
    const Vec2 e1 = mesh.texcoords[t[1]] - mesh.texcoords[t[0]], e2 = mesh.texcoords[t[2]] - mesh.texcoords[t[0]];
    const double auv = 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
    if (!(auv > 0) || !(a3 > 0)) continue;
    ratio.emplace_back(std::sqrt(a3 / auv), a3);
    total += a3;
  }
  if (ratio.empty() || !(texel_size > 0)) return 0;
  std::sort(ratio.begin(), ratio.end());
  double acc = 0, median = ratio.back().first;
  for (const auto& [r, a] : ratio)
    if ((acc += a) >= 0.5 * total) {
      median = r;
      break;
    }
  return int(std::clamp(std::lround(median / texel_size), 16L, long(std::max(16, max_size))));
}

GatherResult Gather(const Scene& scene, const GatherOptions& options) {
  options.Check();
  // Texel gathering follows rays from each camera's centre; an orthographic
  // rig has one fixed view and takes the per-pixel path (lib/photometric).
  for (const Camera& cam : scene.cameras)
    if (cam.IsOrthographic())
      throw Error(Msg("camera ", cam.id, ": ORTHOGRAPHIC cameras are reconstructed per pixel (one fixed view, "
                      "directional lights: lib/photometric); the texel gather needs perspective cameras"));
  GatherResult out;
  out.mesh = LoadMesh(scene.Resolve(scene.mesh));
  out.mesh.Validate(scene.Resolve(scene.mesh));
  int size = options.texture_size;
  // A texel of about `texel_footprint` pixel footprints at the median view,
  // for the chart atlas and for an automatic UV atlas size: finer texels
  // would hold too few samples each, coarser ones blur the material.
  double footprint = 0;
  if (!out.mesh.HasUVs() || size == 0) {
    footprint = MedianPixelFootprint(scene, out.mesh, options.min_cos);
    if (!(footprint > 0)) throw Error(Msg(scene.mesh, ": no vertex of the mesh is seen by any photo"));
  }
  if (out.mesh.HasUVs() && size == 0) {
    size = UvTextureSize(out.mesh, options.texel_footprint * footprint, options.max_atlas_size);
    if (size == 0) throw Error(Msg(scene.mesh, ": the texture coordinates span no area"));
    std::fprintf(stderr, "  atlas: %dx%d texels from the mesh's texture coordinates (texel ~%.3g pixel footprints of %.3g)\n",
                 size, size, options.texel_footprint, footprint);
  }
  if (!out.mesh.HasUVs()) {
    ChartAtlasOptions co;
    co.max_resolution = options.max_atlas_size;
    co.texel_size = options.texel_footprint * footprint;
    ChartAtlasInfo info;
    out.mesh = MakeChartAtlasUVs(out.mesh, co, &info);
    size = info.resolution;
    out.made_uvs = true;
    std::fprintf(stderr, "  chart atlas: %d charts, %dx%d texels of %.3g (pixel footprint %.3g), %.0f %% filled\n",
                 info.charts, size, size, info.texel_size, footprint, 100 * info.fill);
  }
  out.atlas = BuildAtlas(out.mesh, size, size, 1, out.made_uvs);
  const Atlas& atlas = out.atlas;
  if (out.made_uvs) {
    const long border = std::count_if(atlas.texels.begin(), atlas.texels.end(), [](const Texel& t) { return !t.interior; });
    std::fprintf(stderr, "  chart atlas: %zu texels, %ld of them (%.0f %%) outside every chart triangle\n",
                 atlas.texels.size(), border, 100.0 * border / std::max<size_t>(1, atlas.texels.size()));
  }
  const long nt = static_cast<long>(atlas.texels.size());
  if (nt == 0) throw Error(Msg(scene.mesh, ": texture coordinates cover no texel of a ", size, "^2 atlas"));
  RayTracer tracer(out.mesh);
  const double eps = 1e-4;  // ray offset (metres)
  // See GatherOptions::border_texel_samples.
  const bool no_border = out.made_uvs && !options.border_texel_samples;
  const int footprint_rays = options.footprint_rays;
  std::vector<double> turn_rate;
  if (options.max_footprint_turn_deg > 0 || (options.max_lookup_contrast < 1 && options.contrast_min_turn_deg > 0))
    for (const Texel& t : atlas.texels) turn_rate.push_back(NormalTurnRate(out.mesh, t));
  const double max_turn = options.max_footprint_turn_deg * kPi / 180;
  const double min_contrast_turn = options.contrast_min_turn_deg * kPi / 180;

  // GatherOptions::sample_texel, once per texel.
  std::vector<char> requested;
  if (options.sample_texel) {
    requested.resize(nt);
    ParallelFor(nt, options.threads, [&](long t) { requested[t] = options.sample_texel(atlas.texels[t]); }, 1024);
  }

  // Kept samples per image (texel, record); one full-size scratch buffer is
  // reused across images, so memory grows with kept samples, not texels x views.
  std::vector<std::vector<std::pair<int32_t, Record>>> per_image(scene.images.size());
  std::vector<Record> recs(nt);
  GatherStats& st = out.stats;
  st.texels = nt;
  Progress progress("gather samples", static_cast<long>(scene.images.size()), options.progress);
  for (size_t i = 0; i < scene.images.size(); ++i) {
    const ImageEntry& e = scene.images[i];
    const Camera& cam = scene.CameraById(e.camera);
    const Light& light = scene.LightById(e.light);
    const std::string view = Msg("images[", i, "] (", e.file, ")");
    const Image img = ReadImage(scene.Resolve(e.file), scene.images_color_space);
    if (img.width != cam.width || img.height != cam.height)
      throw Error(Msg(view, ": image is ", img.width, "x", img.height, " but camera ", cam.id, " is ", cam.width, "x",
                      cam.height));
    if (img.channels < 1) throw Error(Msg(view, ": image has no channels"));
    Image mask;
    if (!e.mask.empty()) {
      mask = ReadImage(scene.Resolve(e.mask));
      if (mask.width != cam.width || mask.height != cam.height)
        throw Error(Msg(view, ": mask ", e.mask, " is ", mask.width, "x", mask.height, " but camera ", cam.id, " is ",
                        cam.width, "x", cam.height));
    }
    const Rigid3 world_from_cam = e.cam_from_world.Inverse();
    const Vec3 eye = world_from_cam.translation;
    std::fill(recs.begin(), recs.end(), Record{});
    ParallelFor(nt, options.threads, [&](long t) {
      const Texel& tx = atlas.texels[t];
      Record& r = recs[t];
      if (!requested.empty() && !requested[t]) return void(r.reason = kNotRequested);
      if (no_border && !tx.interior) {
        // Distance (texels) from the texel centre to the clamped point it measures.
        const Vec2 offset = UvToTexel(TexelUv(out.mesh, tx), atlas.width, atlas.height) - Vec2(tx.x + 0.5, tx.y + 0.5);
        if (offset.norm() > options.border_texel_max_offset) return void(r.reason = kBorderTexel);
      }
      const Vec3 x = tx.position, n = tx.normal;
      const Vec3 xc = e.cam_from_world * x;
      if (xc.z() <= 1e-9) return void(r.reason = kOutsideImage);
      const Vec2 px = cam.Project(xc);
      // Bilinear footprint must lie inside the image.
      if (!(px.x() >= 1.0 && px.y() >= 1.0 && px.x() <= cam.width - 1.0 && px.y() <= cam.height - 1.0))
        return void(r.reason = kOutsideImage);
      Vec3 to_eye = eye - x;
      const double dist = to_eye.norm();
      to_eye /= dist;
      if (n.dot(to_eye) < options.min_cos) return void(r.reason = kBackFacing);
      const double footprint_turn = turn_rate.empty() ? 0.0 : turn_rate[t] * dist / cam.fx() / n.dot(to_eye);
      if (options.max_footprint_turn_deg > 0 && footprint_turn > max_turn) return void(r.reason = kTurning);
      if (tracer.Occluded(x + n * eps, to_eye, 0.0, dist - 2 * eps)) return void(r.reason = kOccluded);
      const int x0 = static_cast<int>(std::floor(px.x() - 0.5)), y0 = static_cast<int>(std::floor(px.y() - 0.5));
      if (!e.mask.empty()) {
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx)
            if (!(mask.at(x0 + dx, y0 + dy, 0) > 0)) return void(r.reason = kOutsideMask);  // NaN: outside
      }
      const double tolerance = LookupPatchTolerance(dist, cam.fx(), n.dot(to_eye));  // of the footprint measures
      // The normal the pixel value belongs to (see GatherOptions::footprint_rays).
      Vec3 ns = n;
      double foreshortening = 1.0;
      if (footprint_rays > 0) {
        Vec3 mean;
        if (!FootprintNormal(tracer, cam, world_from_cam, eye, x, tolerance, px.x(), px.y(), footprint_rays,
                             options.max_foreign_share, &mean))
          return void(r.reason = kOccluded);
        foreshortening = std::min(1.0, mean.norm());
        ns = mean.normalized();
        if (ns.dot(to_eye) < options.min_cos) return void(r.reason = kBackFacing);
      }
      if (options.footprint_subsamples > 0) {
        if (!FootprintSubsamples(tracer, cam, world_from_cam, eye, x, Frame::FromNormalTangent(ns, tx.tangent),
                                 tolerance, px.x(), px.y(), options.footprint_subsamples, r.footprint,
                                 &r.pixel_tilt))
          return void(r.reason = kOccluded);
      }
      const LightSample ls = SampleLight(light, x, world_from_cam.rotation, eye);
      if (ns.dot(ls.wi) < options.min_cos) return void(r.reason = kUnlit);
      const double cos_i = n.dot(ls.wi);
      if (cos_i < options.min_cos || !(ls.normal_irradiance > 0).all()) return void(r.reason = kUnlit);
      if (tracer.Occluded(x + n * eps, ls.wi, 0.0, std::isinf(ls.distance) ? 1e30 : ls.distance - 2 * eps))
        return void(r.reason = kShadowed);
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx)
          for (int c = 0; c < img.channels; ++c) {
            const float v = img.at(x0 + dx, y0 + dy, c);
            if (!(v >= 0) || !std::isfinite(v)) return void(r.reason = kInvalid);
            if (v >= img.saturation_level) return void(r.reason = kSaturated);
          }
      const Frame frame = Frame::FromNormalTangent(ns, tx.tangent);
      const Vec3 wi = frame.ToLocal(ls.wi), wo = frame.ToLocal(to_eye);
      // Measurement model (samples.h): value_c / exposure = f_c * cos_i * E_c;
      // with s = mean_c E_c: y_c = value_c / exposure * s / E_c, geom = cos_i * s.
      const double s = ls.normal_irradiance.mean();
      for (int c = 0; c < 3; ++c) {
        const double v = img.Bilinear(px.x(), px.y(), std::min(c, img.channels - 1));
        r.y[c] = static_cast<float>(v / e.exposure * s / ls.normal_irradiance[c]);
        r.wi[c] = static_cast<float>(wi[c]);
        r.wo[c] = static_cast<float>(wo[c]);
      }
      r.geom = static_cast<float>(ns.dot(ls.wi) * foreshortening * s);
      // A finite pixel can still give a non-finite sample (extreme light or
      // exposure values); no fit may ever see one.
      if (!std::isfinite(r.geom) || !(r.geom > 0) || !std::isfinite(r.y[0]) || !std::isfinite(r.y[1]) ||
          !std::isfinite(r.y[2]) || !(r.y[0] >= 0 && r.y[1] >= 0 && r.y[2] >= 0))
        return void(r.reason = kInvalid);
      float peak = 0;
      for (int c = 0; c < 3; ++c) peak = std::max(peak, img.Bilinear(px.x(), px.y(), std::min(c, img.channels - 1)));
      r.signal = peak > options.noise_floor;
      double lo = 1e300, hi = 0;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          double v = 0;
          for (int c = 0; c < img.channels; ++c) v += img.at(x0 + dx, y0 + dy, c) / img.channels;
          lo = std::min(lo, v), hi = std::max(hi, v);
        }
      const double contrast = (hi - lo) / (hi + lo + 2 * options.noise_floor);
      if (contrast > options.max_lookup_contrast && footprint_turn >= min_contrast_turn)
        return void(r.reason = kContrast);
      if (options.probe_rays > 0) {
        r.probe = ProbeFootprint(tracer, cam, world_from_cam, eye, light, x, n, tolerance, eps, px.x(), px.y(),
                                 options.probe_rays);
      }
      r.probe.contrast = static_cast<float>(contrast);  // beside the probe's own measures
      if (options.probe_rays > 0) {
        if (r.probe.foreign > options.max_probe_foreign_share) return void(r.reason = kProbeForeign);
        if (r.probe.unlit > options.max_unlit_share) return void(r.reason = kProbeUnlit);
      }
      r.reason = kKept;
    }, 256);
    long kept = 0, signal = 0;
    const long invalid_before = st.invalid, saturated_before = st.saturated;
    for (long t = 0; t < nt; ++t) {
      const Record& r = recs[t];
      if (r.reason == kNotRequested) continue;  // GatherOptions::sample_texel
      ++st.candidates;
      switch (r.reason) {
        case kNotRequested: break;  // (skipped above: not a candidate)
        case kKept: ++kept; signal += r.signal; per_image[i].emplace_back(static_cast<int32_t>(t), r); break;
        case kBorderTexel: ++st.border_texel; break;
        case kOutsideImage: ++st.outside_image; break;
        case kBackFacing: ++st.back_facing; break;
        case kOccluded: ++st.occluded; break;
        case kOutsideMask: ++st.outside_mask; break;
        case kUnlit: ++st.unlit; break;
        case kShadowed: ++st.shadowed; break;
        case kSaturated: ++st.saturated; break;
        case kInvalid: ++st.invalid; break;
        case kTurning: ++st.turning; break;
        case kProbeUnlit: ++st.probe_unlit; break;
        case kProbeForeign: ++st.probe_foreign; break;
        case kContrast: ++st.contrast; break;
      }
    }
    if (kept > 0 && signal == 0)
      st.warnings.push_back(Msg(view, ": all ", kept, " kept samples are below the noise floor ", options.noise_floor,
                                " (black photo? check its light and exposure)"));
    st.signal += signal;
    if (st.invalid > invalid_before)
      st.warnings.push_back(Msg(view, ": ", st.invalid - invalid_before,
                                " samples rejected for non-finite or negative pixel values (a broken HDR merge?)"));
    // Saturated samples are dropped one by one; a view that loses most of
    // its lit samples that way was overexposed (or its file clips: a half
    // EXR at 65504), which the user should hear about by name.
    const long saturated = st.saturated - saturated_before;
    if (saturated > 0 && saturated >= kept)
      st.warnings.push_back(Msg(view, ": ", saturated, " of ", saturated + kept,
                                " lit samples are saturated (pixel value >= ", img.saturation_level,
                                "): lower the exposure"));
    st.kept += kept;
    st.kept_per_image.push_back(kept);
    progress.Tick();
  }
  progress.Finish();
  // Named after the scene: a wrong camera, pose or light there is the usual cause.
  if (st.kept == 0)
    throw Error(Msg(scene.Resolve("scene.json"), ": no usable samples in ", scene.images.size(),
                    st.saturated > 0 ? Msg(" views (", st.saturated, " lit samples saturated: overexposed photos?): ")
                                     : std::string(" views (check cameras, poses, lights and masks): "),
                    st.Report()));
  if (st.signal == 0 || double(st.signal) < options.min_signal_fraction * double(st.kept))
    throw Error(Msg(scene.Resolve("scene.json"), ": no signal: only ", st.signal, " of ", st.kept, " kept samples in ", scene.images.size(),
                    " views are above the noise floor (pixel value ", options.noise_floor,
                    "); the photos are (nearly) black. Check the exposure (scene.json images[].exposure and the "
                    "camera's), that the lights were on and match scene.json lights[], and that the masks cover "
                    "the object. ", st.Report(false)));

  // Counting sort by texel (stable in image order), into structure of arrays.
  SampleSet& ss = out.samples;
  ss.num_texels = static_cast<int>(nt);
  ss.texel_begin.assign(nt + 1, 0);
  for (const auto& kept : per_image)
    for (const auto& [t, r] : kept) ss.texel_begin[t + 1]++;
  for (long t = 0; t < nt; ++t) ss.texel_begin[t + 1] += ss.texel_begin[t];
  // Images are visited in order and each lists its texels in order, so a
  // running cursor per texel yields samples sorted by texel, then image.
  ss.texel.resize(st.kept);
  ss.image.resize(st.kept);
  ss.geom.resize(st.kept);
  for (int k = 0; k < 3; ++k) ss.wi[k].resize(st.kept), ss.wo[k].resize(st.kept), ss.y[k].resize(st.kept);
  std::vector<int64_t> cursor(ss.texel_begin.begin(), ss.texel_begin.end() - 1);
  if (options.probe_rays > 0) out.probes.resize(st.kept);
  constexpr int kFp = 3 * SampleSet::kFootprintSubsamples;
  if (options.footprint_subsamples > 0) ss.footprint.resize(size_t(st.kept) * kFp);
  std::vector<float> pixel_tilt(options.footprint_subsamples > 0 ? st.kept : 0);
  for (size_t i = 0; i < per_image.size(); ++i)
    for (const auto& [t, r] : per_image[i]) {
      const int64_t s = cursor[t]++;
      if (options.probe_rays > 0) out.probes[s] = r.probe;
      ss.texel[s] = t;
      ss.image[s] = static_cast<int32_t>(i);
      ss.geom[s] = r.geom;
      if (options.footprint_subsamples > 0) {
        std::copy(r.footprint, r.footprint + kFp, ss.footprint.begin() + s * kFp);
        pixel_tilt[s] = r.pixel_tilt;
      }
      for (int k = 0; k < 3; ++k) ss.wi[k][s] = r.wi[k], ss.wo[k][s] = r.wo[k], ss.y[k][s] = r.y[k];
    }
  if (options.footprint_subsamples > 0) {
    // GatherOptions::footprint_min_tilt_deg: the sub-samples only where the
    // normal turns within the pixels.
    std::nth_element(pixel_tilt.begin(), pixel_tilt.begin() + pixel_tilt.size() / 2, pixel_tilt.end());
    st.footprint_median_tilt_deg = std::atan(double(pixel_tilt[pixel_tilt.size() / 2])) * 180 / kPi;
    st.footprint_kept = st.footprint_median_tilt_deg >= options.footprint_min_tilt_deg;
    if (!st.footprint_kept) ss.footprint.clear();
  }
  return out;
}

}  // namespace svbrdf
