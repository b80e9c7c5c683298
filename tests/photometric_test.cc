// Photometric captures: the ORTHOGRAPHIC camera, normal integration, the
// pixel mesh, the folder reader's errors, Lambertian normals and the
// dictionary fit on closed-form observations.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "brdf/fresnel.h"
#include "core/error.h"
#include "core/rng.h"
#include "io/scene.h"
#include "photometric/dictionary_fit.h"
#include "photometric/transfer.h"
#include "photometric/observations.h"
#include "photometric/pixel_mesh.h"
#include "photometric/ps_folder.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

Camera Ortho(int w, int h, double s) {
  Camera c;
  c.id = 1;
  c.model = CameraModelId::kOrthographic;
  c.width = w, c.height = h;
  c.params = {s, s, 0.5 * w, 0.5 * h};
  return c;
}

TEST(Orthographic, ProjectionIgnoresDepthAndRaysAreParallel) {
  const Camera cam = Ortho(64, 48, 500);
  EXPECT_EQ(CameraModelFromName("ORTHOGRAPHIC", "test"), CameraModelId::kOrthographic);
  const Vec2 a = cam.Project(Vec3(0.01, -0.02, 0.5)), b = cam.Project(Vec3(0.01, -0.02, 3.0));
  EXPECT_NEAR((a - b).norm(), 0.0, 1e-12);
  EXPECT_NEAR(a.x(), 500 * 0.01 + 32, 1e-12);
  Vec3 origin, dir;
  cam.PixelRay(Vec2(10.5, 7.25), &origin, &dir);
  EXPECT_NEAR((dir - Vec3(0, 0, 1)).norm(), 0.0, 1e-15);
  const Vec2 back = cam.Project(origin + 2.0 * dir);
  EXPECT_NEAR(back.x(), 10.5, 1e-9);
  EXPECT_NEAR(back.y(), 7.25, 1e-9);
  EXPECT_NEAR((cam.ToViewer(Vec3(0.3, 0.1, 2)) - Vec3(0, 0, -1)).norm(), 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(cam.MetresPerPixel(7.0), 1.0 / 500);
}

// A sphere cap z(x, y) seen from the camera: normals in, depth back.
TEST(Photometric, IntegrateNormalsRecoversASphere) {
  const int w = 41, h = 41;
  const double px = 0.001, radius = 0.018;
  Image normals(w, h, 3), region(w, h, 1);
  std::vector<double> truth(w * h, 0.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double X = (x + 0.5 - 20.5) * px, Y = (y + 0.5 - 20.5) * px;
      const double r2 = X * X + Y * Y;
      if (r2 > 0.8 * radius * radius) continue;
      const double Z = -std::sqrt(radius * radius - r2);  // towards the camera
      const Vec3 n = Vec3(X, Y, Z).normalized();
      for (int c = 0; c < 3; ++c) normals.at(x, y, c) = float(n[c]);
      region.at(x, y, 0) = 1.0f;
      truth[y * w + x] = Z;
    }
  const std::vector<double> depth = IntegrateNormals(normals, region, px);
  double mean_t = 0, mean_d = 0;
  int n = 0;
  for (int i = 0; i < w * h; ++i)
    if (region.pixels[i] > 0.5f) mean_t += truth[i], mean_d += depth[i], ++n;
  mean_t /= n, mean_d /= n;
  double worst = 0;
  for (int i = 0; i < w * h; ++i)
    if (region.pixels[i] > 0.5f) worst = std::max(worst, std::abs((depth[i] - mean_d) - (truth[i] - mean_t)));
  EXPECT_LT(worst, 0.05 * px * 20);  // a small share of the cap's 18 mm radius
  EXPECT_GT(std::abs(truth[20 * w + 20] - mean_t), 0.001);  // the test measures something: the cap is not flat
}

// A ball in front of a tilted wall: the wall's depth jumps at the ball's
// rim, which no normal shows. Poisson integration bends the wall towards the
// ball around it (the ramp that would cast false shadows); the bilateral
// refinement keeps the wall a plane to within half a pixel.
TEST(Photometric, IntegrateNormalsKeepsADepthJump) {
  const int w = 60, h = 60;
  const double px = 0.001, radius = 0.012, slope = 0.4;
  Image normals(w, h, 3), region(w, h, 1);
  std::vector<char> wall(w * h, 0);
  const Vec3 wall_normal = Vec3(slope, 0, -1).normalized();  // z = z0 + slope x: dz/dx = -nx/nz
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double X = (x + 0.5 - 30) * px, Y = (y + 0.5 - 30) * px;
      const double r2 = X * X + Y * Y;
      Vec3 n = wall_normal;
      if (r2 < 0.95 * radius * radius) n = Vec3(X, Y, -std::sqrt(radius * radius - r2)).normalized();
      else wall[y * w + x] = r2 > std::pow(radius + 3 * px, 2);
      for (int c = 0; c < 3; ++c) normals.at(x, y, c) = float(n[c]);
      region.at(x, y, 0) = 1.0f;
    }
  // How far the wall is from a plane of the true slope: spread of
  // depth - slope x over the wall pixels away from the rim.
  auto wall_bend = [&](const std::vector<double>& depth) {
    double lo = 1e9, hi = -1e9;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (wall[y * w + x]) {
          const double off = depth[y * w + x] - slope * x * px;
          lo = std::min(lo, off), hi = std::max(hi, off);
        }
    return hi - lo;
  };
  NormalIntegrationOptions poisson;
  poisson.bilateral_iterations = 0;
  const double bend_poisson = wall_bend(IntegrateNormals(normals, region, px, poisson));
  const double bend_bilateral = wall_bend(IntegrateNormals(normals, region, px));
  std::printf("wall bend: Poisson %.3f mm, bilateral %.3f mm\n", bend_poisson * 1e3, bend_bilateral * 1e3);
  EXPECT_GT(bend_poisson, 2 * px);      // the test measures something: Poisson does bend the wall
  EXPECT_LT(bend_bilateral, 0.1 * bend_poisson);
  EXPECT_LT(bend_bilateral, 0.5 * px);  // within half a pixel over a 60-pixel wall
}

