#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>

#include "core/error.h"
#include "io/image.h"
#include "io/material.h"
#include "io/mesh.h"
#include "io/output_folder.h"
#include "io/scene.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A fresh folder per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() / Msg("svbrdf_io_", getpid(), "_", info->test_suite_name(), "_", info->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }
  std::string str() const { return path_.string(); }

 private:
  fs::path path_;
};

void WriteText(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// Runs `fn`, expecting an Error whose message contains every needle.
void ExpectError(const std::function<void()>& fn, const std::vector<std::string>& needles) {
  try {
    fn();
    ADD_FAILURE() << "no error; expected one containing '" << needles.front() << "'";
  } catch (const Error& e) {
    for (const std::string& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
  }
}

const char* kTinyIes =
    "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 10\n0 90\n0\n100 50\n";

// ---------------------------------------------------------------- scene.json

Scene MakeScene(const TempDir& dir) {
  WriteText(dir / "mesh.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  WriteText(dir / "lights/lamp.ies", kTinyIes);
  Scene s;
  s.dir = dir.str();
  s.mesh = "mesh.obj";
  s.images_color_space = ColorSpace::kSRGB;
  const std::vector<std::pair<CameraModelId, std::vector<double>>> cams = {
      {CameraModelId::kSimplePinhole, {900, 400, 300}},
      {CameraModelId::kPinhole, {900, 910, 400.5, 300.25}},
      {CameraModelId::kSimpleRadial, {900, 400, 300, 0.01}},
      {CameraModelId::kRadial, {900, 400, 300, 0.01, -0.002}},
      {CameraModelId::kOpenCV, {900, 905, 400, 300, 0.01, -0.002, 0.0001, 0.0003}}};
  for (size_t i = 0; i < cams.size(); ++i) {
    Camera c;
    c.id = int(i) + 1;
    c.model = cams[i].first;
    c.width = 800;
    c.height = 600;
    c.params = cams[i].second;
    s.cameras.push_back(c);
  }
  Light point;
  point.id = 1;
  point.position = Vec3(0, 2, 1);
  point.intensity = Rgb(10, 9, 8);
  Light flash = point;
  flash.id = 2;
  flash.camera_frame = true;
  flash.position = Vec3(0.05, 0, 0);
  Light dir_light;
  dir_light.id = 3;
  dir_light.type = LightType::kDirectional;
  dir_light.to_light = Vec3(0, 1, 0);
  dir_light.irradiance = Rgb(3, 2, 1);
  Light spot;
  spot.id = 4;
  spot.type = LightType::kSpot;
  spot.position = Vec3(0, 2, 0);
  spot.direction = Vec3(0, -1, 0);
  spot.intensity = Rgb(5, 5, 5);
  spot.exponent = 20;
  spot.cutoff_deg = 40;
  Light gonio;
  gonio.id = 5;
  gonio.type = LightType::kGoniometric;
  gonio.position = Vec3(0, 2, 0);
  gonio.direction = Vec3(0, -1, 0);
  gonio.up = Vec3(0, 0, 1);
  gonio.ies = "lights/lamp.ies";
  gonio.scale = 0.5;
  s.lights = {point, flash, dir_light, spot, gonio};
  for (int i = 0; i < 5; ++i) {
    ImageEntry im;
    im.file = Msg("images/", i, ".exr");
    im.camera = i + 1;
    im.light = 5 - i;
    im.cam_from_world = Rigid3::LookAt(Vec3(i, 1, 3), Vec3::Zero(), Vec3::UnitY());
    im.exposure = 0.5 + i;
    if (i % 2 == 0) im.mask = Msg("masks/", i, ".png");
    s.images.push_back(im);
  }
  s.ground_truth = json{{"params", "gt/params.exr"}, {"ids", {1, 2, 3}}};
  return s;
}

TEST(Scene, RoundTripEveryCameraAndLightType) {
  TempDir dir;
  const Scene a = MakeScene(dir);
  SaveScene(a, dir / "scene.json");
  const Scene b = LoadScene(dir / "scene.json");
  EXPECT_EQ(b.mesh, a.mesh);
  EXPECT_EQ(b.images_color_space, a.images_color_space);
  ASSERT_EQ(b.cameras.size(), a.cameras.size());
  for (size_t i = 0; i < a.cameras.size(); ++i) {
    EXPECT_EQ(b.cameras[i].id, a.cameras[i].id);
    EXPECT_EQ(b.cameras[i].model, a.cameras[i].model);
    EXPECT_EQ(b.cameras[i].width, a.cameras[i].width);
    EXPECT_EQ(b.cameras[i].height, a.cameras[i].height);
    EXPECT_EQ(b.cameras[i].params, a.cameras[i].params);
  }
  ASSERT_EQ(b.lights.size(), a.lights.size());
  for (size_t i = 0; i < a.lights.size(); ++i) {
    const Light &x = a.lights[i], &y = b.lights[i];
    EXPECT_EQ(y.id, x.id);
    EXPECT_EQ(y.type, x.type);
    EXPECT_EQ(y.camera_frame, x.camera_frame);
    if (x.type != LightType::kDirectional) {
      EXPECT_EQ(y.position, x.position);
    }
    if (x.type == LightType::kPoint || x.type == LightType::kSpot) {
      EXPECT_TRUE((y.intensity == x.intensity).all());
    }
    if (x.type == LightType::kDirectional) {
      EXPECT_EQ(y.to_light, x.to_light);
      EXPECT_TRUE((y.irradiance == x.irradiance).all());
    }
    if (x.type == LightType::kSpot || x.type == LightType::kGoniometric) {
      EXPECT_EQ(y.direction, x.direction);
    }
    EXPECT_EQ(y.exponent, x.exponent);
    EXPECT_EQ(y.cutoff_deg, x.cutoff_deg);
    EXPECT_EQ(y.ies, x.ies);
    EXPECT_EQ(y.scale, x.scale);
  }
  ASSERT_TRUE(b.lights[4].profile);
  EXPECT_DOUBLE_EQ(b.lights[4].profile->MaxCandela(), 100.0);
  ASSERT_EQ(b.images.size(), a.images.size());
  for (size_t i = 0; i < a.images.size(); ++i) {
    const ImageEntry &x = a.images[i], &y = b.images[i];
    EXPECT_EQ(y.file, x.file);
    EXPECT_EQ(y.camera, x.camera);
    EXPECT_EQ(y.light, x.light);
    EXPECT_EQ(y.exposure, x.exposure);
    EXPECT_EQ(y.mask, x.mask);
    EXPECT_TRUE(y.cam_from_world.rotation.coeffs().isApprox(x.cam_from_world.rotation.coeffs(), 1e-15));
    EXPECT_EQ(y.cam_from_world.translation, x.cam_from_world.translation);
  }
  EXPECT_EQ(b.ground_truth, a.ground_truth);
  EXPECT_EQ(SceneToJson(b), SceneToJson(a));
  EXPECT_EQ(&b.CameraById(3), &b.cameras[2]);
  ExpectError([&] { b.LightById(42); }, {"no light with id 42"});
}

TEST(Scene, WriterUsesContractFieldNames) {
  TempDir dir;
  const json j = SceneToJson(MakeScene(dir));
  EXPECT_EQ(j["format"], "svbrdf-scene/1");
  const json& pose = j["images"][0]["cam_from_world"];
  ASSERT_EQ(pose["q"].size(), 4u);
  ASSERT_EQ(pose["t"].size(), 3u);
  const Eigen::Quaterniond q = MakeScene(dir).images[0].cam_from_world.rotation;
  EXPECT_EQ(pose["q"][0].get<double>(), q.w());  // [w, x, y, z]
  EXPECT_EQ(j["lights"][1]["frame"], "camera");
  EXPECT_FALSE(j["lights"][0].contains("frame"));
  EXPECT_TRUE(j["lights"][2].contains("to_light"));
  EXPECT_TRUE(j["lights"][3].contains("cutoff_deg"));
  EXPECT_EQ(j["lights"][4]["ies"], "lights/lamp.ies");
}

TEST(Scene, MalformedFieldsAreNamed) {
  TempDir dir;
  const json good = SceneToJson(MakeScene(dir));
  struct Case {
    std::function<void(json&)> mutate;
    std::string needle;
  };
  const std::vector<Case> cases = {
      {[](json& j) { j["format"] = "svbrdf-scene/2"; }, "format: expected \"svbrdf-scene/1\""},
      {[](json& j) { j.erase("mesh"); }, "mesh: missing, expected string"},
      {[](json& j) { j["mesh"] = "nothere.obj"; }, "mesh: mesh file not found"},
      {[](json& j) { j["images_color_space"] = "rec709"; }, "images_color_space: expected \"linear\" or \"srgb\""},
      {[](json& j) { j["cameras"] = json::object(); }, "cameras: expected array"},
      {[](json& j) { j["cameras"][0]["model"] = "FISHEYE"; }, "cameras[0].model: unknown camera model 'FISHEYE'"},
      {[](json& j) { j["cameras"][1]["params"] = {1, 2, 3}; }, "cameras[1].params: expected array of 4 numbers for PINHOLE"},
      {[](json& j) { j["cameras"][1]["params"][0] = "900"; }, "cameras[1].params: expected array of numbers"},
      {[](json& j) { j["cameras"][0]["width"] = 0; }, "cameras[0].width: expected positive integer"},
      {[](json& j) { j["cameras"][0]["height"] = 600.5; }, "cameras[0].height: expected integer"},
      {[](json& j) { j["cameras"][0].erase("id"); }, "cameras[0].id: missing, expected integer"},
      {[](json& j) { j["cameras"][1]["id"] = 1; }, "cameras[1].id: duplicate id 1"},
      {[](json& j) { j["lights"][2]["id"] = 1; }, "lights[2].id: duplicate id 1"},
      {[](json& j) { j["lights"][0]["type"] = "area"; }, "lights[0].type: unknown light type \"area\""},
      {[](json& j) { j["lights"][0]["intensity"] = {1, 2}; }, "lights[0].intensity: expected array of 3 numbers"},
      {[](json& j) { j["lights"][0]["intensity"] = {1, -2, 3}; }, "lights[0].intensity: expected array of 3 non-negative"},
      {[](json& j) { j["lights"][1]["frame"] = "object"; }, "lights[1].frame: expected \"world\" or \"camera\""},
      {[](json& j) { j["lights"][2]["to_light"] = {0, 0, 0}; }, "lights[2].to_light: expected non-zero"},
      {[](json& j) { j["lights"][3]["cutoff_deg"] = -5; }, "lights[3].cutoff_deg: expected positive number"},
      {[](json& j) { j["lights"][3].erase("exponent"); }, "lights[3].exponent: missing, expected number"},
      {[](json& j) { j["lights"][4]["ies"] = "lights/none.ies"; }, "lights[4].ies: "},
      {[](json& j) { j["lights"][4]["up"] = {0, 2, 0}; }, "lights[4].up: must not be parallel"},
      {[](json& j) { j["images"][2]["cam_from_world"]["q"] = {1, 0, 0}; }, "images[2].cam_from_world.q: expected array of 4 numbers"},
      {[](json& j) { j["images"][2]["cam_from_world"]["q"] = {0, 0, 0, 0}; }, "images[2].cam_from_world.q: expected non-zero"},
      {[](json& j) { j["images"][0]["cam_from_world"]["t"] = "0 0 3"; }, "images[0].cam_from_world.t: expected array of 3 numbers"},
      {[](json& j) { j["images"][0].erase("cam_from_world"); }, "images[0].cam_from_world: missing, expected object"},
      {[](json& j) { j["images"][0]["camera"] = 9; }, "images[0].camera: no camera with id 9"},
      {[](json& j) { j["images"][0]["light"] = 9; }, "images[0].light: no light with id 9"},
      {[](json& j) { j["images"][1]["exposure"] = 0; }, "images[1].exposure: expected positive number"},
      {[](json& j) { j["images"][1]["exposre"] = 1; }, "images[1].exposre: unknown field"},
      {[](json& j) { j["images"][1]["file"] = 3; }, "images[1].file: expected string"},
  };
  for (const Case& c : cases) {
    json j = good;
    c.mutate(j);
    ExpectError([&] { ParseScene(j, dir.str(), "/x/scene.json"); }, {"/x/scene.json: " + c.needle});
  }
  // The unmodified document is valid.
  EXPECT_NO_THROW(ParseScene(good, dir.str(), "/x/scene.json"));
}

TEST(Scene, FileErrorsNameTheFile) {
  TempDir dir;
  WriteText(dir / "scene.json", "{\"format\": \"svbrdf-scene/1\",\n \"mesh\": }");
  ExpectError([&] { LoadScene(dir / "scene.json"); }, {dir / "scene.json", "byte"});
  ExpectError([&] { LoadScene(dir / "missing.json"); }, {dir / "missing.json"});
  // A capture folder given where its scene.json is expected.
  ExpectError([&] { LoadScene(dir.str()); }, {dir.str(), "is a folder", "did you mean", "scene.json"});
}

// ---------------------------------------------------------------- meshes

TEST(Mesh, ObjWithUVsQuadsAndNegativeIndices) {
  TempDir dir;
  WriteText(dir / "quad.obj",
            "# a unit quad and a triangle\nmtllib x.mtl\no quad\n"
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\ns off\n"
            "f 1/1/1 2/2/1 3/3/1 4/4/1\n"
            "v 2 0 0\nf -1/-1 -4/-3 -3/-2\n");
  const Mesh m = LoadMesh(dir / "quad.obj");
  ASSERT_EQ(m.positions.size(), 5u);
  ASSERT_EQ(m.faces.size(), 3u);  // quad fan-triangulated + one triangle
  EXPECT_EQ(m.faces[0], Vec3i(0, 1, 2));
  EXPECT_EQ(m.faces[1], Vec3i(0, 2, 3));
  EXPECT_EQ(m.faces[2], Vec3i(4, 1, 2));
  ASSERT_TRUE(m.HasUVs());
  EXPECT_EQ(m.face_uvs[1], Vec3i(0, 2, 3));
  EXPECT_EQ(m.face_uvs[2], Vec3i(3, 1, 2));
  ASSERT_EQ(m.normals.size(), 5u);
  EXPECT_TRUE(m.normals[0].isApprox(Vec3::UnitZ()));
}

TEST(Mesh, ObjWithoutUVsAndNormalOnlyCorners) {
  TempDir dir;
  WriteText(dir / "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n");
  const Mesh m = LoadMesh(dir / "tri.obj");
  EXPECT_FALSE(m.HasUVs());
  EXPECT_EQ(m.faces.size(), 1u);
}

// Other renderers (Mitsuba, Blender) shade with the normals a mesh file
// gives; a capture rendered with them must be reconstructed and relit with
// them, not with normals recomputed from the triangles.
TEST(Mesh, ObjNormalsAreTheFilesOwnWhenOnePerPosition) {
  TempDir dir;
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  WriteText(dir / "tilted.obj", tri + "vn 0.5 0 1\nvn 0 0 2\nf 1//1 2//2 3//2\n");
  Mesh m = LoadMesh(dir / "tilted.obj");
  ASSERT_EQ(m.normals.size(), 3u);
  EXPECT_TRUE(m.normals[0].isApprox(Vec3(0.5, 0, 1).normalized(), 1e-12));  // not the face's (0, 0, 1)
  EXPECT_TRUE(m.normals[1].isApprox(Vec3::UnitZ(), 1e-12));
  // Split normals (position 1 with two different ones): no per-position normal, so computed.
  WriteText(dir / "split.obj", tri + "v 1 1 0.5\nvn 1 0 0\nvn 0 1 0\nf 1//1 2//1 3//1\nf 2//2 4//2 3//2\n");
  m = LoadMesh(dir / "split.obj");
  Mesh computed = m;
  computed.ComputeNormals();
  EXPECT_EQ(m.normals, computed.normals);
  // A zero normal, or a face without normals, falls back to the computed ones too.
  WriteText(dir / "zero.obj", tri + "vn 0 0 0\nvn 0 0 1\nf 1//1 2//2 3//2\n");
  EXPECT_TRUE(LoadMesh(dir / "zero.obj").normals[0].isApprox(Vec3::UnitZ(), 1e-12));
  WriteText(dir / "mixed.obj", tri + "v 1 1 0\nvn 0.5 0 1\nf 1//1 2//1 3//1\nf 2 4 3\n");
  EXPECT_TRUE(LoadMesh(dir / "mixed.obj").normals[0].isApprox(Vec3::UnitZ(), 1e-12));
}

TEST(Mesh, PlyNormalsAreTheFilesOwn) {
  TempDir dir;
  WriteText(dir / "n.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\nelement face 1\n"
            "property list uchar int vertex_indices\nend_header\n"
            "0 0 0 0 0.6 0.8\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n");
  const Mesh m = LoadMesh(dir / "n.ply");
  ASSERT_EQ(m.normals.size(), 3u);
  EXPECT_TRUE(m.normals[0].isApprox(Vec3(0, 0.6, 0.8), 1e-6));
}

TEST(Mesh, SaveObjWithNormalsRoundTripsThem) {
  TempDir dir;
  Mesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  m.faces = {Vec3i(0, 1, 2)};
  m.normals = {Vec3(0.6, 0, 0.8), Vec3(0, 0, 1), Vec3(0, 1.0 / 3, std::sqrt(8.0) / 3)};
  SaveObj(m, dir / "m.obj", /*write_normals=*/true);
  EXPECT_EQ(LoadMesh(dir / "m.obj").normals, m.normals);
}

TEST(Mesh, ObjErrorsNameFileAndLine) {
  TempDir dir;
  WriteText(dir / "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  ExpectError([&] { LoadMesh(dir / "bad.obj"); }, {dir / "bad.obj", ":4", "out of range"});
  WriteText(dir / "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
  ExpectError([&] { LoadMesh(dir / "flat.obj"); }, {"degenerate"});
  ExpectError([&] { LoadMesh(dir / "mesh.stl"); }, {"unknown mesh format"});
}

TEST(Mesh, AngleWeightedNormalsAsMitsubaAndBlender) {
  Mesh m;
  // Vertex 0 shared by a large face in the xy plane and a small one in the xz
  // plane, both with a 90 deg corner there: equal weights whatever their areas
  // (area weighting would give (0, 1, 4) / sqrt(17)).
  m.positions = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0), Vec3(0, 0, -1), Vec3(1, 0, 0)};
  m.faces = {Vec3i(0, 1, 2), Vec3i(0, 4, 3)};
  m.ComputeNormals();
  EXPECT_TRUE(m.normals[0].isApprox(Vec3(0, 1, 1) / std::sqrt(2.0), 1e-12)) << m.normals[0].transpose();
  // A fan of two thin, large faces in the yz plane (45 deg corners each at
  // vertex 0) against one 90 deg face in the xy plane: the fan counts as its
  // angle, 90 deg, not as its area.
  Mesh fan;
  fan.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 10, 10), Vec3(0, 0, 1)};
  fan.faces = {Vec3i(0, 1, 2), Vec3i(0, 2, 3), Vec3i(0, 3, 4)};
  fan.ComputeNormals();
  EXPECT_TRUE(fan.normals[0].isApprox(Vec3(1, 0, 1) / std::sqrt(2.0), 1e-12)) << fan.normals[0].transpose();
  // A degenerate face adds nothing (and no NaN).
  fan.faces.push_back(Vec3i(0, 1, 1));
  fan.ComputeNormals();
  EXPECT_TRUE(fan.normals[0].isApprox(Vec3(1, 0, 1) / std::sqrt(2.0), 1e-12));
}

TEST(Mesh, PlyAsciiWithUVsAndQuads) {
  TempDir dir;
  WriteText(dir / "a.ply",
            "ply\nformat ascii 1.0\ncomment test\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nproperty float s\nproperty float t\nelement face 1\n"
            "property list uchar int vertex_indices\nend_header\n"
            "0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n4 0 1 2 3\n");
  const Mesh m = LoadMesh(dir / "a.ply");
  ASSERT_EQ(m.faces.size(), 2u);
  ASSERT_TRUE(m.HasUVs());
  EXPECT_EQ(m.face_uvs, m.faces);
  EXPECT_EQ(m.texcoords[2], Vec2(1, 1));
}

template <class T>
void Put(std::string& s, T v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

TEST(Mesh, PlyBinaryLittleEndianWithExtraProperties) {
  TempDir dir;
  std::string data =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nproperty uchar red\nproperty double u\nproperty double v\n"
      "element face 1\nproperty list uchar int vertex_indices\nproperty int flags\nend_header\n";
  const float xyz[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  for (int i = 0; i < 3; ++i) {
    for (float c : xyz[i]) Put(data, c);
    Put<uint8_t>(data, 200);
    Put<double>(data, 0.25 * i);
    Put<double>(data, 0.5);
  }
  Put<uint8_t>(data, 3);
  for (int i : {0, 1, 2}) Put<int32_t>(data, i);
  Put<int32_t>(data, 7);
  WriteText(dir / "b.ply", data);
  const Mesh m = LoadMesh(dir / "b.ply");
  ASSERT_EQ(m.positions.size(), 3u);
  EXPECT_EQ(m.positions[1], Vec3(1, 0, 0));
  EXPECT_EQ(m.faces[0], Vec3i(0, 1, 2));
  ASSERT_TRUE(m.HasUVs());
  EXPECT_EQ(m.texcoords[2], Vec2(0.5, 0.5));
  // Truncated binary body.
  WriteText(dir / "c.ply", data.substr(0, data.size() - 6));
  ExpectError([&] { LoadMesh(dir / "c.ply"); }, {dir / "c.ply", "truncated"});
}

TEST(Mesh, SaveObjRoundTripIsExact) {
  TempDir dir;
  Mesh m;
  m.positions = {Vec3(0.1, 0.2, 0.3), Vec3(1.0 / 3, 0, 0), Vec3(0, 1e-7, 2)};
  m.texcoords = {Vec2(0.1, 0.9), Vec2(1.0 / 7, 0), Vec2(0.5, 0.5)};
  m.faces = {Vec3i(0, 1, 2)};
  m.face_uvs = {Vec3i(2, 1, 0)};
  SaveObj(m, dir / "m.obj");
  const Mesh r = LoadMesh(dir / "m.obj");
  EXPECT_EQ(r.positions, m.positions);
  EXPECT_EQ(r.texcoords, m.texcoords);
  EXPECT_EQ(r.faces, m.faces);
  EXPECT_EQ(r.face_uvs, m.face_uvs);
}

// ---------------------------------------------------------------- images

Image Ramp(int w, int h, int c) {
  Image img(w, h, c);
  for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = float(i % 97) / 96.0f;
  return img;
}

TEST(ImageIo, ExrRoundTripIsExactAndUnsaturated) {
  TempDir dir;
  Image a = Ramp(7, 5, 3);
  a.at(0, 0, 0) = 12.5f;  // HDR values survive
  WriteImage(dir / "a.exr", a);
  const Image b = ReadImage(dir / "a.exr", ColorSpace::kSRGB);  // sRGB is ignored for EXR
  EXPECT_EQ(b.width, 7);
  EXPECT_EQ(b.channels, 3);
  EXPECT_EQ(b.pixels, a.pixels);
  EXPECT_TRUE(std::isinf(b.saturation_level));
  EXPECT_EQ(SaturatedFraction(b), 0.0);
  // No temporary file left behind.
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir.str())) ++files;
  EXPECT_EQ(files, 1);
}

TEST(ImageIo, Png16RoundTrip) {
  TempDir dir;
  const Image a = Ramp(9, 4, 3);
  WriteImage(dir / "a.png", a, PixelFormat::kUInt16);
  const Image b = ReadImage(dir / "a.png");
  EXPECT_EQ(b.saturation_level, 1.0f);
  for (size_t i = 0; i < a.pixels.size(); ++i) EXPECT_NEAR(b.pixels[i], a.pixels[i], 0.51 / 65535);
}

TEST(ImageIo, Png8SrgbRoundTrip) {
  TempDir dir;
  const Image a = Ramp(16, 8, 1);
  WriteImage(dir / "a.png", a, PixelFormat::kUInt8, ColorSpace::kSRGB);
  const Image b = ReadImage(dir / "a.png", ColorSpace::kSRGB);
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    // Quantisation happens in the encoded domain: within half a step there.
    EXPECT_NEAR(LinearToSrgb(b.pixels[i]), LinearToSrgb(a.pixels[i]), 0.5 / 255 + 1e-6);
    // After decoding, within 1/255 where the sRGB curve's slope (d linear / d code <= 2.27 near 1)
    // keeps half a step below it, i.e. below 0.8.
    if (a.pixels[i] <= 0.8f) {
      EXPECT_NEAR(b.pixels[i], a.pixels[i], 1.0 / 255);
    }
  }
  // Read as linear, the stored values are the sRGB encoding.
  const Image raw = ReadImage(dir / "a.png");
  EXPECT_NEAR(raw.at(5, 0, 0), LinearToSrgb(a.at(5, 0, 0)), 0.51 / 255);
}

