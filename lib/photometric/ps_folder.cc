#include "photometric/ps_folder.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "io/output_folder.h"
#include "io/scene.h"
#include "photometric/pixel_mesh.h"

namespace svbrdf {

namespace fs = std::filesystem;

namespace {

// An 8-bit photo whose counts were floored, each count k >= 1 put at the
// middle k + 1/2 of the values it stands for (ImportPsOptions::quantization);
// 0 and 255 (saturated) stay, and so does an alpha channel.
Image Dequantized(const Image& photo) {
  Image out = photo;
  for (size_t i = 0; i < out.pixels.size(); ++i) {
    if (out.channels == 4 && i % 4 == 3) continue;
    const long k = std::lround(double(out.pixels[i]) * 255.0);
    if (k >= 1 && k <= 254) out.pixels[i] = float((k + 0.5) / 255.0);
  }
  return out;
}

// Rows of three numbers; blank lines are skipped.
std::vector<Vec3> ReadRows3(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(Msg(path, ": cannot open (a photometric-stereo folder needs it)"));
  std::vector<Vec3> rows;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.find_first_not_of(" \t\r,") == std::string::npos) continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream ls(line);
    Vec3 v;
    std::string rest;
    if (!(ls >> v.x() >> v.y() >> v.z()) || (ls >> rest))
      throw Error(Msg(path, ": line ", number, ": expected three numbers, got \"", line, "\""));
    if (!v.allFinite()) throw Error(Msg(path, ": line ", number, ": not a finite number"));
    rows.push_back(v);
  }
  return rows;
}

void ImageSize(const std::string& path, int* w, int* h, int* channels) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw Error(Msg(path, ": cannot read image: ", OIIO::geterror()));
  *w = in->spec().width, *h = in->spec().height, *channels = in->spec().nchannels;
}

Image Erode(const Image& mask, int radius) {
  Image out = mask;
  for (int r = 0; r < radius; ++r) {
    const Image prev = out;
    for (int y = 0; y < mask.height; ++y)
      for (int x = 0; x < mask.width; ++x) {
        if (prev.at(x, y, 0) < 0.5f) continue;
        const bool edge = x == 0 || y == 0 || x == mask.width - 1 || y == mask.height - 1 ||
                          prev.at(x - 1, y, 0) < 0.5f || prev.at(x + 1, y, 0) < 0.5f ||
                          prev.at(x, y - 1, 0) < 0.5f || prev.at(x, y + 1, 0) < 0.5f;
        if (edge) out.at(x, y, 0) = 0.0f;
      }
  }
  return out;
}


}  // namespace

PsFolder ReadPsFolder(const std::string& dir) {
  PsFolder f;
  f.dir = dir;
  if (!fs::is_directory(dir)) throw Error(Msg(dir, ": not a folder"));
  const std::string list = (fs::path(dir) / "filenames.txt").string();
  if (fs::exists(list)) {
    std::ifstream in(list);
    std::string line;
    while (std::getline(in, line)) {
      line.erase(line.find_last_not_of(" \t\r") + 1);
      line.erase(0, line.find_first_not_of(" \t"));
      if (!line.empty()) f.files.push_back(line);
    }
    if (f.files.empty()) throw Error(Msg(list, ": lists no photo"));
  } else {
    for (int i = 1;; ++i) {
      char name[16];
      std::snprintf(name, sizeof name, "%03d.png", i);
      if (!fs::exists(fs::path(dir) / name)) break;
      f.files.push_back(name);
    }
    if (f.files.empty()) throw Error(Msg(dir, ": neither filenames.txt nor 001.png, 002.png, ... found"));
  }
  const std::string dirs_file = (fs::path(dir) / "light_directions.txt").string();
  const std::string ints_file = (fs::path(dir) / "light_intensities.txt").string();
  f.to_light = ReadRows3(dirs_file);
  const std::vector<Vec3> ints = ReadRows3(ints_file);
  if (f.to_light.size() != f.files.size())
    throw Error(Msg(dirs_file, ": ", f.to_light.size(), " rows for ", f.files.size(), " photos"));
  if (ints.size() != f.files.size())
    throw Error(Msg(ints_file, ": ", ints.size(), " rows for ", f.files.size(), " photos"));
  for (size_t i = 0; i < f.to_light.size(); ++i) {
    if (std::abs(f.to_light[i].norm() - 1.0) > 1e-3)
      throw Error(Msg(dirs_file, ": row ", i + 1, ": direction has length ", f.to_light[i].norm(), ", expected a unit vector"));
    if (!(ints[i].minCoeff() > 0))
      throw Error(Msg(ints_file, ": row ", i + 1, ": intensities must be positive"));
    f.intensity.push_back(Rgb(ints[i].x(), ints[i].y(), ints[i].z()));
  }
  const std::string mask_file = (fs::path(dir) / "mask.png").string();
  if (!fs::exists(mask_file)) throw Error(Msg(mask_file, ": missing (the object mask)"));
  const Image mask = ReadImage(mask_file);
  f.width = mask.width, f.height = mask.height;
  f.mask = Image(f.width, f.height, 1);
  long object = 0;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      float m = 0;
      for (int c = 0; c < mask.channels; ++c) m = std::max(m, mask.at(x, y, c));
      f.mask.at(x, y, 0) = m > 0 ? 1.0f : 0.0f;
      object += m > 0;
    }
  if (object == 0) throw Error(Msg(mask_file, ": no object pixel (all zero)"));
  for (const std::string& name : f.files) {
    const std::string path = (fs::path(dir) / name).string();
    if (!fs::exists(path)) throw Error(Msg(path, ": missing (listed as a photo)"));
    int w, h, c;
    ImageSize(path, &w, &h, &c);
    if (w != f.width || h != f.height)
      throw Error(Msg(path, ": photo is ", w, "x", h, " but mask.png is ", f.width, "x", f.height));
  }
  return f;
}