TEST(Photometric, NormalIntegrationOptionsAreChecked) {
  NormalIntegrationOptions o;
  o.bilateral_k = 0;
  EXPECT_THROW(o.Check(), Error);
  o = {};
  o.bilateral_iterations = -1;
  EXPECT_THROW(o.Check(), Error);
  o = {};
  o.max_slope = -1;
  EXPECT_THROW(o.Check(), Error);
  EXPECT_NO_THROW(NormalIntegrationOptions{}.Check());
}

TEST(Photometric, OneLobeDiffuseIndicesAreChecked) {
  DictionaryFitOptions o;
  EXPECT_NO_THROW(o.Check());
  o.one_lobe_diffuse_etas = {};
  EXPECT_THROW(o.Check(), Error);
  o.one_lobe_diffuse_etas = {1.0, 0.8};
  EXPECT_THROW(o.Check(), Error);
  o.one_lobe_diffuse_etas = {std::nan("")};
  EXPECT_THROW(o.Check(), Error);
}

TEST(Photometric, PixelMeshHasOneQuadPerPixelMappedOntoItsTexel) {
  const Camera cam = Ortho(8, 6, 1000);
  Image region(8, 6, 1), normals(8, 6, 3);
  for (int y = 1; y < 5; ++y)
    for (int x = 2; x < 6; ++x) region.at(x, y, 0) = 1.0f, normals.at(x, y, 2) = -1.0f;
  Rigid3 pose;
  pose.translation = Vec3(0, 0, 1);
  const Mesh mesh = PixelGridMesh(cam, pose, region, std::vector<double>(48, 0.0), 1.0, normals);
  EXPECT_EQ(mesh.faces.size(), 2u * 16u);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    Vec3 centre = Vec3::Zero();
    Vec2 uv = Vec2::Zero();
    for (int k = 0; k < 3; ++k) centre += mesh.positions[mesh.faces[f][k]] / 3, uv += mesh.texcoords[mesh.face_uvs[f][k]] / 3;
    const Vec2 pixel = cam.Project(pose * centre);
    // The texel holding uv is the pixel the face lies in.
    EXPECT_EQ(int(std::floor(uv.x() * 8)), int(std::floor(pixel.x())));
    EXPECT_EQ(int(std::floor((1 - uv.y()) * 6)), int(std::floor(pixel.y())));
    EXPECT_NEAR((pose * centre).z(), 1.0, 1e-12);
  }
}