TEST(ImageIo, SaturationOfIntegerFiles) {
  TempDir dir;
  Image a(4, 1, 3, 0.25f);
  a.at(1, 0, 2) = 3.0f;  // clipped to the maximum when written
  a.at(2, 0, 0) = 1.0f;
  WriteImage(dir / "s.tif", a, PixelFormat::kUInt16);
  const Image b = ReadImage(dir / "s.tif");
  EXPECT_EQ(b.at(1, 0, 2), 1.0f);
  EXPECT_DOUBLE_EQ(SaturatedFraction(b), 0.5);
  Image mask(4, 1, 1, 0.0f);
  mask.at(0, 0, 0) = mask.at(1, 0, 0) = 1;
  EXPECT_DOUBLE_EQ(SaturatedFraction(b, &mask), 0.5);
}

TEST(ImageIo, SaturationOfHalfFloatFiles) {
  TempDir dir;
  Image a(4, 1, 3, 0.25f);
  a.at(1, 0, 0) = 65504.0f;  // half's largest finite value: where a clipping writer puts raw maxima
  a.at(2, 0, 1) = 1e30f;     // beyond half: infinity once written
  a.at(3, 0, 2) = 65000.0f;  // bright, representable: not saturated
  WriteImage(dir / "h.exr", a, PixelFormat::kHalf);
  const Image b = ReadImage(dir / "h.exr");
  EXPECT_EQ(b.saturation_level, 65504.0f);
  EXPECT_TRUE(IsHighDynamicRange(b));
  EXPECT_DOUBLE_EQ(SaturatedFraction(b), 0.5);
  // Float files have no clipping level; integer files are not HDR.
  WriteImage(dir / "f.exr", a, PixelFormat::kFloat);
  EXPECT_TRUE(std::isinf(ReadImage(dir / "f.exr").saturation_level));
  EXPECT_FALSE(IsHighDynamicRange(Image(2, 2, 3)));
}