void ImportPsOptions::Check() const {
  if (in_dir.empty() || out_dir.empty()) throw Error("import-ps: an input folder and --out are needed");
  if (hold_out_every < 2) throw Error(Msg("import-ps: --hold-out-every must be >= 2, got ", hold_out_every));
  if (erode_px < 0 || erode_px > 20) throw Error(Msg("import-ps: --erode must be in [0, 20], got ", erode_px));
  if (erode_training_px < 0 || erode_training_px > 20)
    throw Error(Msg("import-ps: --erode-training must be in [0, 20], got ", erode_training_px));
  if (!(pixels_per_metre > 0) || !std::isfinite(pixels_per_metre))
    throw Error(Msg("import-ps: --pixels-per-metre must be a finite number > 0, got ", pixels_per_metre));
  if (quantization != "floor" && quantization != "round")
    throw Error(Msg("import-ps: --quantization must be floor or round, got '", quantization, "'"));
}

Image ReadCameraNormals(const std::string& path, int width, int height) {
  const Image in = ReadImage(path);
  if (in.width != width || in.height != height)
    throw Error(Msg(path, ": normals are ", in.width, "x", in.height, " but the photos are ", width, "x", height));
  if (in.channels < 3) throw Error(Msg(path, ": expected 3 channels (xyz), got ", in.channels));
  Image out(width, height, 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const Vec3 n(in.at(x, y, 0), in.at(x, y, 1), in.at(x, y, 2));
      if (!n.allFinite()) throw Error(Msg(path, ": pixel (", x, ", ", y, ") is not finite"));
      if (n.norm() < 0.5) continue;  // outside the object
      const Vec3 c = FlipYZ(n.normalized());
      for (int k = 0; k < 3; ++k) out.at(x, y, k) = float(c[k]);
    }
  return out;
}