// Closed-form observations of one pixel family: Lambert albedo plus a
// Beckmann lobe from the dictionary, lights on a cone about the view.
// A hole in a sphere cap's normals (pixels the photos did not determine)
// filled by the membrane of its rim: close to the cap, much closer than
// facing the camera.
TEST(Photometric, FillNormalsSmoothlyBridgesAHole) {
  const int w = 41, h = 41;
  Image normals(w, h, 3), region(w, h, 1), known(w, h, 1);
  std::vector<Vec3> truth(w * h, Vec3::Zero());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double X = (x - 20) / 22.0, Y = (y - 20) / 22.0;
      if (X * X + Y * Y > 0.8) continue;
      truth[y * w + x] = Vec3(X, Y, -std::sqrt(1 - X * X - Y * Y));
      region.at(x, y, 0) = 1.0f;
      const bool hole = std::abs(x - 28) <= 3 && std::abs(y - 18) <= 4;
      const Vec3 n = hole ? Vec3(0, 0, -1) : truth[y * w + x];
      known.at(x, y, 0) = hole ? 0.0f : 1.0f;
      for (int c = 0; c < 3; ++c) normals.at(x, y, c) = float(n[c]);
    }
  auto hole_error = [&](const Image& n) {
    double worst = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (region.at(x, y, 0) > 0.5f && known.at(x, y, 0) < 0.5f)
          worst = std::max(worst, std::acos(std::min(1.0, Vec3(n.at(x, y, 0), n.at(x, y, 1), n.at(x, y, 2))
                                                              .normalized().dot(truth[y * w + x]))) * 180 / kPi);
    return worst;
  };
  const double before = hole_error(normals);
  ASSERT_TRUE(FillNormalsSmoothly(known, region, &normals));
  const double after = hole_error(normals);
  EXPECT_GT(before, 15.0);
  EXPECT_LT(after, 2.0);
  EXPECT_FALSE(FillNormalsSmoothly(Image(w, h, 1), region, &normals));  // nothing known
}

// diffuse_eta > 1: the diffuse is a body under a smooth interface of that
// index, (1 - F(cos_i)) (1 - F(cos_o)) times Lambert's.
PsObservations SyntheticObservations(const std::vector<Vec3>& normals, const std::vector<Rgb>& diffuse, double specular,
                                     const BasisMaterial& lobe, double diffuse_eta = 1.0) {
  PsObservations o;
  o.cam = Ortho(int(normals.size()), 1, 1000);
  o.width = int(normals.size()), o.height = 1;
  for (int i = 0; i < 40; ++i) {
    const double theta = (10 + 40 * (i % 5) / 4.0) * kPi / 180, phi = 2 * kPi * i / 40 + 0.3 * (i % 5);
    o.to_light.push_back(Vec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), -std::cos(theta)));
  }
  o.lights = int(o.to_light.size());
  o.region = Image(o.width, 1, 1, 1.0f);
  o.valid = o.region;
  for (int p = 0; p < o.width; ++p) {
    o.pixel.push_back(p);
    o.depth.push_back(1.0);
  }
  o.value.assign(size_t(o.width) * o.lights * 3, 0.0f);
  o.weight.assign(o.value.size(), 1.0f);
  for (int p = 0; p < o.width; ++p) {
    const Frame fr = Frame::FromNormal(normals[p]);
    for (int l = 0; l < o.lights; ++l) {
      const Vec3 wi = fr.ToLocal(o.to_light[l]), wo = fr.ToLocal(o.to_viewer);
      const double spec = wi.z() > 0 ? EvalModelD(lobe.spec, lobe.params.data(), wi, wo)[0] : 0.0;
      const double through = diffuse_eta > 1 && wi.z() > 0 ? (1 - brdf::FresnelDielectric(wi.z(), diffuse_eta)) *
                                                                  (1 - brdf::FresnelDielectric(wo.z(), diffuse_eta))
                                                            : 1.0;
      for (int c = 0; c < 3; ++c)
        o.value[o.At(p, l) + c] = float(std::max(0.0, wi.z()) * (diffuse[p][c] * through / kPi + specular * spec));
    }
  }
  return o;
}