TEST(ImageIo, LabelImageRoundTrip) {
  TempDir dir;
  Image ids(3, 2, 1);
  for (size_t i = 0; i < ids.pixels.size(); ++i) ids.pixels[i] = float(i);
  WriteLabelImage(dir / "id.png", ids);
  EXPECT_EQ(ReadLabelImage(dir / "id.png").pixels, ids.pixels);
  ids.pixels[0] = 1000;  // needs 16 bits
  WriteLabelImage(dir / "id16.png", ids);
  EXPECT_EQ(ReadLabelImage(dir / "id16.png").pixels, ids.pixels);
}

TEST(ImageIo, Errors) {
  TempDir dir;
  ExpectError([&] { ReadImage(dir / "none.png"); }, {dir / "none.png"});
  ExpectError([&] { WriteImage(dir / "a.png", Image(2, 2, 1), PixelFormat::kFloat); }, {"a.png", "integers"});
  ExpectError([&] { WriteImage(dir / "a.jpg", Image(2, 2, 1), PixelFormat::kUInt16); }, {"8 bits"});
}

TEST(ImageIo, BilinearAtPixelCentres) {
  Image img(2, 2, 1);
  img.at(0, 0, 0) = 0;
  img.at(1, 0, 0) = 1;
  img.at(0, 1, 0) = 2;
  img.at(1, 1, 0) = 3;
  EXPECT_FLOAT_EQ(img.Bilinear(0.5, 0.5, 0), 0);
  EXPECT_FLOAT_EQ(img.Bilinear(1.5, 0.5, 0), 1);
  EXPECT_FLOAT_EQ(img.Bilinear(0.5, 1.5, 0), 2);
  EXPECT_FLOAT_EQ(img.Bilinear(1.0, 1.0, 0), 1.5);
  EXPECT_FLOAT_EQ(img.Bilinear(0.0, 0.0, 0), 0);  // clamped at the border
  EXPECT_FLOAT_EQ(img.Bilinear(5.0, 5.0, 0), 3);
}

