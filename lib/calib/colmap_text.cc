#include "calib/colmap_text.h"

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "core/error.h"
#include "io/scene.h"

namespace svbrdf {

namespace {

// Non-comment, non-empty lines with their 1-based line numbers.
std::vector<std::pair<int, std::string>> DataLines(const std::string& path, bool keep_empty) {
  std::ifstream in(path);
  if (!in) throw Error(Msg(path, ": cannot open"));
  std::vector<std::pair<int, std::string>> lines;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!line.empty() && line[0] == '#') continue;
    if (line.empty() && !keep_empty) continue;
    lines.emplace_back(n, line);
  }
  return lines;
}

}  // namespace

std::vector<Camera> ReadColmapCameras(const std::string& path) {
  std::vector<Camera> cams;
  for (const auto& [n, line] : DataLines(path, false)) {
    std::istringstream is(line);
    Camera c;
    std::string model;
    if (!(is >> c.id >> model >> c.width >> c.height))
      throw Error(Msg(path, ":", n, ": expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]"));
    c.model = CameraModelFromName(model, Msg(path, ":", n));
    double v;
    while (is >> v) c.params.push_back(v);
    if (int(c.params.size()) != CameraModelNumParams(c.model))
      throw Error(Msg(path, ":", n, ": model ", model, " needs ", CameraModelNumParams(c.model), " parameters, got ",
                      c.params.size()));
    cams.push_back(c);
  }
  if (cams.empty()) throw Error(Msg(path, ": no cameras"));
  return cams;
}

void WriteColmapCameras(const std::vector<Camera>& cameras, const std::string& path) {
  std::ostringstream os;
  os << "# Camera list with one line of data per camera:\n"
     << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
     << "# Number of cameras: " << cameras.size() << "\n"
     << std::setprecision(17);
  for (const Camera& c : cameras) {
    os << c.id << ' ' << CameraModelName(c.model) << ' ' << c.width << ' ' << c.height;
    for (double p : c.params) os << ' ' << p;
    os << '\n';
  }
  WriteFileAtomic(path, os.str());
}

ColmapModel ReadColmapText(const std::string& dir) {
  namespace fs = std::filesystem;
  ColmapModel m;
  m.cameras = ReadColmapCameras((fs::path(dir) / "cameras.txt").string());
  const std::string images_path = (fs::path(dir) / "images.txt").string();
  // images.txt: two lines per image; the second (observations) may be empty.
  const auto lines = DataLines(images_path, true);
  size_t i = 0;
  while (i < lines.size()) {
    if (lines[i].second.empty()) {
      ++i;
      continue;
    }
    const auto& [n, line] = lines[i];
    std::istringstream is(line);
    ColmapImage im;
    double qw, qx, qy, qz, tx, ty, tz;
    if (!(is >> im.id >> qw >> qx >> qy >> qz >> tx >> ty >> tz >> im.camera_id >> im.name))
      throw Error(Msg(images_path, ":", n, ": expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME"));
    im.cam_from_world.rotation = Eigen::Quaterniond(qw, qx, qy, qz).normalized();
    im.cam_from_world.translation = Vec3(tx, ty, tz);
    if (i + 1 < lines.size()) {
      std::istringstream ps(lines[i + 1].second);
      double x, y;
      long id;
      while (ps >> x >> y >> id) {
        im.points2d.emplace_back(x, y);
        im.point3d_ids.push_back(id);
      }
    }
    m.images.push_back(im);
    i += 2;
  }
  const fs::path points_path = fs::path(dir) / "points3D.txt";
  if (fs::exists(points_path)) {
    for (const auto& [n, line] : DataLines(points_path.string(), false)) {
      std::istringstream is(line);
      ColmapPoint p;
      int r, g, b;
      if (!(is >> p.id >> p.xyz.x() >> p.xyz.y() >> p.xyz.z() >> r >> g >> b >> p.error))
        throw Error(Msg(points_path.string(), ":", n, ": expected POINT3D_ID X Y Z R G B ERROR TRACK[]"));
      m.points[p.id] = p;
    }
  }
  return m;
}

}  // namespace svbrdf