// Light residuals (transfer.h FitResidualField): a residual that varies
// smoothly over the light directions (a lobe the basis lacks) carries to a
// left-out light, so the pixel's share is near 1 and the field is kept;
// residuals that are independent noise per photo carry nothing: share near
// 0, not kept. The stored maps are the residuals times the share.
TEST(Photometric, LightResidualsAreKeptWhereTheyCarryToNeighbouringLights) {
  const std::vector<Vec3> normals(8, Vec3(0, 0, -1));
  const std::vector<Rgb> albedo(8, Rgb(0.5, 0.4, 0.3));
  BasisMaterial lambert = DictionaryCandidates()[0];
  const std::vector<BasisMaterial> basis = {lambert};
  std::vector<Image> weights = {Image(8, 1, 3)};
  for (int p = 0; p < 8; ++p)
    for (int c = 0; c < 3; ++c) weights[0].at(p, 0, c) = float(albedo[p][c]);
  DictionaryFitOptions o;
  o.threads = 1;
  o.residual_window = 1;
  Image normals_cam(8, 1, 3);
  for (int p = 0; p < 8; ++p) normals_cam.at(p, 0, 2) = -1.0f;
  // Smooth: the photos hold a glossy lobe (the same pixels with a
  // Cook-Torrance term) that the Lambert-only basis cannot.
  const BasisMaterial lobe = DictionaryCandidates().back();
  PsObservations smooth = SyntheticObservations(normals, albedo, 0.2, lobe);
  const ResidualField kept = FitResidualField(smooth, basis, weights, {}, normals_cam, {}, o);
  EXPECT_TRUE(kept.kept);
  EXPECT_LT(kept.loo_error_with, 0.5 * kept.loo_error_without);
  EXPECT_GT(kept.share.at(3, 0, 0), 0.7f);
  ASSERT_EQ(kept.maps.size(), size_t(smooth.lights));
  ASSERT_EQ(kept.directions.size(), size_t(smooth.lights));
  const int l = 7, p = 3;
  const double lambertian = std::max(0.0, -smooth.to_light[l].z()) * albedo[p][1] / kPi;
  EXPECT_NEAR(kept.maps[l].at(p, 0, 1), kept.share.at(p, 0, 0) * (smooth.value[smooth.At(p, l) + 1] - lambertian),
              1e-5);
  // Noise: the Lambertian photos plus independent noise per photo.
  PsObservations noisy = SyntheticObservations(normals, albedo, 0.0, lobe);
  Rng rng(7);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (float& v : noisy.value) v += float(noise(rng));
  const ResidualField dropped = FitResidualField(noisy, basis, weights, {}, normals_cam, {}, o);
  EXPECT_FALSE(dropped.kept);
  EXPECT_TRUE(dropped.maps.empty());
  EXPECT_LT(dropped.share.at(3, 0, 0), 0.3f);
}

TEST(Photometric, LambertianNormalsAndDictionaryFitRecoverClosedFormPixels) {
  const std::vector<BasisMaterial> dict = DictionaryCandidates();
  ASSERT_EQ(dict[0].spec.Label(), "lambert");
  const BasisMaterial lobe = dict.back();  // the broadest GGX lobe
  std::vector<Vec3> normals;
  std::vector<Rgb> diffuse;
  for (int p = 0; p < 30; ++p) {
    normals.push_back(Vec3(0.3 * std::sin(p), 0.25 * std::cos(1.3 * p), -1).normalized());
    diffuse.push_back(Rgb(0.2 + 0.02 * p, 0.5, 0.8 - 0.02 * p));
  }
  // Lambert only: exact normals.
  const PsObservations lam = SyntheticObservations(normals, diffuse, 0.0, lobe);
  Image determined;
  const Image n0 = LambertianNormals(lam, {}, 1, &determined);
  for (int p = 0; p < 30; ++p) {
    EXPECT_LT(std::acos(std::min(1.0, Vec3(n0.at(p, 0, 0), n0.at(p, 0, 1), n0.at(p, 0, 2)).dot(normals[p]))), 1e-3);
    EXPECT_EQ(determined.at(p, 0, 0), 1.0f);
  }
  // A black pixel sends no light under any lamp: not determined.
  std::vector<Rgb> dark = diffuse;
  dark[7] = Rgb::Zero();
  LambertianNormals(SyntheticObservations(normals, dark, 0.0, lobe), {}, 1, &determined);
  EXPECT_EQ(determined.at(7, 0, 0), 0.0f);
  EXPECT_EQ(determined.at(8, 0, 0), 1.0f);
  // With the lobe: selection finds it, the weights come back.
  const PsObservations glossy = SyntheticObservations(normals, diffuse, 0.4, lobe);
  Image truth(30, 1, 3);
  for (int p = 0; p < 30; ++p)
    for (int c = 0; c < 3; ++c) truth.at(p, 0, c) = float(normals[p][c]);
  DictionaryFitOptions o;
  o.threads = 1;
  o.prior_rows = 0;
  o.selection_pixels = 50;
  const BasisSelection sel = SelectBasis(glossy, truth, {}, o);
  ASSERT_GE(sel.basis.size(), 2u);
  EXPECT_EQ(sel.basis[1].name, lobe.name);
  std::vector<Image> weights;
  Image confidence;
  SolveWeights(glossy, sel.basis, truth, {}, o, &weights, &confidence);
  for (int p = 0; p < 30; ++p) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(weights[0].at(p, 0, c), diffuse[p][c], 1e-3);
    EXPECT_NEAR(weights[1].at(p, 0, 1), 0.4, 1e-3);
  }
  // The normal search returns the true normals from a start 3 degrees off.
  Image start = truth;
  for (int p = 0; p < 30; ++p) {
    const Vec3 m = (normals[p] + Vec3(0.05, -0.02, 0)).normalized();
    for (int c = 0; c < 3; ++c) start.at(p, 0, c) = float(m[c]);
  }
  const Image refined = RefineNormals(glossy, sel.basis, start, {}, o);
  for (int p = 0; p < 30; ++p)
    EXPECT_LT(std::acos(std::min(1.0, Vec3(refined.at(p, 0, 0), refined.at(p, 0, 1), refined.at(p, 0, 2))
                                          .normalized()
                                          .dot(normals[p]))) * 180 / kPi,
              0.3);
}