// ---------------------------------------------------------------- material

Material MakeMaterial() {
  Material m;
  m.mesh.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  m.mesh.texcoords = {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1)};
  m.mesh.faces = {Vec3i(0, 1, 2)};
  m.mesh.face_uvs = m.mesh.faces;
  m.width = 6;
  m.height = 4;
  for (const char* label : {"lafortune-2", "cook_torrance-ggx-smith-schlick", "lambert"}) {
    BasisMaterial b;
    b.name = label;
    b.spec = ModelSpec::FromLabel(label);
    b.params = b.spec.InitialParams();
    b.params[0] = 0.123456789;
    m.basis.push_back(b);
    m.weights.push_back(Ramp(6, 4, 3));
  }
  m.normal_map = Image(6, 4, 3, 0.0f);
  for (int i = 0; i < 24; ++i) m.normal_map.pixels[3 * i + 2] = 1;
  m.confidence = Ramp(6, 4, 1);
  m.material_id = Image(6, 4, 1, 2.0f);
  m.extra = json{{"tool", "io_test"}};
  return m;
}

// Every model's parameters by name (conductors' eta/kappa/f0/f82_tint,
// coated) survive material.json exactly.
TEST(Material, EveryModelRoundTrips) {
  TempDir dir;
  Material a = MakeMaterial();
  a.basis.clear();
  a.weights.clear();
  for (const ModelSpec& spec : AllModelSpecs()) {
    BasisMaterial b;
    b.name = spec.Label();
    b.spec = spec;
    b.params = spec.InitialParams();
    // Distinct values, exact in JSON, inside the range the loader enforces.
    const std::vector<ParamInfo> info = spec.Params();
    for (size_t i = 0; i < b.params.size(); ++i)
      b.params[i] += (b.params[i] + 1e-3 * (i + 1) <= info[i].upper ? 1 : -1) * 1e-3 * (i + 1);
    a.basis.push_back(b);
    a.weights.push_back(Ramp(6, 4, 3));
  }
  a.material_id = Image(6, 4, 1, 0.0f);
  SaveMaterial(a, dir / "all");
  const Material b = LoadMaterial(dir / "all");
  ASSERT_EQ(b.basis.size(), a.basis.size());
  for (size_t i = 0; i < a.basis.size(); ++i) {
    EXPECT_EQ(b.basis[i].spec.Label(), a.basis[i].spec.Label());
    EXPECT_EQ(b.basis[i].params, a.basis[i].params) << a.basis[i].spec.Label();
  }
}

