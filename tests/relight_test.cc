// Renderer checks against closed forms: a Lambertian sphere under a point
// light, a hard shadow, the COLMAP pixel convention, and the mask silhouette.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "atlas/atlas.h"
#include "brdf/fresnel.h"
#include "core/error.h"
#include "raytrace/sphere_mesh.h"
#include "relight/light_paths.h"
#include "relight/relight.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

constexpr double kRadius = 0.5;

Material UniformMaterial(const Mesh& mesh, const std::string& label, const std::vector<std::pair<std::string, double>>& params) {
  Material m;
  m.mesh = mesh;
  m.width = m.height = 4;
  BasisMaterial b;
  b.name = "m0";
  b.spec = ModelSpec::FromLabel(label);
  b.params = b.spec.InitialParams();
  const auto info = b.spec.Params();
  for (const auto& [name, value] : params)
    for (size_t i = 0; i < info.size(); ++i)
      if (info[i].name == name) b.params[i] = value;
  m.basis.push_back(b);
  m.weights.emplace_back(4, 4, 3, 1.0f);
  return m;
}

Vec3 FromAnglesWorld(double theta) { return Vec3(std::sin(theta), 0, std::cos(theta)); }

Mesh Sphere(double radius, const Vec3& centre, int rings = 200) {
  Mesh m = MakeUvSphere(rings, 2 * rings);
  for (Vec3& p : m.positions) p = centre + radius * p;
  return m;
}

Scene OneView(const Vec3& eye, const Light& light, int w = 160, int h = 120, double f = 150) {
  Scene s;
  Camera cam;
  cam.id = 1;
  cam.model = CameraModelId::kPinhole;
  cam.width = w;
  cam.height = h;
  cam.params = {f, f, w / 2.0, h / 2.0};
  s.cameras = {cam};
  s.lights = {light};
  ImageEntry e;
  e.file = "images/0000.exr";
  e.camera = 1;
  e.light = light.id;
  e.cam_from_world = Rigid3::LookAt(eye, Vec3::Zero(), Vec3::UnitY());
  s.images = {e};
  return s;
}

Light PointLight(const Vec3& p, double intensity) {
  Light l;
  l.id = 1;
  l.type = LightType::kPoint;
  l.position = p;
  l.intensity = Rgb::Constant(intensity);
  return l;
}

// Renders image 0 of `s` at pixel centres.
RenderedView RenderFirstView(const Mesh& mesh, const Material& mat, const Scene& s) {
  RayTracer tracer(mesh);
  MaterialShader shader(mat);
  RelightOptions ro;
  ro.progress = false;
  return RenderView(tracer, shader, s, 0, ro);
}

// Ray-sphere intersection of a pixel centre's ray, for the analytic reference.
bool AnalyticHit(const Scene& s, double px, double py, double radius, Vec3* x) {
  const ImageEntry& e = s.images[0];
  const Rigid3 wfc = e.cam_from_world.Inverse();
  const Vec3 o = wfc.translation;
  const Vec3 d = (wfc.rotation * s.cameras[0].Unproject(Vec2(px, py))).normalized();
  const double b = o.dot(d), c = o.squaredNorm() - radius * radius, disc = b * b - c;
  if (disc < 0) return false;
  *x = o + (-b - std::sqrt(disc)) * d;
  return true;
}

// The shader's transfer for a distant light adds the light residuals
// interpolated between the nearest sample directions (io/material.h) to the
// polynomial transfer; a new direction is not served the previous one's
// neighbours (they are cached per direction).
TEST(Relight, TransferAddsTheInterpolatedLightResiduals) {
  Material mat;
  mat.width = 2, mat.height = 1;
  mat.texture_filter = TextureFilter::kNearest;
  mat.light_transfer.assign(4, Image(2, 1, 3));
  for (int c = 0; c < 3; ++c) mat.light_transfer[0].at(1, 0, c) = 0.05f;  // constant term
  mat.light_residual_directions = {Vec3(0, 0, 1), Vec3(std::sin(0.2), 0, std::cos(0.2)),
                                   Vec3(0, std::sin(0.2), std::cos(0.2)), Vec3(-std::sin(0.2), 0, std::cos(0.2))};
  for (int k = 0; k < 4; ++k) {
    mat.light_residuals.push_back(Image(2, 1, 3));
    for (int c = 0; c < 3; ++c) mat.light_residuals[k].at(1, 0, c) = float(0.1 * (k + 1) * (c + 1));
  }
  const MaterialShader shader(mat);
  ASSERT_TRUE(shader.HasTransfer());
  const Vec2 texel1(0.75, 0.5);
  for (const Vec3& d : {Vec3(std::sin(0.1), 0, std::cos(0.1)), mat.light_residual_directions[2],
                        Vec3(std::sin(0.1), 0, std::cos(0.1))}) {
    int index[kLightResidualNeighbours];
    double weight[kLightResidualNeighbours];
    const int n = LightResidualNeighbours(mat.light_residual_directions, d, -1, index, weight);
    Rgb expected = Rgb::Constant(0.05);
    for (int k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c) expected[c] += weight[k] * 0.1 * (index[k] + 1) * (c + 1);
    const Rgb t = shader.Transfer(texel1, d);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(t[c], expected[c], 1e-6);
  }
  // Exactly on sample 2: its residual alone (weights 1 / angle).
  EXPECT_NEAR(shader.Transfer(texel1, mat.light_residual_directions[2])[0], 0.05 + 0.3, 1e-4);
  // Texel 0 holds no transfer and no residual.
  EXPECT_EQ(shader.Transfer(Vec2(0.25, 0.5), Vec3(0, 0, 1))[0], 0.0);
}

