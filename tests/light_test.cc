#include "light/light.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "core/rng.h"
#include "light/envmap.h"

namespace svbrdf {
namespace {

const Eigen::Quaterniond kIdentity = Eigen::Quaterniond::Identity();

LightSample Sample(const Light& l, const Vec3& x) { return SampleLight(l, x, kIdentity, Vec3::Zero()); }

TEST(Light, PointInverseSquare) {
  Light l;
  l.type = LightType::kPoint;
  l.position = Vec3(0, 2, 0);
  l.intensity = Rgb(8, 4, 16);
  const LightSample s = Sample(l, Vec3::Zero());
  EXPECT_NEAR(s.distance, 2.0, 1e-15);
  EXPECT_TRUE(s.wi.isApprox(Vec3::UnitY()));
  EXPECT_NEAR(s.normal_irradiance[0], 2.0, 1e-15);
  EXPECT_NEAR(s.normal_irradiance[1], 1.0, 1e-15);
  EXPECT_NEAR(s.normal_irradiance[2], 4.0, 1e-15);
}

TEST(Light, Directional) {
  Light l;
  l.type = LightType::kDirectional;
  l.to_light = Vec3(0, 0, 2);  // need not be unit in memory
  l.irradiance = Rgb(3, 3, 3);
  const LightSample s = Sample(l, Vec3(5, 6, 7));
  EXPECT_TRUE(std::isinf(s.distance));
  EXPECT_TRUE(s.wi.isApprox(Vec3::UnitZ()));
  EXPECT_DOUBLE_EQ(s.normal_irradiance[0], 3.0);
}

TEST(Light, SpotInsideOutsideCutoffAndCosPower) {
  Light l;
  l.type = LightType::kSpot;
  l.position = Vec3(0, 2, 0);
  l.direction = Vec3(0, -1, 0);
  l.intensity = Rgb(5, 5, 5);
  l.exponent = 20;
  l.cutoff_deg = 40;
  // On the axis: I0 / r^2.
  EXPECT_NEAR(Sample(l, Vec3::Zero()).normal_irradiance[0], 5.0 / 4.0, 1e-14);
  // 30 degrees off the axis at distance 2/cos(30): I0 cos^20(30) / r^2.
  const double a = 30 * kPi / 180;
  const Vec3 x(2 * std::tan(a), 0, 0);
  const double r2 = 4.0 / (std::cos(a) * std::cos(a));
  EXPECT_NEAR(Sample(l, x).normal_irradiance[0], 5.0 * std::pow(std::cos(a), 20) / r2, 1e-14);
  // 45 degrees: outside the 40 degree cutoff.
  EXPECT_EQ(Sample(l, Vec3(2, 0, 0)).normal_irradiance[0], 0.0);
}

TEST(Light, FlashInCameraFrameFollowsTheCamera) {
  Light l;
  l.type = LightType::kPoint;
  l.camera_frame = true;
  l.position = Vec3(0.05, 0, 0);
  l.intensity = Rgb(1, 1, 1);
  const Eigen::Quaterniond world_from_cam(Eigen::AngleAxisd(kPi / 2, Vec3::UnitY()));
  const Vec3 centre(1, 2, 3);
  const Vec3 light_world = centre + world_from_cam * l.position;  // (1, 2, 2.95)
  EXPECT_TRUE(light_world.isApprox(Vec3(1, 2, 2.95), 1e-12));
  const Vec3 x(1, 2, 0.95);  // 2 m from the flash
  const LightSample s = SampleLight(l, x, world_from_cam, centre);
  EXPECT_NEAR(s.distance, 2.0, 1e-12);
  EXPECT_TRUE(s.wi.isApprox(Vec3::UnitZ(), 1e-12));
  EXPECT_NEAR(s.normal_irradiance[0], 0.25, 1e-12);
}

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / (std::to_string(getpid()) + "_" + name)).string();
}

// Two horizontal planes (0 and 90, mirrored into all quadrants), three vertical angles.
const char* kIes =
    "IESNA:LM-63-2002\n[TEST] tiny\n[MANUFAC] none\nTILT=NONE\n"
    "1 -1 2.0 3 2 1 2 0 0 0\n"
    "1.0 1.0 10\n"
    "0 45 90\n"
    "0 90\n"
    "100 50 0\n"
    "200 100 0\n";