TEST(Material, RoundTrip) {
  TempDir dir;
  const Material a = MakeMaterial();
  WriteText(dir / "out/stale.txt", "old");  // an old destination is replaced entirely
  SaveMaterial(a, dir / "out");
  EXPECT_FALSE(fs::exists(dir / "out/stale.txt"));
  const Material b = LoadMaterial(dir / "out");
  EXPECT_EQ(b.width, a.width);
  EXPECT_EQ(b.height, a.height);
  ASSERT_EQ(b.basis.size(), a.basis.size());
  for (size_t i = 0; i < a.basis.size(); ++i) {
    EXPECT_EQ(b.basis[i].name, a.basis[i].name);
    EXPECT_EQ(b.basis[i].spec.Label(), a.basis[i].spec.Label());
    EXPECT_EQ(b.basis[i].params, a.basis[i].params);
    EXPECT_EQ(b.weights[i].pixels, a.weights[i].pixels);
  }
  EXPECT_EQ(b.normal_map.pixels, a.normal_map.pixels);
  EXPECT_EQ(b.confidence.pixels, a.confidence.pixels);
  EXPECT_EQ(b.material_id.pixels, a.material_id.pixels);
  EXPECT_EQ(b.mesh.positions, a.mesh.positions);
  EXPECT_EQ(b.mesh.face_uvs, a.mesh.face_uvs);
  EXPECT_EQ(b.extra, a.extra);
  // Saving over an existing material works and leaves no temporary folder.
  SaveMaterial(b, dir / "out");
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir.str())) ++entries;
  EXPECT_EQ(entries, 1);
}