// Shaders made one after another (here likely at the same address, for
// the same light) each interpolate their own material's residual samples:
// the per-thread neighbour cache must not serve one the other's.
TEST(Relight, LightResidualNeighboursAreNotSharedBetweenShaders) {
  const Vec3 d(0, 0, 1);
  for (int round = 0; round < 3; ++round) {
    Material mat;
    mat.width = 1, mat.height = 1;
    mat.texture_filter = TextureFilter::kNearest;
    const int samples = round == 1 ? 1 : 4;
    for (int k = 0; k < samples; ++k) {
      const double a = 0.1 * (k + 1) * (round + 1);
      mat.light_residual_directions.push_back(Vec3(std::sin(a), 0, std::cos(a)));
      mat.light_residuals.push_back(Image(1, 1, 3, float(round + 1)));
    }
    const MaterialShader shader(mat);
    // Every sample holds round + 1, so any weights give it back.
    EXPECT_NEAR(shader.Transfer(Vec2(0.5, 0.5), d)[0], round + 1.0, 1e-6) << "round " << round;
  }
}

TEST(Relight, LambertianSphereMatchesClosedForm) {
  const double rd = 0.6, intensity = 5.0;
  const Mesh mesh = Sphere(kRadius, Vec3::Zero());
  const Material mat = UniformMaterial(mesh, "lambert", {{"rd_r", rd}, {"rd_g", rd}, {"rd_b", rd}});
  const Scene s = OneView(Vec3(0, 0.3, 2.0), PointLight(Vec3(1.0, 1.5, 1.5), intensity));
  const RenderedView v = RenderFirstView(mesh, mat, s);
  double max_rel = 0, sum_rel = 0;
  int n = 0;
  for (int y = 0; y < v.color.height; ++y)
    for (int x = 0; x < v.color.width; ++x) {
      Vec3 p;
      if (!AnalyticHit(s, x + 0.5, y + 0.5, kRadius, &p)) continue;
      const Vec3 nrm = p.normalized(), l = s.lights[0].position - p;
      const double cos_i = nrm.dot(l.normalized());
      const Vec3 eye = s.images[0].cam_from_world.CentreInWorld();
      // Away from the silhouette and the terminator, where tessellation dominates.
      if (cos_i < 0.1 || nrm.dot((eye - p).normalized()) < 0.2) continue;
      const double expected = rd / kPi * intensity * cos_i / l.squaredNorm();
      const double rel = std::abs(v.color.at(x, y, 1) - expected) / expected;
      max_rel = std::max(max_rel, rel);
      sum_rel += rel;
      ++n;
    }
  ASSERT_GT(n, 3000);
  RecordProperty("max_relative_error", std::to_string(max_rel));
  std::printf("Lambertian sphere: %d pixels, max relative error %.2e, mean %.2e\n", n, max_rel, sum_rel / n);
  EXPECT_LT(max_rel, 2e-3);
  EXPECT_LT(sum_rel / n, 3e-4);
}

// The shading normal is the mesh file's own (OBJ vn): a flat floor whose file
// normals are tilted 30 deg renders as Lambert with the tilted normal,
// rd / pi * E * cos(30 deg) under a light straight above, as Mitsuba renders
// it; normals recomputed from the triangles gave rd / pi * E.
TEST(Relight, ShadesWithTheNormalsOfTheMeshFile) {
  const fs::path dir = fs::temp_directory_path() / Msg("svbrdf_relight_vn_", getpid());
  fs::create_directories(dir);
  const double s30 = 0.5, c30 = std::sqrt(3.0) / 2;
  {
    std::ofstream out(dir / "floor.obj");
    out << "v -2 0 -2\nv -2 0 2\nv 2 0 2\nv 2 0 -2\nvn " << s30 << " " << c30 << " 0\n"
        << "f 1//1 2//1 3//1\nf 1//1 3//1 4//1\n";
  }
  const Mesh mesh = LoadMesh((dir / "floor.obj").string());
  fs::remove_all(dir);
  const double rd = 0.5, irradiance = 2.0;
  const Material mat = UniformMaterial(mesh, "lambert", {{"rd_r", rd}, {"rd_g", rd}, {"rd_b", rd}});
  Light sun;
  sun.id = 1;
  sun.type = LightType::kDirectional;
  sun.to_light = Vec3::UnitY();
  sun.irradiance = Rgb::Constant(irradiance);
  const Scene s = OneView(Vec3(0.3, 3, 0.2), sun, 64, 48, 60);
  const RenderedView v = RenderFirstView(mesh, mat, s);
  const double expected = rd / kPi * irradiance * c30;
  int n = 0;
  for (int y = 0; y < v.color.height; ++y)
    for (int x = 0; x < v.color.width; ++x) {
      if (!(v.mask.at(x, y, 0) > 0)) continue;
      EXPECT_NEAR(v.color.at(x, y, 1), expected, 1e-5 * expected) << x << ", " << y;
      ++n;
    }
  EXPECT_GT(n, 1000);
}

