// Interreflection removal (lib/indirect) against closed forms: inside a
// closed Lambertian sphere lit from its centre every wall point receives the
// same indirect light, so the samples' albedo must come back to the truth;
// a convex sphere sees nothing of itself and its samples must not change.
#include <gtest/gtest.h>

#include <cmath>

#include "atlas/atlas.h"
#include "indirect/interreflection.h"
#include "core/error.h"
#include "raytrace/sphere_mesh.h"

namespace svbrdf {
namespace {

Mesh UnitSphere(bool inwards) {
  Mesh m = MakeUvSphere(16, 32);
  if (inwards)
    for (Vec3i& f : m.faces) std::swap(f[1], f[2]);
  m.ComputeNormals();
  return MakeTrivialAtlasUVs(m, 128);
}

Scene CentreLit(const Vec3& light_position, double intensity) {
  Scene s;
  Camera cam;
  cam.id = 1;
  cam.model = CameraModelId::kPinhole;
  cam.width = 64, cam.height = 48;
  cam.params = {40, 40, 32, 24};
  s.cameras = {cam};
  Light l;
  l.id = 1;
  l.type = LightType::kPoint;
  l.position = light_position;
  l.intensity = Rgb::Constant(intensity);
  s.lights = {l};
  ImageEntry e;
  e.file = "images/0.exr";
  e.camera = 1;
  e.light = 1;
  e.cam_from_world = Rigid3::LookAt(Vec3(0, 0, 0.3), Vec3(0, 0, -1), Vec3::UnitY());
  s.images = {e};
  return s;
}

// One sample per texel of image 0, lit by the scene's point light, with the
// value `radiance(geom)` (y in samples.h units: geom = cos / r^2 * I, y = L).
GatherResult OneSamplePerTexel(const Mesh& mesh, const Scene& s, const std::function<double(double)>& radiance) {
  GatherResult g;
  g.mesh = mesh;
  g.atlas = BuildAtlas(mesh, 128, 128);
  SampleSet& ss = g.samples;
  ss.num_texels = int(g.atlas.texels.size());
  ss.texel_begin.push_back(0);
  const Vec3 light = s.lights[0].position;
  const double intensity = s.lights[0].intensity[0];
  for (int t = 0; t < ss.num_texels; ++t) {
    const Texel& tx = g.atlas.texels[t];
    const Vec3 d = light - tx.position;
    const double cos_i = tx.normal.dot(d.normalized());
    if (cos_i > 0.05) {
      const float wi[3] = {0, 0, 1}, wo[3] = {0, 0, 1};
      const double geom = cos_i / d.squaredNorm() * intensity;
      const float y[3] = {float(radiance(geom)), float(radiance(geom)), float(radiance(geom))};
      ss.Push(t, 0, wi, wo, float(geom), y);
    }
    ss.texel_begin.push_back(ss.size());
  }
  return g;
}

TEST(Interreflection, ClosedSphereAlbedoRecovered) {
  const double rho = 0.5, intensity = 3.0;
  const Mesh mesh = UnitSphere(/*inwards=*/true);
  const Scene s = CentreLit(Vec3::Zero(), intensity);
  // Two bounces after the first hit, as the option: L = rho/pi E (1 + rho + rho^2).
  GatherResult g = OneSamplePerTexel(mesh, s, [&](double geom) { return rho / kPi * geom * (1 + rho + rho * rho); });
  ASSERT_GT(g.samples.size(), 500);
  InterreflectionOptions o;
  o.progress = false;
  o.paths = 32;
  const InterreflectionReport rep = RemoveInterreflection(s, &g, o);
  double sum = 0;
  for (int64_t i = 0; i < g.samples.size(); ++i) sum += kPi * g.samples.y[1][i] / g.samples.geom[i];
  const double albedo = sum / g.samples.size();
  std::printf("albedo after removal %.4f (truth %.2f, raw samples %.4f); %s\n", albedo, rho,
              rho * (1 + rho + rho * rho), rep.Summary().c_str());
  EXPECT_NEAR(albedo, rho, 0.05 * rho);
  // Share removed: (rho + rho^2) / (1 + rho + rho^2) = 3/7.
  EXPECT_NEAR(rep.removed_share, 3.0 / 7.0, 0.03);
}

TEST(Interreflection, ConvexSphereUnchanged) {
  const Mesh mesh = UnitSphere(/*inwards=*/false);
  const Scene s = CentreLit(Vec3(2, 3, 4), 10.0);
  GatherResult g = OneSamplePerTexel(mesh, s, [](double geom) { return 0.6 / kPi * geom; });
  ASSERT_GT(g.samples.size(), 100);
  const std::vector<float> before = g.samples.y[0];
  InterreflectionOptions o;
  o.progress = false;
  const InterreflectionReport rep = RemoveInterreflection(s, &g, o);
  EXPECT_EQ(rep.removed_share, 0.0);
  EXPECT_EQ(g.samples.y[0], before);
}

TEST(Interreflection, OffLeavesSamplesAndBadOptionsAreNamed) {
  const Mesh mesh = UnitSphere(true);
  const Scene s = CentreLit(Vec3::Zero(), 1.0);
  GatherResult g = OneSamplePerTexel(mesh, s, [](double geom) { return 0.3 * geom; });
  const std::vector<float> before = g.samples.y[2];
  InterreflectionOptions o;
  o.bounces = 0;
  EXPECT_EQ(RemoveInterreflection(s, &g, o).removed_share, 0.0);
  EXPECT_EQ(g.samples.y[2], before);
  o.bounces = 9;
  try {
    RemoveInterreflection(s, &g, o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--interreflection-bounces"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace svbrdf