ImportPsResult ImportPs(const ImportPsOptions& o) {
  o.Check();
  const PsFolder f = ReadPsFolder(o.in_dir);
  const int n = int(f.files.size());
  if (o.hold_out_every > n) throw Error(Msg("import-ps: --hold-out-every ", o.hold_out_every, " exceeds the ", n, " photos"));
  ImportPsResult result;
  Image normals_cam;
  if (!o.normals_file.empty()) normals_cam = ReadCameraNormals(o.normals_file, f.width, f.height);
  if (!o.truth_normals_file.empty()) ReadCameraNormals(o.truth_normals_file, f.width, f.height);  // validate now

  OutputFolder out(o.out_dir);
  const fs::path root = out.path();
  fs::create_directories(root / "images");
  fs::create_directories(root / "masks");
  fs::create_directories(root / "heldout" / "images");
  fs::create_directories(root / "heldout" / "masks");

  // Camera: the COLMAP frame (x right, y down, z away from the camera) is
  // the world frame moved back, so the object sits around world z = 0.
  Camera cam;
  cam.id = 1;
  cam.model = CameraModelId::kOrthographic;
  cam.width = f.width, cam.height = f.height;
  cam.params = {o.pixels_per_metre, o.pixels_per_metre, 0.5 * f.width, 0.5 * f.height};
  // The object's mean depth: any positive value does for parallel rays.
  constexpr double kObjectDistance = 1.0;
  Rigid3 cam_from_world;
  cam_from_world.translation = Vec3(0, 0, kObjectDistance);

  const Image eroded_held = Erode(f.mask, o.erode_px), eroded_train = Erode(f.mask, o.erode_training_px);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) result.object_pixels += f.mask.at(x, y, 0) > 0.5f;

  Scene train, held;
  for (Scene* s : {&train, &held}) {
    s->images_color_space = ColorSpace::kLinear;
    s->cameras = {cam};
  }
  train.mesh = "mesh.obj";
  held.mesh = "../mesh.obj";
  std::vector<long> saturated(n, 0);
  std::vector<char> dequantized(n, 0);  // stored as 16-bit PNG (ImportPsOptions::quantization)
  auto stored_ext = [&](int i) { return dequantized[i] ? std::string(".png") : fs::path(f.files[i]).extension().string(); };
  Progress progress("import photos", n, o.progress);
  ParallelFor(n, 0, [&](long i) {
    const bool is_held = (i + 1) % o.hold_out_every == 0;
    const fs::path sub = is_held ? root / "heldout" : root;
    const std::string src = (fs::path(f.dir) / f.files[i]).string();
    const Image photo = ReadImage(src);
    Image mask = is_held ? eroded_held : eroded_train;
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x) {
        if (mask.at(x, y, 0) < 0.5f) continue;
        for (int c = 0; c < photo.channels; ++c)
          if (photo.at(x, y, c) >= photo.saturation_level) {
            mask.at(x, y, 0) = 0.0f;
            ++saturated[i];
            break;
          }
      }
    char stem[24];  // "%03ld" of a long: up to 20 characters
    std::snprintf(stem, sizeof stem, "%03ld", i + 1);
    dequantized[i] = photo.bits == 8 && o.quantization == "floor";
    const fs::path stored = sub / "images" / (std::string(stem) + stored_ext(int(i)));
    if (dequantized[i])
      WriteImage(stored.string(), Dequantized(photo), PixelFormat::kUInt16);
    else
      fs::copy_file(src, stored, fs::copy_options::overwrite_existing);
    WriteImage((sub / "masks" / (std::string(stem) + ".png")).string(), mask, PixelFormat::kUInt8);
    progress.Tick();
  });
  for (int i = 0; i < n; ++i) {
    const bool is_held = (i + 1) % o.hold_out_every == 0;
    Scene& s = is_held ? held : train;
    Light l;
    l.id = i + 1;
    l.type = LightType::kDirectional;
    l.to_light = FlipYZ(f.to_light[i].normalized());  // world = camera frame (rotation identity)
    l.irradiance = f.intensity[i];
    s.lights.push_back(l);
    ImageEntry e;
    char stem[16];
    std::snprintf(stem, sizeof stem, "%03d", i + 1);
    e.file = "images/" + std::string(stem) + stored_ext(i);
    e.mask = "masks/" + std::string(stem) + ".png";
    e.camera = cam.id;
    e.light = l.id;
    e.cam_from_world = cam_from_world;
    s.images.push_back(e);
    (is_held ? result.held_out : result.training) += 1;
    result.saturated_samples += saturated[i];
    result.dequantized += dequantized[i];
  }
  if (result.training < 3) throw Error(Msg("import-ps: only ", result.training, " training photos; lower --hold-out-every"));

  // Geometry: the given normals integrated into a height field, else a plane
  // facing the camera whose normals the capture declares unknown.
  const bool known = normals_cam.width > 0;
  Image region = f.mask, normals = known ? normals_cam : Image(f.width, f.height, 3);
  if (known) {
    Image has(f.width, f.height, 1);
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x)
        has.at(x, y, 0) = normals.at(x, y, 2) < 0 ? 1.0f : 0.0f;
    if (!FillFromNearest(has, &normals)) throw Error(Msg(o.normals_file, ": no normal faces the camera"));
  } else {
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x) normals.at(x, y, 2) = -1.0f;
  }
  const std::vector<double> depth =
      known ? IntegrateNormals(normals, region, 1.0 / o.pixels_per_metre) : std::vector<double>(size_t(f.width) * f.height, 0.0);
  const Mesh mesh = PixelGridMesh(cam, cam_from_world, region, depth, kObjectDistance, normals);
  SaveObj(mesh, (root / "mesh.obj").string(), /*write_normals=*/true);
  train.mesh_normals_known = known;
  held.mesh_normals_known = known;
  // The report measures the material's normals against a ground truth: the
  // one given, else the normals the mesh carries.
  const std::string truth_file = !o.truth_normals_file.empty() ? o.truth_normals_file : o.normals_file;
  if (!truth_file.empty()) {
    fs::create_directories(root / "gt");
    const Image truth = ReadImage(truth_file);
    WriteImage((root / "gt" / "normals_camera.exr").string(), truth, PixelFormat::kFloat);
    train.ground_truth = {{"normals_camera", "gt/normals_camera.exr"}};
    held.ground_truth = {{"normals_camera", "../gt/normals_camera.exr"}};
  }
  SaveScene(train, (root / "scene.json").string());
  SaveScene(held, (root / "heldout" / "scene.json").string());
  out.Commit();
  return result;
}

}  // namespace svbrdf