// A unit sphere's front, 120 x 120 deg in latitude and longitude, as an n x n
// grid of quads with the grid's texture coordinates and exact normals.
Mesh SpherePatch(int n) {
  Mesh m;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double th = kPi * (30.0 + 120.0 * i / n) / 180, ph = kPi * (-60.0 + 120.0 * j / n) / 180;
      m.positions.emplace_back(std::sin(th) * std::sin(ph), std::cos(th), std::sin(th) * std::cos(ph));
      m.texcoords.emplace_back(double(j) / n, 1.0 - double(i) / n);
    }
  const auto id = [&](int i, int j) { return i * (n + 1) + j; };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      m.faces.emplace_back(id(i, j), id(i + 1, j), id(i, j + 1));
      m.faces.emplace_back(id(i, j + 1), id(i + 1, j), id(i + 1, j + 1));
    }
  m.face_uvs = m.faces;
  m.normals = m.positions;
  return m;
}

// A tangent-space map is applied in the frame of the shading point (io/
// normal_map_space.h): on a coarse sphere whose normal turns ~20 deg within
// one texel, a tangent map of (0, 0, 1) renders exactly the mesh normals,
// while a world map of the same normals (the texel centres' mesh normals, as
// a map refined to "no change" was written before normal_map_space) holds
// each texel centre's normal across the texel and shades it visibly wrong.
TEST(Relight, TangentNormalMapKeepsTheMeshsTurnWithinATexel) {
  const int res = 6;  // 6 x 6 texels over 120 x 120 deg of a unit sphere: 20 deg per texel
  const Mesh mesh = SpherePatch(24);
  Material plain = UniformMaterial(mesh, "cook_torrance-ggx-smith-schlick", {});
  plain.width = plain.height = res;
  plain.weights = {Image(res, res, 3, 1.0f)};
  const Atlas atlas = BuildAtlas(mesh, res, res);
  ASSERT_EQ(atlas.texels.size(), size_t(res * res));
  double max_turn = 0;  // largest angle between a texel's normal and its neighbour's: the turn per texel
  for (const Texel& a : atlas.texels)
    if (a.x + 1 < res && atlas.At(a.x + 1, a.y) >= 0)
      max_turn = std::max(max_turn, std::acos(std::min(1.0, a.normal.dot(atlas.texels[atlas.At(a.x + 1, a.y)].normal))));
  EXPECT_GT(max_turn * 180 / kPi, 15.0);
  Material tangent = plain, world = plain;
  tangent.normal_map = world.normal_map = Image(res, res, 3, 0.0f);
  tangent.normal_map_space = NormalMapSpace::kTangent;
  for (const Texel& t : atlas.texels) {
    const Vec3 vt = MapValueFromNormal(t.normal, NormalMapSpace::kTangent, t.normal, t.tangent);
    const Vec3 vw = MapValueFromNormal(t.normal, NormalMapSpace::kWorld, t.normal, t.tangent);
    for (int c = 0; c < 3; ++c) tangent.normal_map.at(t.x, t.y, c) = float(vt[c]), world.normal_map.at(t.x, t.y, c) = float(vw[c]);
  }
  for (const Texel& t : atlas.texels) EXPECT_NEAR(tangent.normal_map.at(t.x, t.y, 2), 1.0, 1e-12);
  const Scene s = OneView(Vec3(0.4, 0.5, 2.5), PointLight(Vec3(1.5, 2.0, 2.0), 5.0));
  const RenderedView ref = RenderFirstView(mesh, plain, s);
  const RenderedView vt = RenderFirstView(mesh, tangent, s);
  const RenderedView vw = RenderFirstView(mesh, world, s);
  double max_t = 0, max_w = 0, sum_w = 0, sum_ref = 0;
  int n = 0;
  for (int y = 0; y < ref.color.height; ++y)
    for (int x = 0; x < ref.color.width; ++x)
      if (ref.mask.at(x, y, 0) > 0)
        for (int c = 0; c < 3; ++c) {
          max_t = std::max(max_t, double(std::abs(vt.color.at(x, y, c) - ref.color.at(x, y, c))));
          max_w = std::max(max_w, double(std::abs(vw.color.at(x, y, c) - ref.color.at(x, y, c))));
          sum_w += std::abs(vw.color.at(x, y, c) - ref.color.at(x, y, c));
          sum_ref += ref.color.at(x, y, c), ++n;
        }
  ASSERT_GT(n, 3000);
  const double mean = sum_ref / n;
  std::printf("turn per texel %.1f deg; |difference| from the mesh-normal render: tangent map max %.2e, world map "
              "max %.2e, mean %.2e (mean radiance %.3f)\n", max_turn * 180 / kPi, max_t, max_w, sum_w / n, mean);
  EXPECT_LT(max_t, 1e-6 * mean);
  EXPECT_GT(max_w, 0.1 * mean);
  EXPECT_GT(sum_w / n, 0.002 * mean);
}

