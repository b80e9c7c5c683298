// RayTracer against analytic geometry built in code (no file I/O).
#include "raytrace/raytracer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "core/parallel.h"
#include "raytrace/sphere_mesh.h"

namespace svbrdf {
namespace {

// Square [-1,1]^2 at height z facing +z, UVs (x+1)/2, (y+1)/2.
Mesh Quad(double z = 0) {
  Mesh m;
  m.positions = {Vec3(-1, -1, z), Vec3(1, -1, z), Vec3(1, 1, z), Vec3(-1, 1, z)};
  m.faces = {Vec3i(0, 1, 2), Vec3i(0, 2, 3)};
  m.texcoords = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
  m.face_uvs = m.faces;
  return m;
}

TEST(RayTracer, PlaneHitIsExact) {
  const Mesh quad = Quad(0.25);
  RayTracer rt(quad);
  Hit hit;
  ASSERT_TRUE(rt.Intersect(Vec3(0.3, -0.2, 2.0), Vec3(0, 0, -3), &hit));  // dir not unit
  EXPECT_NEAR(hit.t, 1.75, 1e-12);
  EXPECT_NEAR((rt.Position(hit) - Vec3(0.3, -0.2, 0.25)).norm(), 0, 1e-12);
  EXPECT_NEAR((hit.geometric_normal - Vec3(0, 0, 1)).norm(), 0, 1e-12);
  EXPECT_NEAR((rt.ShadingNormal(hit) - Vec3(0, 0, 1)).norm(), 0, 1e-12);  // no normals: geometric
}

TEST(RayTracer, SphereHitMatchesAnalyticDistance) {
  const Mesh sphere = MakeUvSphere(256, 512);
  RayTracer rt(sphere);
  std::mt19937 rng(1);
  std::normal_distribution<double> gauss;
  for (int i = 0; i < 200; ++i) {
    const Vec3 d = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized();
    const Vec3 origin = -3.0 * d + 0.2 * Vec3(gauss(rng), gauss(rng), gauss(rng)).cross(d);
    // Analytic: |o + t d| = 1.
    const double b = origin.dot(d), c = origin.squaredNorm() - 1;
    const double t_exact = -b - std::sqrt(b * b - c);
    Hit hit;
    ASSERT_TRUE(rt.Intersect(origin, d, &hit));
    EXPECT_NEAR(hit.t, t_exact, 1e-4 * t_exact);
    // Barycentrics reconstruct the point on the ray.
    EXPECT_NEAR((rt.Position(hit) - (origin + hit.t * d)).norm(), 0, 1e-9);
    EXPECT_GT(hit.geometric_normal.dot(-d), 0);  // outward winding faces the ray
    EXPECT_NEAR(hit.geometric_normal.norm(), 1, 1e-12);
    EXPECT_GT(rt.ShadingNormal(hit).dot(rt.Position(hit).normalized()), 0.9999);
  }
}

TEST(RayTracer, Miss) {
  const Mesh sphere = MakeUvSphere(16, 32);
  RayTracer rt(sphere);
  Hit hit;
  EXPECT_FALSE(rt.Intersect(Vec3(0, 0, 3), Vec3(0, 0, 1), &hit));   // pointing away
  EXPECT_FALSE(rt.Intersect(Vec3(2, 0, 3), Vec3(0, 0, -1), &hit));  // passes beside
}

TEST(RayTracer, TnearTfarRespected) {
  const Mesh quad = Quad(0);
  RayTracer rt(quad);
  Hit hit;
  EXPECT_FALSE(rt.Intersect(Vec3(0, 0, 1), Vec3(0, 0, -1), &hit, 0.0, 0.9));
  EXPECT_FALSE(rt.Intersect(Vec3(0, 0, 1), Vec3(0, 0, -1), &hit, 1.1, 10));
  EXPECT_TRUE(rt.Intersect(Vec3(0, 0, 1), Vec3(0, 0, -1), &hit, 0.9, 1.1));
  EXPECT_FALSE(rt.Occluded(Vec3(0, 0, 1), Vec3(0, 0, -1), 0.0, 0.9));
  EXPECT_TRUE(rt.Occluded(Vec3(0, 0, 1), Vec3(0, 0, -1), 0.9, 1.1));
}

TEST(RayTracer, NormalFollowsWindingNotRay) {
  const Mesh sphere = MakeUvSphere(64, 128);
  RayTracer rt(sphere);
  Hit hit;
  ASSERT_TRUE(rt.Intersect(Vec3::Zero(), Vec3(1, 1, 0), &hit));
  EXPECT_NEAR(hit.t, 1.0, 1e-3);
  // From inside, the outward-wound normal points along the ray, not at it.
  EXPECT_GT(hit.geometric_normal.dot(Vec3(1, 1, 0).normalized()), 0.99);
}

TEST(RayTracer, Occlusion) {
  const Mesh quad = Quad(0);  // blocker between z = +1 and z = -1
  RayTracer rt(quad);
  const Vec3 a(0.1, 0.2, 1), b(-0.1, 0.1, -1);
  EXPECT_TRUE(rt.Occluded(a, b - a, 1e-6, (b - a).norm() - 1e-6));
  // Segment beside the quad, and one that stops short of it.
  EXPECT_FALSE(rt.Occluded(Vec3(3, 0, 1), Vec3(0, 0, -1), 0, 2));
  EXPECT_FALSE(rt.Occluded(a, b - a, 1e-6, 0.4 * (b - a).norm()));
}

TEST(RayTracer, TexCoordInterpolation) {
  const Mesh quad = Quad(0);
  RayTracer rt(quad);
  for (const Vec2& xy : {Vec2(0.5, -0.25), Vec2(-0.9, 0.7), Vec2(0.3, 0.3)}) {
    Hit hit;
    ASSERT_TRUE(rt.Intersect(Vec3(xy.x(), xy.y(), 1), Vec3(0, 0, -1), &hit));
    const Vec2 uv = rt.TexCoord(hit);
    EXPECT_NEAR(uv.x(), (xy.x() + 1) / 2, 1e-12);
    EXPECT_NEAR(uv.y(), (xy.y() + 1) / 2, 1e-12);
  }
  Mesh no_uv = quad;
  no_uv.face_uvs.clear();
  RayTracer rt2(no_uv);
  Hit hit;
  ASSERT_TRUE(rt2.Intersect(Vec3(0.5, 0.5, 1), Vec3(0, 0, -1), &hit));
  EXPECT_EQ(rt2.TexCoord(hit), Vec2::Zero());
}

TEST(RayTracer, ParallelQueriesMatchSerial) {
  const Mesh sphere = MakeUvSphere(64, 128);
  RayTracer rt(sphere);
  const int n = 20000;
  std::vector<Vec3> origins(n), dirs(n);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1.5, 1.5);
  for (int i = 0; i < n; ++i) {
    origins[i] = Vec3(uni(rng), uni(rng), 3);
    dirs[i] = Vec3(uni(rng) * 0.2, uni(rng) * 0.2, -1);
  }
  auto run = [&](int threads, std::vector<Hit>& hits, std::vector<char>& occluded) {
    hits.assign(n, Hit());
    occluded.assign(n, 0);
    ParallelFor(n, threads, [&](long i) {
      rt.Intersect(origins[i], dirs[i], &hits[i]);
      occluded[i] = rt.Occluded(origins[i], dirs[i], 0, 10);
    }, 64);
  };
  std::vector<Hit> serial, parallel;
  std::vector<char> occ_serial, occ_parallel;
  run(1, serial, occ_serial);
  run(8, parallel, occ_parallel);
  for (int i = 0; i < n; ++i) {
    ASSERT_EQ(serial[i].prim, parallel[i].prim) << i;
    ASSERT_EQ(serial[i].t, parallel[i].t) << i;
    ASSERT_EQ(serial[i].b1, parallel[i].b1) << i;
    ASSERT_EQ(occ_serial[i], occ_parallel[i]) << i;
    ASSERT_EQ(bool(occ_serial[i]), serial[i].prim >= 0) << i;
  }
}

TEST(RayTracer, InvalidMeshThrows) {
  const Mesh empty;
  try {
    RayTracer rt(empty);
    FAIL() << "expected Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no faces"), std::string::npos) << e.what();
  }
  Mesh bad = Quad();
  bad.faces[1][2] = 7;  // out of range: must not reach Embree
  EXPECT_THROW(RayTracer rt(bad), Error);
}

}  // namespace
}  // namespace svbrdf