// A wall beside every pixel: the lights with x >= 0.15 black out (their
// count in *hidden); returns which photos are in its cast shadow.
std::vector<uint8_t> HideLightsBehindWall(PsObservations* obs, int* hidden) {
  std::vector<uint8_t> shadowed(size_t(obs->P()) * obs->lights, 0);
  *hidden = 0;
  for (int l = 0; l < obs->lights; ++l) {
    if (obs->to_light[l].x() < 0.15) continue;
    ++*hidden;
    for (long p = 0; p < obs->P(); ++p) {
      shadowed[size_t(p) * obs->lights + l] = 1;
      for (int c = 0; c < 3; ++c) obs->value[obs->At(p, l) + c] = 0.0f;
    }
  }
  return shadowed;
}

// A wall beside the pixels hides the lights on one side, as in a concavity:
// more than the darkest quarter of the photos are black, so the
// interquartile fit keeps some and leans away from the wall. Told which
// photos are in cast shadow (what the pipeline's shadow rounds take from
// the start's height field), the fit is exact again.
TEST(Photometric, LambertianNormalsLeaveOutCastShadows) {
  const BasisMaterial lobe = DictionaryCandidates().back();
  std::vector<Vec3> normals;
  for (int p = 0; p < 20; ++p) normals.push_back(Vec3(0.2 * std::sin(p), 0.2 * std::cos(1.3 * p), -1).normalized());
  PsObservations obs = SyntheticObservations(normals, std::vector<Rgb>(20, Rgb(0.6, 0.5, 0.4)), 0.0, lobe);
  int hidden = 0;
  const std::vector<uint8_t> shadowed = HideLightsBehindWall(&obs, &hidden);
  ASSERT_GT(hidden, obs.lights * 3 / 10);
  ASSERT_LT(hidden, obs.lights / 2);
  auto mean_error = [&](const Image& n) {
    double sum = 0;
    for (int p = 0; p < 20; ++p)
      sum += std::acos(std::min(1.0, Vec3(n.at(p, 0, 0), n.at(p, 0, 1), n.at(p, 0, 2)).normalized().dot(normals[p])));
    return sum / 20 * 180 / kPi;
  };
  const double plain = mean_error(LambertianNormals(obs, {}, 1));
  const double aware = mean_error(LambertianNormals(obs, shadowed, 1));
  EXPECT_GT(plain, 2.0);
  EXPECT_LT(aware, 0.05);
}

// The dictionary BRDF called `name`.
BasisMaterial DictionaryLobe(const std::string& name) {
  for (const BasisMaterial& b : DictionaryCandidates())
    if (b.name == name) return b;
  ADD_FAILURE() << "no dictionary BRDF " << name;
  return DictionaryCandidates()[0];
}

// Camera-facing normals that wave over n pixels with amplitudes ax, ay.
std::vector<Vec3> WavyNormals(int n, double ax, double ay) {
  std::vector<Vec3> out;
  for (int p = 0; p < n; ++p) out.push_back(Vec3(ax * std::sin(p), ay * std::cos(1.3 * p), -1).normalized());
  return out;
}

// Degrees between pixel p of a 1-row normal image and `truth`.
double AngleDeg(const Image& n, int p, const Vec3& truth) {
  return std::acos(std::min(1.0, Vec3(n.at(p, 0, 0), n.at(p, 0, 1), n.at(p, 0, 2)).normalized().dot(truth))) * 180 / kPi;
}