TEST(Ies, ParsesAndInterpolates) {
  const IesProfile p = ParseIes(kIes, "tiny.ies");
  ASSERT_EQ(p.vertical_deg.size(), 3u);
  ASSERT_EQ(p.horizontal_deg.size(), 2u);
  EXPECT_DOUBLE_EQ(p.multiplier, 2.0);
  EXPECT_DOUBLE_EQ(p.MaxCandela(), 400.0);
  const double d = kPi / 180;
  EXPECT_DOUBLE_EQ(p.Intensity(0, 0), 200.0);
  EXPECT_DOUBLE_EQ(p.Intensity(45 * d, 90 * d), 200.0);
  EXPECT_NEAR(p.Intensity(22.5 * d, 45 * d), 0.5 * (150 + 300), 1e-9);
  // Quadrant symmetry: 180 mirrors 0, 270 mirrors 90, 315 mirrors 45.
  EXPECT_NEAR(p.Intensity(0, 180 * d), 200.0, 1e-9);
  EXPECT_NEAR(p.Intensity(45 * d, 270 * d), 200.0, 1e-9);
  EXPECT_NEAR(p.Intensity(22.5 * d, 315 * d), 225.0, 1e-9);
  // Beyond the last vertical angle: no light.
  EXPECT_EQ(p.Intensity(120 * d, 0), 0.0);
}

TEST(Ies, SingleHorizontalAngleIsRotationallySymmetric) {
  const IesProfile p = ParseIes("IESNA:LM-63-1995\nTILT=NONE\n1 1000 1 2 1 1 2 0 0 0\n1 1 5\n0 90\n0\n10 20\n", "x");
  EXPECT_DOUBLE_EQ(p.Intensity(kPi / 4, 0), 15.0);
  EXPECT_DOUBLE_EQ(p.Intensity(kPi / 4, 2.0), 15.0);
}

TEST(Light, GoniometricFromIesFile) {
  const std::string path = TempPath("lamp.ies");
  std::ofstream(path) << kIes;
  Light l;
  l.type = LightType::kGoniometric;
  l.position = Vec3(0, 2, 0);
  l.direction = Vec3(0, -1, 0);
  l.up = Vec3(0, 0, 1);
  l.scale = 0.5;
  l.profile = std::make_shared<IesProfile>(LoadIes(path));
  std::filesystem::remove(path);
  // Straight down: vertical 0 -> 200 cd, * 0.5 / 4.
  EXPECT_NEAR(Sample(l, Vec3::Zero()).normal_irradiance[0], 25.0, 1e-12);
  // 45 degrees towards +z (= up, horizontal 0): 100 cd at r^2 = 8.
  EXPECT_NEAR(Sample(l, Vec3(0, 0, 2)).normal_irradiance[1], 100 * 0.5 / 8, 1e-12);
  // 45 degrees towards +x: horizontal 90 (axis x up = (0,-1,0)x(0,0,1) = (-1,0,0) is 90; +x is 270,
  // mirrored to 90): 200 cd.
  EXPECT_NEAR(Sample(l, Vec3(2, 0, 0)).normal_irradiance[2], 200 * 0.5 / 8, 1e-12);
}

void ExpectIesError(const std::string& text, const std::string& needle) {
  try {
    ParseIes(text, "bad.ies");
    FAIL() << "no error for " << needle;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bad.ies"), std::string::npos) << what;
    EXPECT_NE(what.find(needle), std::string::npos) << what;
  }
}

TEST(Ies, BrokenFilesAreClearErrors) {
  ExpectIesError("IESNA:LM-63-2002\n1 2 3\n", "TILT");
  ExpectIesError("IESNA:LM-63-2002\nTILT=INCLUDE\n1\n", "TILT=INCLUDE");
  ExpectIesError("IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 2 1 2 0 0 0\n1 1 10\n0 45 90\n0 90\n100 50\n", "truncated");
  ExpectIesError("IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 x 1 2 0 0 0\n", "number of horizontal angles");
  ExpectIesError("IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 10\n0 90\n0\n1 2 3\n", "extra");
  ExpectIesError("IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 10\n90 0\n0\n1 2\n", "ascending");
  try {
    LoadIes("/nonexistent/lamp.ies");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/lamp.ies"), std::string::npos);
  }
}

