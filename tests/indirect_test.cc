// Interreflection removal (lib/indirect) against closed forms: inside a
// closed Lambertian sphere lit from its centre every wall point receives the
// same indirect light, so the samples' albedo must come back to the truth;
// a convex sphere sees nothing of itself and its samples must not change.
#include <gtest/gtest.h>

#include <cmath>

#include "atlas/atlas.h"
#include "indirect/interreflection.h"
#include "brdf/model.h"
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

// The second pass (TraceIndirectWithMaterial) inside the closed sphere lit
// from its centre: the walls (Lambertian, rho) send the same radiance
// L_w = rho/pi E (1 + rho) (two bounces) from every direction, so a texel
// receives a(wo) L_w, with a(wo) its own BRDF's directional albedo. A small
// glossy patch gets its glossy albedo, not the walls' rho: the receiver's
// BRDF, frame, view direction and units all enter.
TEST(Interreflection, MaterialTraceGivesEachTexelItsOwnDirectionalAlbedo) {
  const double rho = 0.5, intensity = 3.0;
  const Mesh mesh = UnitSphere(/*inwards=*/true);
  const Scene s = CentreLit(Vec3::Zero(), intensity);
  GatherResult g = OneSamplePerTexel(mesh, s, [&](double geom) { return rho / kPi * geom; });
  ASSERT_GT(g.samples.size(), 500);
  Material m;
  m.mesh = g.mesh;
  m.width = g.atlas.width, m.height = g.atlas.height;
  BasisMaterial wall, glossy;
  wall.name = "wall", glossy.name = "glossy";
  wall.spec = ModelSpec::FromLabel("lambert");
  wall.params = {rho, rho, rho};
  glossy.spec = ModelSpec::FromLabel("cook_torrance-ggx-nofresnel");
  glossy.params = glossy.spec.InitialParams();
  const std::vector<ParamInfo> info = glossy.spec.Params();
  for (size_t i = 0; i < info.size(); ++i) {
    if (info[i].name.rfind("rd_", 0) == 0) glossy.params[i] = 0.1;
    if (info[i].name.rfind("rs_", 0) == 0) glossy.params[i] = 0.8;
    if (info[i].name == "roughness") glossy.params[i] = 0.2;
  }
  m.basis = {wall, glossy};
  m.weights = {Image(m.width, m.height, 3, 0.0f), Image(m.width, m.height, 3, 0.0f)};
  std::vector<char> patch(g.atlas.texels.size());
  for (size_t t = 0; t < g.atlas.texels.size(); ++t) {
    const Texel& tx = g.atlas.texels[t];
    patch[t] = tx.position.z() < -0.95;  // ~2.5 % of the wall: the walls' light stays uniform
    for (int c = 0; c < 3; ++c) m.weights[patch[t] ? 1 : 0].at(tx.x, tx.y, c) = 1.0f;
  }
  InterreflectionOptions o;
  o.progress = false;
  o.refit_paths = 64;
  const std::vector<Rgb> e = TraceIndirectWithMaterial(s, g, m, o);
  ASSERT_EQ(int64_t(e.size()), g.samples.size());
  // The glossy BRDF's directional albedo for a view at angle theta_o, by quadrature.
  auto albedo = [&](double cos_o) {
    const Vec3 wo(std::sqrt(std::max(0.0, 1 - cos_o * cos_o)), 0, cos_o);
    const int n_theta = 128, n_phi = 128;
    double sum = 0;
    for (int i = 0; i < n_theta; ++i)
      for (int j = 0; j < n_phi; ++j) {
        const double ct = (i + 0.5) / n_theta, st = std::sqrt(1 - ct * ct), phi = 2 * kPi * (j + 0.5) / n_phi;
        const Vec3 wi(st * std::cos(phi), st * std::sin(phi), ct);
        sum += EvalModelD(glossy.spec, glossy.params.data(), wi, wo)[1] * ct;  // d omega = d cos d phi
      }
    return sum * 2 * kPi / (n_theta * n_phi);
  };
  const Vec3 eye = s.images[0].cam_from_world.CentreInWorld();
  const double walls = rho / kPi * intensity * (1 + rho);
  double sum_patch = 0, sum_wall = 0, a_mean = 0;
  int n_patch = 0, n_wall = 0;
  for (int64_t i = 0; i < g.samples.size(); ++i) {
    const Texel& tx = g.atlas.texels[g.samples.texel[i]];
    if (patch[g.samples.texel[i]]) {
      const double a = albedo(tx.normal.dot((eye - tx.position).normalized()));
      sum_patch += e[i][1] / (a * walls), a_mean += a, ++n_patch;
    } else {
      sum_wall += e[i][1] / (rho * walls), ++n_wall;
    }
  }
  ASSERT_GT(n_patch, 10);
  a_mean /= n_patch;
  std::printf("indirect over the closed form: walls %.4f (%d texels), glossy patch %.4f (%d texels, albedo %.3f)\n",
              sum_wall / n_wall, n_wall, sum_patch / n_patch, n_patch, a_mean);
  EXPECT_NEAR(sum_wall / n_wall, 1.0, 0.05);
  EXPECT_NEAR(sum_patch / n_patch, 1.0, 0.07);
  EXPECT_GT(std::abs(a_mean - rho), 0.1);  // the patch's answer is not the walls' one
  // A convex sphere sees nothing of itself: nothing to trace.
  const Mesh out = UnitSphere(false);
  GatherResult gc = OneSamplePerTexel(out, CentreLit(Vec3(2, 3, 4), 10.0), [](double geom) { return 0.2 * geom; });
  Material mc = m;
  mc.mesh = gc.mesh;
  for (const Rgb& v : TraceIndirectWithMaterial(CentreLit(Vec3(2, 3, 4), 10.0), gc, mc, o)) EXPECT_EQ(v.sum(), 0.0);
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
