#include "synth/raw_photos.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <unistd.h>

#include "core/error.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "io/output_folder.h"
#include "io/scene.h"
#include "relight/relight.h"
#include "synth/shapes.h"

namespace svbrdf {

namespace fs = std::filesystem;

void RawPhotoOptions::Check() const {
  material.Check();
  if (board_texture.width < 8 || board_texture.channels != 1) throw Error("raw photos: board_texture missing");
  if (!(white_albedo > 0 && white_albedo <= 1 && black_albedo > 0 && black_albedo < white_albedo))
    throw Error("raw photos: albedos must satisfy 0 < black < white <= 1");
  if (num_images < 3 || num_heldout < 0) throw Error("raw photos: num_images must be >= 3, num_heldout >= 0");
  if (width < 64 || height < 64) throw Error("raw photos: width/height must be >= 64");
  if (distortion.size() != 4) throw Error("raw photos: distortion needs k1 k2 p1 p2");
  if (!(object_radius > 0 && distance > 3 * object_radius && sphere_radius > 0 && lamp_radius > 0))
    throw Error("raw photos: sizes must be > 0 and the camera outside the object");
  if (!flash_offset.empty() && flash_offset.size() != 3) throw Error("raw photos: flash_offset must be [x, y, z] metres");
  if (num_lamps < 1 || brackets < 1 || bracket_stops < 0 || spp < 1 || spp > 8)
    throw Error("raw photos: num_lamps, brackets >= 1, spp in [1, 8]");
  if (format != "png16" && format != "png8" && format != "exr")
    throw Error(Msg("raw photos: format '", format, "' unknown; expected png16, png8 or exr"));
}

namespace {

Vec3 RandomUnit(Rng& rng) {
  std::normal_distribution<double> g;
  return Vec3(g(rng), g(rng), g(rng)).normalized();
}

nlohmann::json PoseJson(const Rigid3& p) {
  const auto& q = p.rotation;
  return {{"q", {q.w(), q.x(), q.y(), q.z()}}, {"t", {p.translation.x(), p.translation.y(), p.translation.z()}}};
}

// Ray-sphere: smallest t > 1e-9, or +inf.
double HitSphere(const Vec3& o, const Vec3& d, const Vec3& c, double r) {
  const Vec3 oc = o - c;
  const double b = oc.dot(d), cc = oc.squaredNorm() - r * r, disc = b * b - cc;
  if (disc < 0) return INFINITY;
  const double s = std::sqrt(disc);
  if (-b - s > 1e-9) return -b - s;
  if (-b + s > 1e-9) return -b + s;
  return INFINITY;
}

struct World {
  const RawPhotoOptions* o;
  Eigen::Matrix<double, 2, 3> tex_from_board;
  Vec3 up;
  std::vector<Vec3> spheres;
  std::vector<Vec3> lamps;
  Vec3 object_centre;
  double object_bound;