// A small environment with smooth variation and one bright texel.
EnvironmentMap TestEnvironment() {
  const int w = 16, h = 8;
  std::vector<float> rgb(size_t(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) rgb[(size_t(y) * w + x) * 3 + c] = float(0.2 + 0.1 * c + 0.5 * std::sin(0.7 * x + y) * std::sin(0.7 * x + y));
  for (int c = 0; c < 3; ++c) rgb[(size_t(2) * w + 5) * 3 + c] = 40.0f;
  return EnvironmentMap(w, h, rgb, "test");
}

TEST(EnvironmentMap, UvAndDirectionsRoundTrip) {
  for (double u : {0.05, 0.3, 0.77})
    for (double v : {0.1, 0.5, 0.93}) {
      const Vec2 uv = EnvironmentMap::DirectionToUv(EnvironmentMap::UvToDirection(Vec2(u, v)));
      EXPECT_NEAR(uv.x(), u, 1e-12);
      EXPECT_NEAR(uv.y(), v, 1e-12);
    }
  // +y is up (v = 0), Mitsuba's convention.
  EXPECT_NEAR(EnvironmentMap::DirectionToUv(Vec3::UnitY()).y(), 0.0, 1e-12);
}

TEST(EnvironmentMap, SampledPdfMatchesPdfAndIntegratesToOne) {
  const EnvironmentMap env = TestEnvironment();
  Rng rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 1000; ++i) {
    double pdf = 0;
    const Vec3 d = env.Sample(u(rng), u(rng), &pdf);
    EXPECT_NEAR(d.norm(), 1.0, 1e-12);
    EXPECT_NEAR(pdf, env.Pdf(d), 1e-9 * pdf);
  }
  double integral = 0;
  const int n = 800;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < 2 * n; ++j) {
      const double th = kPi * (i + 0.5) / n, ph = kPi * (j + 0.5) / n;
      integral += env.Pdf(Vec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph))) * std::sin(th) *
                  (kPi / n) * (kPi / n);
    }
  EXPECT_NEAR(integral, 1.0, 2e-3);
}

TEST(EnvironmentMap, SampleHistogramPassesChiSquare) {
  const EnvironmentMap env = TestEnvironment();
  const int m = 200000;
  std::vector<double> count(size_t(env.width()) * env.height(), 0.0);
  Rng rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < m; ++i) {
    double pdf;
    const Vec2 uv = EnvironmentMap::DirectionToUv(env.Sample(u(rng), u(rng), &pdf));
    const int x = std::min(int(uv.x() * env.width()), env.width() - 1), y = std::min(int(uv.y() * env.height()), env.height() - 1);
    count[size_t(y) * env.width() + x] += 1;
  }
  double chi2 = 0;
  int bins = 0;
  for (int y = 0; y < env.height(); ++y)
    for (int x = 0; x < env.width(); ++x) {
      const double expected = env.TexelProbability(x, y) * m;
      if (expected < 5) continue;
      chi2 += (count[size_t(y) * env.width() + x] - expected) * (count[size_t(y) * env.width() + x] - expected) / expected;
      ++bins;
    }
  // 127 degrees of freedom: the 0.1 % critical value is ~181.
  EXPECT_GT(bins, 100);
  EXPECT_LT(chi2, 181.0) << bins << " bins";
}

TEST(EnvironmentMap, BadMapsAreClearErrors) {
  std::vector<float> rgb(4 * 2 * 3, 1.0f);
  rgb[5] = std::nanf("");
  EXPECT_THROW(EnvironmentMap(4, 2, rgb, "x.exr"), Error);
  EXPECT_THROW(EnvironmentMap(4, 2, std::vector<float>(24, 0.0f), "x.exr"), Error);
  EXPECT_THROW(EnvironmentMap(4, 2, std::vector<float>(23, 1.0f), "x.exr"), Error);
  std::vector<float> ringing(24, 1.0f);
  ringing[3] = -1e-3f;
  const EnvironmentMap env(4, 2, ringing, "x.exr");
  EXPECT_EQ(env.clamped_negative(), 1);
  EXPECT_EQ(env.Radiance(EnvironmentMap::UvToDirection(Vec2(0.375, 0.25)))[0], 0.0);
  try {
    EnvironmentMap(4, 2, rgb, "sky.exr");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sky.exr"), std::string::npos);
  }
}

}  // namespace
}  // namespace svbrdf