TEST(Relight, HardShadowBehindABlocker) {
  // A floor quad at y = 0, a small blocker quad at y = 0.5, light above.
  Mesh mesh;
  auto quad = [&](double y, double h) {
    const int b = static_cast<int>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), {Vec3(-h, y, -h), Vec3(-h, y, h), Vec3(h, y, h), Vec3(h, y, -h)});
    mesh.faces.emplace_back(b, b + 1, b + 2);
    mesh.faces.emplace_back(b, b + 2, b + 3);
  };
  quad(0.0, 2.0);
  quad(0.5, 0.1);
  mesh.ComputeNormals();
  const Material mat = UniformMaterial(mesh, "lambert", {{"rd_r", 0.5}, {"rd_g", 0.5}, {"rd_b", 0.5}});
  Scene s = OneView(Vec3(1.5, 3, 0.3), PointLight(Vec3(0, 2.0, 0), 4.0), 101, 101, 60);
  const RenderedView v = RenderFirstView(mesh, mat, s);
  // The shadow of the blocker's 0.2 m square on the floor is 0.2 * 2/1.5 wide
  // around the origin; the blocker itself is lit (seen from above).
  int shadow = 0, lit = 0;
  for (int y = 0; y < v.color.height; ++y)
    for (int x = 0; x < v.color.width; ++x) {
      const Vec3 dir = s.images[0].cam_from_world.Inverse().rotation * s.cameras[0].Unproject(Vec2(x + 0.5, y + 0.5));
      const Vec3 o = s.images[0].cam_from_world.CentreInWorld();
      const Vec3 floor = o + dir * (-o.y() / dir.y());
      const double half = 0.1 * 2.0 / 1.5;
      const Vec3 on_blocker = o + dir * ((0.5 - o.y()) / dir.y());
      if (std::abs(on_blocker.x()) < 0.1 && std::abs(on_blocker.z()) < 0.1) continue;  // sees the blocker
      if (std::abs(floor.x()) > 1.99 || std::abs(floor.z()) > 1.99) continue;            // beyond the floor
      if (std::abs(floor.x()) < half * 0.95 && std::abs(floor.z()) < half * 0.95) {
        EXPECT_EQ(v.color.at(x, y, 0), 0.0f) << "pixel " << x << "," << y << " should be in shadow";
        ++shadow;
      } else if (std::abs(floor.x()) > half * 1.05 || std::abs(floor.z()) > half * 1.05) {
        const Vec3 l = s.lights[0].position - floor;
        const double expected = 0.5 / kPi * 4.0 * l.normalized().y() / l.squaredNorm();
        EXPECT_NEAR(v.color.at(x, y, 0), expected, 1e-4 * expected + 1e-7);
        ++lit;
      }
    }
  EXPECT_GT(shadow, 0);
  EXPECT_GT(lit, 1000);
}

TEST(Relight, ProjectionFollowsColmapPixelConvention) {
  // A tiny sphere at known world points: the centroid of its mask (pixel
  // centres at +0.5) lands on the camera's projection of its centre.
  for (const Vec3& c : {Vec3(0.1, -0.05, 0.0), Vec3(-0.3, 0.2, 0.1)}) {
    const Mesh mesh = Sphere(0.02, c, 40);
    const Material mat = UniformMaterial(mesh, "lambert", {});
    const Scene s = OneView(Vec3(0, 0, 3.0), PointLight(Vec3(0, 0, 3), 1.0), 200, 150, 500);
    const RenderedView v = RenderFirstView(mesh, mat, s);
    double sx = 0, sy = 0, n = 0;
    for (int y = 0; y < v.mask.height; ++y)
      for (int x = 0; x < v.mask.width; ++x)
        if (v.mask.at(x, y, 0) > 0) sx += x + 0.5, sy += y + 0.5, n += 1;
    ASSERT_GT(n, 10);
    const Vec2 expected = s.cameras[0].Project(s.images[0].cam_from_world * c);
    EXPECT_NEAR(sx / n, expected.x(), 0.15);
    EXPECT_NEAR(sy / n, expected.y(), 0.15);
  }
}

TEST(Relight, MaskMatchesAnalyticSilhouette) {
  const Mesh mesh = Sphere(kRadius, Vec3::Zero());
  const Material mat = UniformMaterial(mesh, "lambert", {});
  const Scene s = OneView(Vec3(0.2, 0.4, 1.8), PointLight(Vec3(0, 2, 2), 1.0));
  const RenderedView v = RenderFirstView(mesh, mat, s);
  long inter = 0, uni = 0;
  for (int y = 0; y < v.mask.height; ++y)
    for (int x = 0; x < v.mask.width; ++x) {
      Vec3 p;
      const bool a = AnalyticHit(s, x + 0.5, y + 0.5, kRadius, &p), b = v.mask.at(x, y, 0) > 0;
      inter += a && b;
      uni += a || b;
    }
  const double iou = double(inter) / uni;
  std::printf("mask IoU vs analytic silhouette: %.5f\n", iou);
  EXPECT_GT(iou, 0.995);
}

TEST(Relight, DeterministicWithSeedAndThreads) {
  const Mesh mesh = Sphere(kRadius, Vec3::Zero(), 40);
  const Material mat = UniformMaterial(mesh, "cook_torrance-ggx", {{"roughness", 0.2}});
  const Scene s = OneView(Vec3(0, 0.3, 2.0), PointLight(Vec3(1.0, 1.5, 1.5), 5.0), 64, 48, 60);
  RayTracer tracer(mesh);
  MaterialShader shader(mat);
  RelightOptions a;
  a.progress = false;
  a.samples_per_pixel = 3;
  a.threads = 1;
  RelightOptions b = a;
  b.threads = 2;
  const RenderedView va = RenderView(tracer, shader, s, 0, a), vb = RenderView(tracer, shader, s, 0, b);
  EXPECT_EQ(va.color.pixels, vb.color.pixels);
  RelightOptions c = a;
  c.seed = 99;
  EXPECT_NE(va.color.pixels, RenderView(tracer, shader, s, 0, c).color.pixels);
}