// "normal_map_space": tangent round-trips; world (the default) is not written,
// so such folders read the same in programs that predate the field; absent
// reads as world.
TEST(Material, NormalMapSpaceRoundTripsAndWorldIsTheDefault) {
  TempDir dir;
  Material a = MakeMaterial();
  a.normal_map_space = NormalMapSpace::kTangent;
  SaveMaterial(a, dir / "t");
  EXPECT_EQ(ReadJsonFile(dir / "t/material.json")["normal_map_space"], "tangent");
  const Material b = LoadMaterial(dir / "t");
  EXPECT_EQ(b.normal_map_space, NormalMapSpace::kTangent);
  EXPECT_EQ(b.normal_map.pixels, a.normal_map.pixels);
  a.normal_map_space = NormalMapSpace::kWorld;
  SaveMaterial(a, dir / "w");
  EXPECT_FALSE(ReadJsonFile(dir / "w/material.json").contains("normal_map_space"));
  EXPECT_EQ(LoadMaterial(dir / "w").normal_map_space, NormalMapSpace::kWorld);
  // Written explicitly as "world" it reads as world too.
  json j = ReadJsonFile(dir / "w/material.json");
  j["normal_map_space"] = "world";
  WriteText(dir / "w/material.json", j.dump());
  EXPECT_EQ(LoadMaterial(dir / "w").normal_map_space, NormalMapSpace::kWorld);
}