  // Diffuse albedo of the board plane (table outside the printed area).
  double Albedo(const Vec3& x) const {
    const Vec2 t = tex_from_board * Vec3(x.x(), x.y(), 1.0);
    const Image& tex = o->board_texture;
    if (t.x() < 0 || t.y() < 0 || t.x() >= tex.width || t.y() >= tex.height) return 0.3;
    return o->black_albedo + (o->white_albedo - o->black_albedo) * tex.Bilinear(t.x(), t.y(), 0);
  }
  // Radiance of a non-object ray; *t gets the distance (inf on a miss).
  double Background(const Vec3& eye, const Vec3& d, int lamp, double* t_out) const {
    double t = INFINITY;
    int sphere = -1;
    for (size_t s = 0; s < spheres.size(); ++s) {
      const double ts = HitSphere(eye, d, spheres[s], o->sphere_radius);
      if (ts < t) t = ts, sphere = int(s);
    }
    const double dz = d.z() != 0 ? -eye.z() / d.z() : INFINITY;  // plane z = 0
    const Vec3& L = lamps[lamp];
    if (dz > 1e-9 && dz < t) {
      *t_out = dz;
      const Vec3 x = eye + dz * d;
      const Vec3 to_l = L - x;
      const double r2 = to_l.squaredNorm();
      const double cos_i = std::max(0.0, to_l.normalized().dot(up));
      return Albedo(x) / kPi * o->lamp_intensity * cos_i / r2;
    }
    *t_out = t;
    if (sphere < 0) return 0.0;
    const Vec3 x = eye + t * d;
    const Vec3 n = (x - spheres[sphere]) / o->sphere_radius;
    const Vec3 r = d - 2 * d.dot(n) * n;
    if (std::isfinite(HitSphere(x, r, L, o->lamp_radius)))
      return o->mirror_reflectance * o->lamp_intensity / (kPi * o->lamp_radius * o->lamp_radius);
    return o->mirror_reflectance * (0.02 + 0.05 * std::max(0.0, r.dot(up)));  // dim sky
  }
};

}  // namespace

RawPhotoTruth SynthesizeRawPhotos(const RawPhotoOptions& o, const std::string& out_dir) {
  o.Check();
  OutputFolder out(out_dir);  // complete or absent, also on errors and signals
  const fs::path tmp = out.path();
  for (const char* d : {"photos", "masks", "truth/images", "truth/masks", "truth/heldout/images", "truth/heldout/masks"})
    fs::create_directories(tmp / d);
  Rng rng(StreamSeed(o.seed, 0x7a3));
  std::uniform_real_distribution<double> u01(0, 1);

  World w;
  w.o = &o;
  w.tex_from_board = o.texture_from_board;
  // The printed face is seen from the side where board x, y appear as the
  // drawing's x (right), y (down): z = x cross y points away from the viewer.
  const double det = o.texture_from_board.leftCols(2).determinant();
  w.up = det > 0 ? Vec3(0, 0, -1) : Vec3(0, 0, 1);
  const Eigen::Matrix2d board_from_tex_lin = o.texture_from_board.leftCols(2).inverse();
  auto board_at = [&](double fx, double fy) {  // board point at a fraction of the texture
    const Vec2 t(fx * o.board_texture.width, fy * o.board_texture.height);
    const Vec2 b = board_from_tex_lin * (t - o.texture_from_board.col(2));
    return Vec3(b.x(), b.y(), 0.0);
  };
  const Vec3 board_centre = board_at(0.5, 0.5);
  const Vec3 ex = (board_at(1, 0.5) - board_at(0, 0.5)).normalized(), ey = w.up.cross(ex);

  RawPhotoTruth truth;
  // Object: scaled procedural shape at a random orientation above the centre.
  Mesh object_mesh = MakeShape(o.object, o.detail);
  for (Vec3& p : object_mesh.positions) p *= o.object_radius / 0.5;
  object_mesh.ComputeNormals(NormalWeighting::kArea);  // as the shapes (shapes.h)
  truth.world_from_object.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(2 * kPi * u01(rng), RandomUnit(rng)));
  w.object_centre = board_centre + w.up * (1.25 * o.object_radius);
  truth.world_from_object.translation = w.object_centre;
  w.object_bound = 0;
  Mesh world_mesh = object_mesh;
  for (Vec3& p : world_mesh.positions) {
    w.object_bound = std::max(w.object_bound, p.norm());
    p = truth.world_from_object * p;
  }
  world_mesh.ComputeNormals(NormalWeighting::kArea);
  w.object_bound *= 1.01;
  GroundTruthOptions gto = o.material;
  gto.seed = StreamSeed(o.seed, 1, o.material.seed);
  Material gt = MakeGroundTruth(world_mesh, gto);
  SaveMaterial(gt, (tmp / "truth" / "gt").string());
  SaveObj(object_mesh, (tmp / "mesh.obj").string(), /*write_normals=*/true);  // the normals the photos show

  // Mirror spheres near two opposite corners of the printed board.
  for (auto [fx, fy] : {std::pair{0.14, 0.2}, std::pair{0.86, 0.8}})
    w.spheres.push_back(board_at(fx, fy) + w.up * o.sphere_radius);
  truth.sphere_centres = w.spheres;
  for (int l = 0; l < o.num_lamps; ++l) {
    const double az = 2 * kPi * (l + 0.3 * u01(rng)) / o.num_lamps;
    w.lamps.push_back(board_centre + w.up * (0.45 + 0.25 * u01(rng)) +
                      (0.2 + 0.25 * u01(rng)) * (std::cos(az) * ex + std::sin(az) * ey));
  }