// Interreflection inside a closed Lambertian sphere (radius R, albedo rho)
// with a point light of intensity I at its centre: every wall point gets the
// direct irradiance E = I / R^2, and since the form factor from any point of
// a sphere's inside to an area dA of it is dA / (4 pi R^2), every bounce
// multiplies the irradiance by rho uniformly. With N bounces the wall's
// radiance is rho/pi E (1 + rho + ... + rho^N). Paths up to the first
// Russian roulette have zero variance here; the mean over the image must
// match the closed form for any N, and N = 0 is the direct-only renderer.
TEST(Relight, BouncesInsideASphereMatchTheClosedForm) {
  const double radius = 1.0, rho = 0.5, intensity = 3.0;
  Mesh mesh = Sphere(radius, Vec3::Zero(), 60);
  for (Vec3i& f : mesh.faces) std::swap(f[1], f[2]);  // normals inwards
  if (!mesh.face_uvs.empty())
    for (Vec3i& f : mesh.face_uvs) std::swap(f[1], f[2]);
  mesh.ComputeNormals();
  const Material mat = UniformMaterial(mesh, "lambert", {{"rd_r", rho}, {"rd_g", rho}, {"rd_b", rho}});
  Scene s = OneView(Vec3(0, 0, 0.3), PointLight(Vec3::Zero(), intensity), 64, 48, 40);
  s.images[0].cam_from_world = Rigid3::LookAt(Vec3(0, 0, 0.3), Vec3(0, 0, -1), Vec3::UnitY());
  RayTracer tracer(mesh);
  MaterialShader shader(mat);
  for (int bounces : {0, 1, 3}) {
    RelightOptions o;
    o.progress = false;
    o.bounces = bounces;
    o.bounce_samples = 8;
    const RenderedView v = RenderView(tracer, shader, s, 0, o);
    double sum = 0;
    int n = 0;
    for (int y = 0; y < v.color.height; ++y)
      for (int x = 0; x < v.color.width; ++x) {
        if (v.mask.at(x, y, 0) == 0) continue;
        sum += v.color.at(x, y, 1);
        ++n;
      }
    ASSERT_EQ(n, 64 * 48);  // the camera sees only the inside
    double series = 0;
    for (int k = 0; k <= bounces; ++k) series += std::pow(rho, k);
    const double expected = rho / kPi * intensity / (radius * radius) * series;
    EXPECT_NEAR(sum / n, expected, 0.01 * expected) << bounces << " bounces";
  }
}

// The flat coat's mirror reflection (MaterialShader::Mirror) inside a
// sphere lit from its centre: the lower half a black-based `plastic` (no
// diffuse light, only its coat's delta reflection), the upper half white
// Lambert, whose radiance is rho/pi I/r^2 towards every direction. With one
// bounce a pixel on the plastic shows F(<N|wo>) times that (its mirror ray
// meets the Lambertian half; one that met the plastic would see nothing).
TEST(Relight, FlatCoatMirrorsTheRoomInClosedForm) {
  const double rho = 0.8, intensity = 2.0, ior = 1.5;
  Mesh mesh = Sphere(1.0, Vec3::Zero(), 60);
  for (Vec3i& f : mesh.faces) std::swap(f[1], f[2]);  // normals inwards
  mesh.ComputeNormals();
  for (const Vec3& p : mesh.positions) mesh.texcoords.emplace_back(0.5, p.z() > 0 ? 0.75 : 0.25);
  mesh.face_uvs = mesh.faces;
  Material mat = UniformMaterial(mesh, "lambert", {{"rd_r", rho}, {"rd_g", rho}, {"rd_b", rho}});
  BasisMaterial coat;
  coat.name = "m1";
  coat.spec = ModelSpec::FromLabel("plastic");
  coat.params = {0, 0, 0, ior};
  mat.basis.push_back(coat);
  mat.texture_filter = TextureFilter::kNearest;
  const int rows = 8;
  const Vec2 upper = UvToTexel(Vec2(0.5, 0.75), 1, rows);
  mat.weights = {Image(1, rows, 3, 0.0f), Image(1, rows, 3, 0.0f)};
  for (int y = 0; y < rows; ++y) {
    const bool lambert = std::abs(y + 0.5 - upper.y()) < rows / 4.0;
    for (int c = 0; c < 3; ++c) mat.weights[lambert ? 0 : 1].at(0, y, c) = 1.0f;
  }
  Scene s = OneView(Vec3(0, 0, 0.3), PointLight(Vec3::Zero(), intensity), 64, 48, 40);
  s.images[0].cam_from_world = Rigid3::LookAt(Vec3(0, 0, 0.3), Vec3(0, 0, -1), Vec3::UnitY());
  RayTracer tracer(mesh);
  MaterialShader shader(mat);
  ASSERT_TRUE(shader.HasMirror());
  RelightOptions o;
  o.progress = false;
  o.bounces = 1;
  o.bounce_samples = 64;
  const RenderedView v = RenderView(tracer, shader, s, 0, o);
  const Rigid3 wfc = s.images[0].cam_from_world.Inverse();
  double rendered = 0, expected = 0;
  int n = 0, lit = 0;
  for (int y = 0; y < v.color.height; ++y)
    for (int x = 0; x < v.color.width; ++x) {
      const Vec3 d = (wfc.rotation * s.cameras[0].Unproject(Vec2(x + 0.5, y + 0.5))).normalized();
      const Vec3 o_ = wfc.translation;
      const double b = o_.dot(d), c = o_.squaredNorm() - 1;
      const Vec3 hit = o_ + (-b + std::sqrt(b * b - c)) * d;  // from inside: the far root
      const Vec3 normal = -hit;                               // inwards
      const Vec3 r = d - 2 * d.dot(normal) * normal;
      const Vec3 hit2 = hit - 2 * hit.dot(r) * r;  // the chord from hit along r
      if (hit.z() > -0.15 || std::abs(hit2.z()) < 0.15) continue;  // away from the seam
      const double f = brdf::FresnelDielectric(normal.dot(-d), ior);
      expected += hit2.z() > 0 ? f * rho / kPi * intensity : 0.0;
      lit += hit2.z() > 0;
      rendered += v.color.at(x, y, 1);
      ++n;
    }
  ASSERT_GT(n, 500);
  ASSERT_GT(lit, 100);
  EXPECT_NEAR(rendered / n, expected / n, 0.03 * expected / n);
  // Without bounces the coat shows nothing: its BRDF has no diffuse part.
  o.bounces = 0;
  const RenderedView direct = RenderView(tracer, shader, s, 0, o);
  EXPECT_LT(direct.color.at(32, 24, 1), 1e-9);
}