// A glossy dielectric (diffuse plus a GGX lobe): its Lambertian start is
// biased; the one-lobe search picks a lobe of the dictionary for the object
// and brings the normals closer, each by at most 15 degrees; pixels outside
// `where` keep their start.
TEST(Photometric, OneLobeNormalsTakeOutTheLambertianBias) {
  const BasisMaterial lobe = DictionaryLobe("specular_ggx_m0.22");
  const std::vector<Vec3> normals = WavyNormals(40, 0.4, 0.35);
  const PsObservations obs = SyntheticObservations(normals, std::vector<Rgb>(40, Rgb(0.4, 0.4, 0.4)), 0.08, lobe);
  auto angle = [&](const Image& n, int p) { return AngleDeg(n, p, normals[p]); };
  const Image start = LambertianNormals(obs, {}, 1);
  DictionaryFitOptions o;
  o.threads = 1;
  Image where(40, 1, 1, 1.0f);
  where.at(5, 0, 0) = 0.0f;
  std::string chosen;
  const Image refined = RefineNormalsUnderOneLobe(obs, start, {}, o, where, &chosen);
  EXPECT_EQ(chosen, lobe.name);
  double before = 0, after = 0;
  for (int p = 0; p < 40; ++p) {
    if (p == 5) continue;
    before += angle(start, p) / 39, after += angle(refined, p) / 39;
    const Vec3 a(start.at(p, 0, 0), start.at(p, 0, 1), start.at(p, 0, 2)), b(refined.at(p, 0, 0), refined.at(p, 0, 1),
                                                                              refined.at(p, 0, 2));
    EXPECT_LE(std::acos(std::min(1.0, a.normalized().dot(b.normalized()))) * 180 / kPi, 15.0 + 1e-6) << "pixel " << p;
  }
  std::printf("one-lobe normals (%s): %.2f -> %.2f deg\n", chosen.c_str(), before, after);
  EXPECT_GT(before, 1.0);
  EXPECT_LT(after, 0.35 * before);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(refined.at(5, 0, c), start.at(5, 0, c));
}

// The glossy dielectric beside a wall the height field does not know of:
// more than a quarter of the lights are hidden, so a search that only
// drops each pixel's darkest quarter fits black photos and leans away from
// the wall. The photos the start's own fit says are in shadow are left out,
// and the one-lobe search takes out the Lambertian bias as without the wall.
TEST(Photometric, OneLobeNormalsLeaveOutShadowsTheHeightFieldMissed) {
  const BasisMaterial lobe = DictionaryLobe("specular_ggx_m0.22");
  const std::vector<Vec3> normals = WavyNormals(40, 0.4, 0.35);
  PsObservations obs = SyntheticObservations(normals, std::vector<Rgb>(40, Rgb(0.4, 0.4, 0.4)), 0.08, lobe);
  int hidden = 0;
  const std::vector<uint8_t> wall = HideLightsBehindWall(&obs, &hidden);
  ASSERT_GT(hidden, obs.lights * 3 / 10);
  // The start knows the wall (as after the shadow rounds); the search is
  // not told, as where the height field misses a shadow.
  const Image start = LambertianNormals(obs, wall, 1);
  DictionaryFitOptions o;
  o.threads = 1;
  std::string chosen;
  const Image refined = RefineNormalsUnderOneLobe(obs, start, {}, o, Image(40, 1, 1, 1.0f), &chosen);
  double before = 0, after = 0;
  for (int p = 0; p < 40; ++p) before += AngleDeg(start, p, normals[p]) / 40, after += AngleDeg(refined, p, normals[p]) / 40;
  std::printf("one-lobe normals beside a wall (%s): %.2f -> %.2f deg\n", chosen.c_str(), before, after);
  EXPECT_GT(before, 1.0);
  EXPECT_LT(after, 0.35 * before);
}

// A plastic: its diffuse enters and leaves through the surface, so it falls
// faster than the cosine towards grazing light (1 - F both ways). The search
// picks that diffuse over Lambert with the lobe, and ends closer to the
// truth than the search held to Lambert does.
TEST(Photometric, OneLobeNormalsSeeTheDiffuseThroughTheSurface) {
  const BasisMaterial lobe = DictionaryLobe("specular_ggx_m0.22");
  const std::vector<Vec3> normals = WavyNormals(40, 0.5, 0.45);
  const PsObservations obs = SyntheticObservations(normals, std::vector<Rgb>(40, Rgb(0.5, 0.5, 0.5)), 0.04, lobe, 2.0);
  const Image start = LambertianNormals(obs, {}, 1);
  DictionaryFitOptions o;
  o.threads = 1;
  const Image where(40, 1, 1, 1.0f);
  std::string chosen;
  const Image refined = RefineNormalsUnderOneLobe(obs, start, {}, o, where, &chosen);
  EXPECT_EQ(chosen, lobe.name + ", diffuse under an interface of index 2");
  // The same search with Lambert's diffuse only: a model that lacks the
  // falloff (the option that keeps Lambert: no Fresnel pairing allowed).
  DictionaryFitOptions lambert_only = o;
  lambert_only.one_lobe_diffuse_etas = {1.0};
  std::string chosen_lambert;
  const Image lambert = RefineNormalsUnderOneLobe(obs, start, {}, lambert_only, where, &chosen_lambert);
  double before = 0, with_lambert = 0, after = 0;
  for (int p = 0; p < 40; ++p) {
    before += AngleDeg(start, p, normals[p]) / 40;
    with_lambert += AngleDeg(lambert, p, normals[p]) / 40;
    after += AngleDeg(refined, p, normals[p]) / 40;
  }
  std::printf("diffuse through the surface: start %.3f deg, Lambert + %s %.3f deg, %s %.3f deg\n", before,
              chosen_lambert.c_str(), with_lambert, chosen.c_str(), after);
  EXPECT_LT(after, 0.7 * with_lambert);
  EXPECT_LT(after, 0.3 * before);
}