// Photometric materials' light residuals (io/material.h): directions and
// maps round-trip; the neighbours of a direction are the nearest in angle
// with weights 1 / angle summing to 1, and a direction that is a sample's
// gets that sample alone.
TEST(Material, LightResidualsRoundTripAndInterpolateTheNearest) {
  TempDir dir;
  Material a = MakeMaterial();
  a.light_residual_directions = {Vec3(0, 0, 1), Vec3(std::sin(0.1), 0, std::cos(0.1)),
                                 Vec3(0, std::sin(0.2), std::cos(0.2)), Vec3(-1, 0, 0)};
  for (int k = 0; k < 4; ++k) a.light_residuals.push_back(Image(6, 4, 3, 0.25f * k - 0.5f));
  SaveMaterial(a, dir / "r");
  const Material b = LoadMaterial(dir / "r");
  ASSERT_EQ(b.light_residuals.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_LT((b.light_residual_directions[k] - a.light_residual_directions[k]).norm(), 1e-12);
    EXPECT_EQ(b.light_residuals[k].pixels, a.light_residuals[k].pixels);
  }
  int index[kLightResidualNeighbours];
  double weight[kLightResidualNeighbours];
  const Vec3 d = Vec3(std::sin(0.05), 0, std::cos(0.05));  // halfway between samples 0 and 1
  ASSERT_EQ(LightResidualNeighbours(a.light_residual_directions, d, -1, index, weight), 3);
  EXPECT_EQ(index[2], 2);  // the -x sample is the farthest: not among the three
  EXPECT_NEAR(weight[0], weight[1], 1e-9);
  EXPECT_NEAR(weight[0] + weight[1] + weight[2], 1.0, 1e-12);
  const double a2 = std::acos(d.dot(a.light_residual_directions[2])), a0 = 0.05;
  EXPECT_NEAR(weight[2] / weight[0], a0 / a2, 1e-9);
  LightResidualNeighbours(a.light_residual_directions, a.light_residual_directions[1], -1, index, weight);
  EXPECT_EQ(index[0], 1);
  EXPECT_GT(weight[0], 1 - 1e-4);
  // Left out (leave-one-out): never among its own neighbours.
  ASSERT_EQ(LightResidualNeighbours(a.light_residual_directions, a.light_residual_directions[1], 1, index, weight), 3);
  for (int k = 0; k < 3; ++k) EXPECT_NE(index[k], 1);
  // More maps than directions cannot be written.
  a.light_residual_directions.pop_back();
  ExpectError([&] { SaveMaterial(a, dir / "bad"); }, {"3 directions"});
  EXPECT_FALSE(fs::exists(dir / "bad"));
}