// A mirror's delta reflection is Schlick's curve of its F0, times its weight.
TEST(Relight, MirrorReflectanceIsSchlicksCurveOfItsF0) {
  Mesh mesh = Sphere(1.0, Vec3::Zero(), 8);
  Material mat = UniformMaterial(mesh, "mirror", {{"f0_r", 0.9}, {"f0_g", 0.6}, {"f0_b", 0.3}});
  MaterialShader shader(mat);
  ASSERT_TRUE(shader.HasMirror());
  const Frame frame = Frame::FromNormal(Vec3(0, 0, 1));
  const Rgb normal = shader.Mirror(Vec2(0.5, 0.5), frame, Vec3(0, 0, 1));
  EXPECT_NEAR(normal[0], 0.9, 1e-12);
  EXPECT_NEAR(normal[2], 0.3, 1e-12);
  const Vec3 wo = FromAnglesWorld(1.2);
  const double s5 = std::pow(1 - std::cos(1.2), 5);
  EXPECT_NEAR(shader.Mirror(Vec2(0.5, 0.5), frame, wo)[1], 0.6 + 0.4 * s5, 1e-12);
  EXPECT_TRUE(shader.Mirror(Vec2(0.5, 0.5), frame, Vec3(0, 0, -1)).isZero());  // below the surface
  EXPECT_TRUE(MaterialShader(UniformMaterial(mesh, "lambert", {})).Mirror(Vec2(0.5, 0.5), frame, wo).isZero());
}

// A glossy point inside a white room: the mixture directions (GlossyMixture)
// estimate the same indirect light as cosine-weighted ones, with far less
// noise, because cosine directions rarely land in a narrow lobe.
TEST(Relight, GlossyMixtureDirectionsAreUnbiasedAndLessNoisy) {
  Mesh mesh = Sphere(1.0, Vec3::Zero(), 60);
  for (Vec3i& f : mesh.faces) std::swap(f[1], f[2]);  // normals inwards
  if (!mesh.face_uvs.empty())
    for (Vec3i& f : mesh.face_uvs) std::swap(f[1], f[2]);
  mesh.ComputeNormals();
  const Material room = UniformMaterial(mesh, "lambert", {{"rd_r", 0.7}, {"rd_g", 0.7}, {"rd_b", 0.7}});
  const Material glossy = UniformMaterial(mesh, "cook_torrance-ggx-nofresnel",
                                          {{"rd_r", 0.02}, {"rd_g", 0.02}, {"rd_b", 0.02}, {"rs_r", 0.9},
                                           {"rs_g", 0.9}, {"rs_b", 0.9}, {"roughness", 0.08}});
  RayTracer tracer(mesh);
  MaterialShader room_shader(room), glossy_shader(glossy);
  const Light light = PointLight(Vec3(0.5, 0.3, 0.2), 2.0);  // LightPaths keeps a reference
  const LightPaths paths(tracer, room_shader, light, Rigid3());
  const Vec3 x(0, 0, -0.99), n(0, 0, 1);  // just inside the (tessellated) wall, facing the room
  const Frame frame = Frame::FromNormal(n);
  const Vec3 wo = (Vec3(0.4, 0.0, 0.3) - x).normalized();
  auto f = [&](const Vec3& wi) { return glossy_shader.Eval(Vec2(0.5, 0.5), frame, wi, wo); };
  auto leave = [&](const Vec3&) { return Vec3(x + n * LightPaths::kSceneScale); };
  auto stats = [&](bool mixture, int n_paths, uint64_t seed) {
    Rng rng(seed);
    double sum = 0, sum2 = 0;
    for (int k = 0; k < n_paths; ++k) {
      const double v = paths.Indirect(frame, f, leave, 1, 1, rng, mixture ? &wo : nullptr)[1];
      sum += v, sum2 += v * v;
    }
    const double mean = sum / n_paths;
    return std::pair<double, double>(mean, std::sqrt(std::max(0.0, sum2 / n_paths - mean * mean)));
  };
  const int kPaths = 200000;
  const auto [mean_cos, sd_cos] = stats(false, kPaths, 1);
  const auto [mean_mix, sd_mix] = stats(true, kPaths, 2);
  ASSERT_GT(mean_cos, 0);
  const double standard_error = std::sqrt((sd_cos * sd_cos + sd_mix * sd_mix) / kPaths);
  EXPECT_NEAR(mean_mix, mean_cos, 4 * standard_error) << "the mixture must estimate the same light";
  EXPECT_LT(standard_error, 0.02 * mean_cos);  // the comparison above is a sharp one
  EXPECT_LT(sd_mix, 0.5 * sd_cos) << "per-path noise, mixture " << sd_mix << " vs cosine " << sd_cos;
  // Below-surface mixture directions have no density: the estimate ignores them.
  EXPECT_EQ(GlossyMixture::Pdf(frame, GlossyMixture::Mirror(frame, wo), Vec3(0, 0, -1)), 0.0);
}