// A metal (a specular lobe, no diffuse): the Lambertian start is far off and
// says so through its misfit; the search under the basis, from the start
// and from the specular cue, finds the normals; pixels outside `search`
// keep their start.
TEST(Photometric, MetalNormalsAreSearchedWhereTheLambertianStartMisfits) {
  const std::vector<BasisMaterial> dict = DictionaryCandidates();
  const BasisMaterial lobe = DictionaryLobe("specular_ggx_m0.14");
  const std::vector<Vec3> normals = WavyNormals(20, 0.25, 0.2);
  auto angle = [&](const Image& n, int p) { return AngleDeg(n, p, normals[p]); };
  Image misfit;
  LambertianNormals(SyntheticObservations(normals, std::vector<Rgb>(20, Rgb(0.5, 0.5, 0.5)), 0.0, lobe), {}, 1, nullptr,
                    &misfit);
  for (int p = 0; p < 20; ++p) EXPECT_LT(misfit.at(p, 0, 0), 0.01) << "a Lambertian pixel fits";
  const PsObservations metal = SyntheticObservations(normals, std::vector<Rgb>(20, Rgb::Zero()), 1.0, lobe);
  const Image start = LambertianNormals(metal, {}, 1, nullptr, &misfit);
  double start_error = 0;
  for (int p = 0; p < 20; ++p) {
    EXPECT_GT(misfit.at(p, 0, 0), 0.15) << "pixel " << p;
    start_error += angle(start, p) / 20;
  }
  EXPECT_GT(start_error, 3.0);
  DictionaryFitOptions o;
  o.threads = 1;
  const std::vector<BasisMaterial> basis = {dict[0], lobe};
  const Image refined = RefineNormals(metal, basis, start, {}, o);
  for (int p = 0; p < 20; ++p) EXPECT_LT(angle(refined, p), 0.5) << "pixel " << p;
  Image search(20, 1, 1);
  search.at(3, 0, 0) = 1.0f;
  const Image masked = RefineNormals(metal, basis, start, {}, o, &search);
  EXPECT_LT(angle(masked, 3), 0.5);
  EXPECT_EQ(masked.at(4, 0, 0), start.at(4, 0, 0));
  EXPECT_EQ(masked.at(4, 0, 1), start.at(4, 0, 1));
}

// The window median: an isolated outlier is gone, a region of them stays.
TEST(Photometric, RegionMedianKeepsRegionsAndDropsIsolatedPixels) {
  Image v(9, 9, 1), region(9, 9, 1, 1.0f);
  v.at(2, 2, 0) = 1.0f;
  for (int y = 5; y < 9; ++y)
    for (int x = 5; x < 9; ++x) v.at(x, y, 0) = 1.0f;
  region.at(0, 0, 0) = 0.0f;
  v.at(0, 0, 0) = 5.0f;  // outside the region: never counted
  const Image m = RegionMedian(v, region, 1);
  EXPECT_EQ(m.at(2, 2, 0), 0.0f);
  EXPECT_EQ(m.at(7, 7, 0), 1.0f);
  EXPECT_EQ(m.at(0, 0, 0), 0.0f);
  EXPECT_EQ(m.at(1, 1, 0), 0.0f);
}