TEST(Material, ErrorsNameTheField) {
  TempDir dir;
  SaveMaterial(MakeMaterial(), dir / "m");
  const std::string file = dir / "m/material.json";
  const json good = ReadJsonFile(file);
  struct Case {
    std::function<void(json&)> mutate;
    std::string needle;
  };
  const std::vector<Case> cases = {
      {[](json& j) { j["format"] = "svbrdf-material/0"; }, "format: expected \"svbrdf-material/1\""},
      {[](json& j) { j["basis"][0]["params"]["shininess"] = 3; }, "basis[0].params.shininess: unknown parameter"},
      {[](json& j) { j["basis"][2]["params"].erase("rd_g"); }, "basis[2].params: missing parameter(s) rd_g"},
      {[](json& j) { j["basis"][2]["model"] = "phong"; }, "basis[2].model: \"phong\" does not match"},
      {[](json& j) { j["basis"][1]["label"] = "cook_torrance-foo"; }, "basis[1].label: unknown reflectance model"},
      {[](json& j) { j["basis"][2]["params"]["rd_r"] = "x"; }, "basis[2].params.rd_r: expected number"},
      {[](json& j) { j["weights"].erase(2); }, "weights: expected one map per basis material"},
      {[](json& j) { j["weights"][1] = "weights/none.exr"; }, "weights[1]: "},
      {[](json& j) { j["resolution"] = {6, 5}; }, "weights[0]: "},
      {[](json& j) { j["resolution"] = {6}; }, "resolution: expected array of 2 numbers"},
      {[](json& j) { j["confidence"] = "normal.exr"; }, "confidence: "},
      {[](json& j) { j["mesh"] = "none.obj"; }, "mesh: "},
      {[](json& j) { j["normal_map_space"] = "object"; },
       "normal_map_space: expected \"world\" or \"tangent\", got \"object\""},
      {[](json& j) { j["normal_map_space"] = 1; }, "normal_map_space: expected string"},
      {[](json& j) { j.erase("normal_map"), j["normal_map_space"] = "tangent"; },
       "normal_map_space: given without a \"normal_map\""},
      {[](json& j) { j["light_residuals"] = {{"directions", {{0, 0, 1}, {0, 1, 0}}}, {"maps", {"normal.exr"}}}; },
       "light_residuals: expected as many directions as maps (at least one), got 2 and 1"},
      {[](json& j) { j["light_residuals"] = {{"directions", {{0, 0, 2}}}, {"maps", {"normal.exr"}}}; },
       "light_residuals.directions[0]: expected a unit vector, got length 2"},
      {[](json& j) { j["light_residuals"] = {{"directions", {{0, 0, 1}}}, {"maps", {"confidence.exr"}}}; },
       "light_residuals.maps[0]: "},
      {[](json& j) { j["light_residuals"] = {{"directions", {{0, 0, 1}}}}; }, "light_residuals.maps: missing"},
  };
  for (const Case& c : cases) {
    json j = good;
    c.mutate(j);
    WriteText(file, j.dump());
    ExpectError([&] { LoadMaterial(dir / "m"); }, {file + ": " + c.needle});
  }
}

TEST(OutputFolder, UncommittedLeavesNothing) {
  const fs::path dir = fs::temp_directory_path() / Msg("svbrdf_outdir_", getpid());
  fs::remove_all(dir);
  {
    OutputFolder out((dir / "result").string());
    EXPECT_NE(out.path(), out.final_path());
    EXPECT_EQ(fs::path(out.path()).parent_path(), dir) << "same parent, so the rename stays on one file system";
    std::ofstream(out.path() + "/a.txt") << "half";
    EXPECT_FALSE(fs::exists(dir / "result"));
  }  // an exception or early return: destroyed without Commit
  EXPECT_TRUE(fs::is_empty(dir));
  fs::remove_all(dir);
}

TEST(OutputFolder, CommitReplacesThePreviousResultWhole) {
  const fs::path dir = fs::temp_directory_path() / Msg("svbrdf_outdir2_", getpid());
  fs::remove_all(dir);
  fs::create_directories(dir / "result");
  std::ofstream(dir / "result" / "old.txt") << "old";
  {
    OutputFolder out((dir / "result/").string());  // a trailing slash names the same folder
    std::ofstream(out.path() + "/new.txt") << "new";
    EXPECT_TRUE(fs::exists(dir / "result" / "old.txt")) << "the previous result stays until the commit";
    out.Commit();
    out.Commit();  // idempotent
  }
  EXPECT_TRUE(fs::exists(dir / "result" / "new.txt"));
  EXPECT_FALSE(fs::exists(dir / "result" / "old.txt"));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1) << "no temporary left";
  // Nested: a material folder written atomically inside an output folder.
  {
    OutputFolder outer((dir / "outer").string());
    OutputFolder inner(outer.path());
    std::ofstream(inner.path() + "/x.txt") << "x";
    inner.Commit();
    outer.Commit();
  }
  EXPECT_TRUE(fs::exists(dir / "outer" / "x.txt"));
  // A file where the folder should go is an error before any work is done.
  std::ofstream(dir / "file") << "not a folder";
  EXPECT_THROW(OutputFolder((dir / "file").string()), Error);
  EXPECT_THROW(OutputFolder("."), Error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace svbrdf