// A convex object cannot light itself: indirect paths leave it.
TEST(Relight, ConvexObjectGetsNoIndirectLight) {
  const Mesh mesh = Sphere(kRadius, Vec3::Zero(), 60);
  const Material mat = UniformMaterial(mesh, "lambert", {{"rd_r", 0.6}, {"rd_g", 0.6}, {"rd_b", 0.6}});
  const Scene s = OneView(Vec3(0, 0.3, 2.0), PointLight(Vec3(1.0, 1.5, 1.5), 5.0), 64, 48, 60);
  RayTracer tracer(mesh);
  MaterialShader shader(mat);
  RelightOptions direct;
  direct.progress = false;
  RelightOptions bounced = direct;
  bounced.bounces = 2;
  const RenderedView a = RenderView(tracer, shader, s, 0, direct), b = RenderView(tracer, shader, s, 0, bounced);
  double sa = 0, sb = 0;
  for (size_t i = 0; i < a.color.pixels.size(); ++i) sa += a.color.pixels[i], sb += b.color.pixels[i];
  EXPECT_GT(sa, 0);
  EXPECT_NEAR(sb, sa, 1e-3 * sa);  // only grazing rays on the tessellation can hit the sphere again
  RelightOptions bad;
  bad.bounces = -1;
  EXPECT_THROW(bad.Check(), Error);
}

TEST(Relight, RejectsBadOptions) {
  RelightOptions o;
  o.samples_per_pixel = 0;
  EXPECT_THROW(o.Check(), Error);
  RelightOptions a;
  a.adaptive_max_rounds = 8;  // rounds of n x n samples need n >= 2
  EXPECT_THROW(a.Check(), Error);
  a.samples_per_pixel = 4;
  EXPECT_NO_THROW(a.Check());
  a.adaptive_tolerance = 0;
  EXPECT_THROW(a.Check(), Error);
}

// Adaptive supersampling against the closed form of a pixel integral: a
// straight edge at 37 % of each pixel's width (value 0.37 exactly) converges
// far below the fixed 4 x 4 error, and flat pixels stop after one round.
TEST(Relight, AdaptiveSupersamplingConvergesOnEdgesAndSkipsFlatPixels) {
  constexpr int kW = 64;
  Camera cam;
  cam.width = kW;
  cam.height = 2;  // row 0: edges, row 1: flat
  ImageEntry entry;
  std::vector<std::atomic<int>> calls(2 * kW);
  const PixelRadiance radiance = [&](double px, double py, Rng&, bool* hit) {
    *hit = true;
    ++calls[int(py) * kW + int(px)];
    const double v = py < 1 ? (px - std::floor(px) < 0.37 ? 1.0 : 0.0) : 0.37;
    return Rgb(v, v, v);
  };
  RelightOptions fixed;
  fixed.samples_per_pixel = 4;
  fixed.progress = false;
  RelightOptions adaptive = fixed;
  adaptive.adaptive_max_rounds = 64;
  adaptive.adaptive_tolerance = 0.001;
  auto mean_error = [&](const RenderedView& v, int row) {
    double e = 0;
    for (int x = 0; x < kW; ++x) e += std::abs(v.color.at(x, row, 0) - 0.37);
    return e / kW;
  };
  for (auto& c : calls) c = 0;
  const RenderedView f = RenderPixels(cam, entry, 0, fixed, radiance);
  for (auto& c : calls) c = 0;
  const RenderedView a = RenderPixels(cam, entry, 0, adaptive, radiance);
  const double fixed_error = mean_error(f, 0), adaptive_error = mean_error(a, 0);
  EXPECT_GT(fixed_error, 0.01);
  EXPECT_LT(adaptive_error, 0.25 * fixed_error) << "fixed " << fixed_error;
  EXPECT_LT(mean_error(a, 1), 1e-6);
  int edge_calls = 0;
  for (int x = 0; x < kW; ++x) {
    EXPECT_EQ(calls[kW + x], 1 + 16) << "flat pixel " << x << ": the centre (mask) and one round";
    edge_calls += calls[x];
  }
  EXPECT_GE(edge_calls, kW * (1 + 4 * 16)) << "edge pixels: at least 4 rounds";
}