  Camera cam;
  cam.id = 1;
  cam.model = CameraModelId::kOpenCV;
  cam.width = o.width;
  cam.height = o.height;
  const double f = o.focal_factor * o.width;
  cam.params = {f, f * 1.001, o.width / 2.0 + 3.3, o.height / 2.0 - 2.1, o.distortion[0], o.distortion[1],
                o.distortion[2], o.distortion[3]};
  truth.camera = cam;

  const bool flash = !o.flash_offset.empty();
  auto make_scene = [&](int count, double az_offset, bool heldout, Rng& r) {
    Scene s;
    s.mesh = heldout ? "../gt/mesh.obj" : "gt/mesh.obj";
    s.cameras = {cam};
    for (int l = 0; l < (flash ? 0 : o.num_lamps); ++l) {
      Light light;
      light.id = l + 1;
      light.type = LightType::kPoint;
      light.position = w.lamps[l];
      light.intensity = Rgb::Constant(o.lamp_intensity);
      s.lights.push_back(light);
    }
    for (int i = 0; i < count; ++i) {
      const double az = az_offset + 2 * kPi * (i + 0.4 * u01(r)) / count;
      const double t = count > 1 ? double(i % 4) / 3.0 : 0.5;
      const double el = (o.elevation_min_deg + t * (o.elevation_max_deg - o.elevation_min_deg)) * kPi / 180;
      const Vec3 dir = std::cos(el) * (std::cos(az) * ex + std::sin(az) * ey) + std::sin(el) * w.up;
      const Vec3 target = w.object_centre + 0.02 * RandomUnit(r);
      ImageEntry e;
      char name[16];
      std::snprintf(name, sizeof name, "%04d", i);
      e.file = Msg("images/", name, ".exr");
      e.mask = Msg("masks/", name, ".png");
      e.camera = 1;
      e.light = heldout ? 1 + int(u01(r) * o.num_lamps) % o.num_lamps : 1 + i % o.num_lamps;
      e.cam_from_world = Rigid3::LookAt(w.object_centre + o.distance * dir, target, w.up);
      if (flash) {  // a flash of its own for every photo, at the offset in the camera frame
        Light light;
        light.type = LightType::kPoint;
        light.position = e.cam_from_world.Inverse() * Vec3(o.flash_offset[0], o.flash_offset[1], o.flash_offset[2]);
        light.intensity = Rgb::Constant(o.lamp_intensity);
        w.lamps.push_back(light.position);
        light.id = int(w.lamps.size());
        e.light = light.id;
        s.lights.push_back(light);
      }
      s.images.push_back(e);
    }
    return s;
  };
  Scene scene = make_scene(o.num_images, 0.0, false, rng);
  Rng hrng(StreamSeed(o.seed, 0x4e1d));
  Scene held = make_scene(o.num_heldout, 0.5, true, hrng);
  truth.lamps = w.lamps;  // with the flashes of every photo
  scene.dir = (tmp / "truth").string();
  held.dir = (tmp / "truth" / "heldout").string();