// A scratch copy of the test crop, for breaking one file at a time.
std::string CropCopy(const std::string& name) {
  const fs::path src = fs::path(SVBRDF_SOURCE_DIR) / "tests/data/diligent_cat_crop";
  const fs::path dst = fs::temp_directory_path() / ("svbrdf_ps_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dst);
  fs::copy(src, dst, fs::copy_options::recursive);
  return dst.string();
}

void ExpectImportError(const std::string& dir, const std::string& file_in_message) {
  ImportPsOptions o;
  o.in_dir = dir;
  o.out_dir = dir + "_cap";
  o.progress = false;
  try {
    ImportPs(o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(file_in_message), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(o.out_dir)) << "half-written capture left behind";
  fs::remove_all(dir);
}

TEST(ImportPs, BadFoldersFailNamingTheFile) {
  {
    const std::string d = CropCopy("nolights");
    fs::remove(d + "/light_directions.txt");
    ExpectImportError(d, "light_directions.txt");
  }
  {
    const std::string d = CropCopy("rows");
    std::ofstream(d + "/light_intensities.txt") << "1 1 1\n1 1 1\n";
    ExpectImportError(d, "light_intensities.txt: 2 rows for 96 photos");
  }
  {
    const std::string d = CropCopy("nonunit");
    std::ifstream in(d + "/light_directions.txt");
    std::string all((std::istreambuf_iterator<char>(in)), {}), rest = all.substr(all.find('\n'));
    std::ofstream(d + "/light_directions.txt") << "0.5 0.5 0.5" << rest;
    ExpectImportError(d, "light_directions.txt: row 1");
  }
  {
    const std::string d = CropCopy("masksize");
    WriteImage(d + "/mask.png", Image(7, 5, 1, 1.0f), PixelFormat::kUInt8);
    ExpectImportError(d, "but mask.png is 7x5");
  }
}

TEST(ImportPs, WritesTrainingAndHeldOutScenesWithUnknownNormals) {
  ImportPsOptions o;
  o.in_dir = std::string(SVBRDF_SOURCE_DIR) + "/tests/data/diligent_cat_crop";
  o.out_dir = (fs::temp_directory_path() / ("svbrdf_ps_import_" + std::to_string(getpid()))).string();
  o.progress = false;
  const ImportPsResult r = ImportPs(o);
  EXPECT_EQ(r.training, 80);
  EXPECT_EQ(r.held_out, 16);
  const Scene train = LoadScene(o.out_dir + "/scene.json"), held = LoadScene(o.out_dir + "/heldout/scene.json");
  EXPECT_FALSE(train.mesh_normals_known);
  EXPECT_TRUE(IsPhotometricCapture(train));
  EXPECT_EQ(held.images.front().light, 6);
  EXPECT_EQ(held.LightById(6).type, LightType::kDirectional);
  // DiLiGenT's y up, z towards the camera become the COLMAP frame's y down, z forward.
  std::ifstream dirs(o.in_dir + "/light_directions.txt");
  Vec3 first;
  dirs >> first.x() >> first.y() >> first.z();
  EXPECT_NEAR((train.LightById(1).to_light - FlipYZ(first.normalized())).norm(), 0.0, 1e-9);
  fs::remove_all(o.out_dir);
}

TEST(ImportPs, FlooredEightBitCountsAreStoredAtTheMiddleOfTheirStep) {
  ImportPsOptions o;
  o.in_dir = CropCopy("floor");
  o.out_dir = o.in_dir + "_cap";
  o.progress = false;
  {  // a saturated and a black pixel in the first photo
    Image first = ReadImage(o.in_dir + "/001.png");
    for (int c = 0; c < first.channels; ++c) first.at(0, 0, c) = 1.0f, first.at(1, 0, c) = 0.0f;
    WriteImage(o.in_dir + "/001.png", first, PixelFormat::kUInt8);
  }
  EXPECT_EQ(o.quantization, "floor");  // DiLiGenT's 8-bit copies are floored
  EXPECT_EQ(ImportPs(o).dequantized, 96);
  long mid = 0, zero = 0, saturated = 0;
  for (const std::string photo : {"001", "006"}) {  // a training and a held-out photo
    const Image src = ReadImage(o.in_dir + "/" + photo + ".png");
    const Image got = ReadImage(o.out_dir + (photo == "006" ? "/heldout" : "") + "/images/" + photo + ".png");
    ASSERT_EQ(src.bits, 8);
    ASSERT_EQ(got.bits, 16);
    ASSERT_EQ(got.pixels.size(), src.pixels.size());
    for (size_t i = 0; i < src.pixels.size(); ++i) {
      const long k = std::lround(src.pixels[i] * 255.0);
      if (k == 0) {
        EXPECT_EQ(got.pixels[i], 0.0f);
        ++zero;
      } else if (k == 255) {
        EXPECT_GE(got.pixels[i], got.saturation_level);
        ++saturated;
      } else {
        EXPECT_NEAR(got.pixels[i], (k + 0.5) / 255.0, 0.6 / 65535);
        ++mid;
      }
    }
  }
  EXPECT_GT(mid, 1000);
  EXPECT_GT(zero, 0);
  EXPECT_GT(saturated, 0);
  fs::remove_all(o.out_dir);
  // Rounded counts are the values themselves: the photos are copied.
  o.quantization = "round";
  EXPECT_EQ(ImportPs(o).dequantized, 0);
  const Image copied = ReadImage(o.out_dir + "/images/001.png");
  EXPECT_EQ(copied.bits, 8);
  EXPECT_EQ(copied.pixels, ReadImage(o.in_dir + "/001.png").pixels);
  fs::remove_all(o.out_dir);
  fs::remove_all(o.in_dir);
  o.quantization = "nearest";
  try {
    o.Check();
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--quantization must be floor or round"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace svbrdf