EnvironmentMap ConstantEnvironment(double radiance) {
  return EnvironmentMap(8, 4, std::vector<float>(8 * 4 * 3, float(radiance)), "constant");
}

// Relative RMS over the object's pixels (mask) of a against b.
double RelRms(const RenderedView& a, const RenderedView& b) {
  double num = 0, den = 0;
  for (size_t p = 0; p < a.mask.pixels.size(); ++p) {
    if (a.mask.pixels[p] == 0) continue;
    for (int c = 0; c < 3; ++c) {
      const double x = a.color.pixels[3 * p + c], y = b.color.pixels[3 * p + c];
      num += (x - y) * (x - y);
      den += y * y;
    }
  }
  return std::sqrt(num / den);
}

TEST(RelightEnvironment, WhiteFurnaceLambertianSphereGivesAlbedoTimesRadiance) {
  // Constant environment L on a convex Lambertian sphere (no self-shadowing):
  // radiance = albedo * L at every visible point.
  const double albedo = 0.7, L = 2.0;
  const Mesh mesh = Sphere(kRadius, Vec3::Zero(), 60);
  const Material mat = UniformMaterial(mesh, "lambert", {{"rd_r", albedo}, {"rd_g", albedo}, {"rd_b", albedo}});
  const Scene s = OneView(Vec3(0, 0.3, 2.0), PointLight(Vec3(1, 1, 1), 1), 40, 30, 40);
  RayTracer tracer(mesh);
  MaterialShader shader(mat);
  RelightOptions o;
  o.progress = false;
  o.env_samples = 256;
  const RenderedView v = RenderViewEnvironment(tracer, shader, s, 0, ConstantEnvironment(L), o);
  double sum = 0, worst = 0, sq = 0;
  long n = 0;
  for (size_t p = 0; p < v.mask.pixels.size(); ++p) {
    if (v.mask.pixels[p] == 0) continue;
    const double r = v.color.pixels[3 * p] / (albedo * L);
    sum += r;
    sq += (r - 1) * (r - 1);
    worst = std::max(worst, std::abs(r - 1));
    ++n;
  }
  std::printf("furnace: %ld pixels, mean ratio %.5f, rms %.4f, worst %.4f\n", n, sum / n, std::sqrt(sq / n), worst);
  ASSERT_GT(n, 100);
  EXPECT_NEAR(sum / n, 1.0, 0.005);   // mean over pixels: no bias beyond 0.5 %
  EXPECT_LT(std::sqrt(sq / n), 0.035);  // per-pixel noise at 256 + 256 samples (measured 2.2 %)
  EXPECT_LT(worst, 0.12);             // no outlier beyond ~5 sigma
}

TEST(RelightEnvironment, ErrorFallsAsOneOverSqrtSamplesAndIsDeterministic) {
  const Mesh mesh = Sphere(kRadius, Vec3::Zero(), 40);
  const Material mat = UniformMaterial(mesh, "cook_torrance-ggx", {{"roughness", 0.3}});
  const Scene s = OneView(Vec3(0, 0.3, 2.0), PointLight(Vec3(1, 1, 1), 1), 24, 18, 24);
  RayTracer tracer(mesh);
  MaterialShader shader(mat);
  // A sky with a bright sun patch.
  std::vector<float> rgb(32 * 16 * 3, 0.5f);
  for (int c = 0; c < 3; ++c) rgb[(3 * 32 + 20) * 3 + c] = 200.0f;
  const EnvironmentMap env(32, 16, rgb, "sky");
  RelightOptions o;
  o.progress = false;
  o.env_samples = 2048;
  const RenderedView ref = RenderViewEnvironment(tracer, shader, s, 0, env, o);
  std::vector<double> err;
  for (int n : {4, 16, 64}) {
    double e = 0;
    for (uint64_t seed : {11, 12, 13, 14}) {  // average over seeds: a smoother estimate of the RMS error
      o.env_samples = n;
      o.seed = seed;
      e += RelRms(RenderViewEnvironment(tracer, shader, s, 0, env, o), ref) / 4;
    }
    err.push_back(e);
  }
  std::printf("environment: relative RMS error %.4f, %.4f, %.4f at 4, 16, 64 samples\n", err[0], err[1], err[2]);
  // 1/sqrt(N): a factor 2 per 4x samples (the reference's own error is ~ 1/sqrt(32) of the N = 64 one).
  EXPECT_NEAR(err[0] / err[1], 2.0, 0.6);
  EXPECT_NEAR(err[1] / err[2], 2.0, 0.6);
  o.env_samples = 4;
  o.seed = 5;
  o.threads = 1;
  const RenderedView a = RenderViewEnvironment(tracer, shader, s, 0, env, o);
  o.threads = 2;
  EXPECT_EQ(a.color.pixels, RenderViewEnvironment(tracer, shader, s, 0, env, o).color.pixels);
}

TEST(RelightEnvironment, RejectsBadOptions) {
  RelightOptions o;
  o.env_samples = 0;
  EXPECT_THROW(o.Check(), Error);
  o = RelightOptions();
  o.envmap_scale = -1;
  EXPECT_THROW(o.Check(), Error);
}

}  // namespace
}  // namespace svbrdf