  RayTracer tracer(gt.mesh);
  MaterialShader shader(gt);
  RelightOptions ro;
  ro.threads = o.threads;
  ro.progress = false;
  auto render = [&](const Scene& sc, size_t i, Image* color_out, Image* mask_out, bool with_object = true) {
    const ImageEntry& e = sc.images[i];
    const RenderedView obj = RenderView(tracer, shader, sc, i, ro);
    const Rigid3 world_from_cam = e.cam_from_world.Inverse();
    const Vec3 eye = world_from_cam.translation;
    const int lamp = e.light - 1;
    Image color(o.width, o.height, 3), mask(o.width, o.height, 1);
    const int n = o.spp;
    ParallelFor(o.height, o.threads, [&](long y) {
      for (int x = 0; x < o.width; ++x) {
        double bg = 0;
        int object_samples = 0;
        for (int s = 0; s <= n * n; ++s) {  // s == n*n: the pixel centre (mask)
          const Vec2 px = s == n * n ? Vec2(x + 0.5, y + 0.5) : Vec2(x + (s % n + 0.5) / n, y + (s / n + 0.5) / n);
          const Vec3 d = (world_from_cam.rotation * cam.Unproject(px)).normalized();
          double t_bg;
          const double radiance = w.Background(eye, d, lamp, &t_bg);
          bool object = false;
          if (with_object && std::isfinite(HitSphere(eye, d, w.object_centre, w.object_bound))) {
            Hit hit;
            object = tracer.Intersect(eye, d, &hit) && hit.t < t_bg;
          }
          if (s == n * n) {
            mask.at(x, int(y), 0) = object ? 1.0f : 0.0f;
          } else if (object) {
            ++object_samples;
          } else {
            bg += radiance;
          }
        }
        for (int c = 0; c < 3; ++c) {
          // Object colour: the renderer's pixel-centre value (borrowed from a
          // neighbour when the centre missed the object).
          double oc = obj.color.at(x, int(y), c);
          if (obj.mask.at(x, int(y), 0) == 0 && object_samples > 0) {
            double sum = 0;
            int cnt = 0;
            for (auto [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
              const int xx = x + dx, yy = int(y) + dy;
              if (xx < 0 || yy < 0 || xx >= o.width || yy >= o.height || obj.mask.at(xx, yy, 0) == 0) continue;
              sum += obj.color.at(xx, yy, c);
              ++cnt;
            }
            oc = cnt ? sum / cnt : 0;
          }
          color.at(x, int(y), c) = float((object_samples * oc + bg) / (n * n));
        }
      }
    });
    *color_out = std::move(color);
    *mask_out = std::move(mask);
  };
  auto write_shot = [&](const Image& color, const std::string& name, double exposure, uint64_t stream) {
    Image shot = color;
    Rng nrng(StreamSeed(o.seed, 0x5e7, stream));
    std::normal_distribution<double> g;
    for (float& v : shot.pixels) {
      double val = v * exposure;
      if (o.noise > 0) val += g(nrng) * o.noise * std::sqrt(std::max(0.0, val));
      v = float(o.format == "exr" ? std::max(0.0, val) : std::clamp(val, 0.0, 1.0));
    }
    WriteImage((tmp / name).string(), shot,
               o.format == "exr" ? PixelFormat::kFloat : o.format == "png16" ? PixelFormat::kUInt16 : PixelFormat::kUInt8,
               o.format == "png8" ? ColorSpace::kSRGB : ColorSpace::kLinear);
  };
  const std::string ext = o.format == "exr" ? "exr" : "png";
  nlohmann::json photos = nlohmann::json::array(), calibration = nlohmann::json::array();
  {
    // Board-only photos for the intrinsics: random targets over the board,
    // distances and a roll about the optical axis.
    Scene cs = scene;
    cs.images.clear();
    Rng crng(StreamSeed(o.seed, 0xca1));
    for (int i = 0; i < o.num_calibration; ++i) {
      const double az = 2 * kPi * (i + 0.5 * u01(crng)) / std::max(1, o.num_calibration);
      const double el = (30 + 40 * u01(crng)) * kPi / 180;
      const Vec3 target = board_at(0.25 + 0.5 * u01(crng), 0.25 + 0.5 * u01(crng));
      const Vec3 dir = std::cos(el) * (std::cos(az) * ex + std::sin(az) * ey) + std::sin(el) * w.up;
      ImageEntry e;
      e.camera = 1;
      e.light = flash ? 1 : 1 + i % o.num_lamps;
      e.cam_from_world = Rigid3::LookAt(target + (0.45 + 0.3 * u01(crng)) * dir, target, w.up);
      // Rolls all round: tilts about different image axes separate the principal
      // point from the pose (tilting about one axis only leaves it ill-posed).
      const Eigen::Quaterniond roll(Eigen::AngleAxisd(2 * kPi * (i + 0.5) / std::max(1, o.num_calibration), Vec3::UnitZ()));
      e.cam_from_world.rotation = roll * e.cam_from_world.rotation;
      e.cam_from_world.translation = roll * e.cam_from_world.translation;
      cs.images.push_back(e);
      Image color, mask;
      render(cs, size_t(i), &color, &mask, false);  // calibrated before the object is placed
      char name[40];
      std::snprintf(name, sizeof name, "photos/calib_%04d.%s", i, ext.c_str());
      write_shot(color, name, 1.0, 900000 + i);
      calibration.push_back(name);
    }
  }
  for (size_t i = 0; i < scene.images.size(); ++i) {
    const ImageEntry& e = scene.images[i];
    Image color, mask;
    render(scene, i, &color, &mask);
    // Ground-truth capture: exact linear image and the visible-object mask.
    WriteImage((tmp / "truth" / e.file).string(), color, PixelFormat::kFloat);
    WriteImage((tmp / "truth" / e.mask).string(), mask, PixelFormat::kUInt8);
    WriteImage((tmp / e.mask).string(), mask, PixelFormat::kUInt8);
    // The photographs: exposure brackets with sensor noise and clipping.
    nlohmann::json files = nlohmann::json::array(), exposures = nlohmann::json::array();
    for (int k = 0; k < o.brackets; ++k) {
      const double exposure = std::pow(2.0, -k * o.bracket_stops);
      char name[64];
      std::snprintf(name, sizeof name, "photos/%04zu_b%d.%s", i, k, ext.c_str());
      write_shot(color, name, exposure, i * 64 + k);
      files.push_back(name);
      exposures.push_back(exposure);
    }
    photos.push_back({{"files", files}, {"exposures", exposures}, {"light", flash ? 1 : e.light}, {"mask", e.mask}});
    truth.cam_from_world.push_back(e.cam_from_world);
    truth.photo_lamp.push_back(e.light - 1);
  }
  scene.ground_truth = {{"material", "gt"}, {"heldout_scene", "heldout/scene.json"}};
  SaveScene(scene, (tmp / "truth" / "scene.json").string());
  for (size_t i = 0; i < held.images.size(); ++i) {
    const RenderedView v = RenderView(tracer, shader, held, i, ro);
    WriteImage((tmp / "truth" / "heldout" / held.images[i].file).string(), v.color, PixelFormat::kFloat);
    WriteImage((tmp / "truth" / "heldout" / held.images[i].mask).string(), v.mask, PixelFormat::kUInt8);
  }
  SaveScene(held, (tmp / "truth" / "heldout" / "scene.json").string());

  // What the user knows: the rough placement of the mesh on the board.
  Rigid3 rough = truth.world_from_object;
  rough.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(o.init_error_deg * kPi / 180, RandomUnit(rng))) * rough.rotation;
  rough.translation += RandomUnit(rng) * o.init_error_mm * 1e-3;
  nlohmann::json spheres = nlohmann::json::array(), lamps = nlohmann::json::array();
  for (const Vec3& c : w.spheres) spheres.push_back({c.x(), c.y(), c.z()});
  for (int l = 0; l < (flash ? 0 : o.num_lamps); ++l) lamps.push_back({{"id", l + 1}, {"type", "point"}});
  if (flash) lamps.push_back({{"id", 1}, {"type", "flash"}, {"offset", o.flash_offset}});  // intensity left to capture
  nlohmann::json board = o.board_json;
  board["white_albedo"] = o.white_albedo;
  board["black_albedo"] = o.black_albedo;
  const nlohmann::json desc = {
      {"format", "svbrdf-capture-description/1"},
      {"board", board},
      {"camera", {{"calibrate", true}, {"model", "OPENCV"}}},
      {"poses", "board"},
      {"images_color_space", o.format == "png8" ? "srgb" : "linear"},
      {"mesh", {{"file", "mesh.obj"}, {"world_from_mesh", PoseJson(rough)}}},
      {"masks", "given"},
      {"mirror_spheres", {{"radius", o.sphere_radius}, {"centres", spheres}}},
      {"lights", lamps},
      {"calibration_photos", calibration},
      {"photos", photos}};
  WriteFileAtomic((tmp / "capture.json").string(), desc.dump(2) + "\n");
  nlohmann::json tj = {{"camera", {{"model", "OPENCV"}, {"params", cam.params}}},
                       {"world_from_object", PoseJson(truth.world_from_object)},
                       {"lamps", nlohmann::json::array()}};
  for (const Vec3& l : w.lamps) tj["lamps"].push_back({l.x(), l.y(), l.z()});
  for (const Rigid3& p : truth.cam_from_world) tj["cam_from_world"].push_back(PoseJson(p));
  WriteFileAtomic((tmp / "truth" / "truth.json").string(), tj.dump(2) + "\n");

  out.Commit();
  return truth;
}

}  // namespace svbrdf
