// Single-threaded ray throughput on a ~20k-triangle sphere: closest-hit and
// occlusion queries, reported as rays (items) per second.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "raytrace/raytracer.h"
#include "raytrace/sphere_mesh.h"

namespace svbrdf {
namespace {

// Rays from a box around the sphere towards random points near it: roughly
// the mix of hits and misses of camera and light rays.
struct Rays {
  std::vector<Vec3> origins, dirs;
  explicit Rays(int n) {
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> uni(-1, 1);
    for (int i = 0; i < n; ++i) {
      const Vec3 o = 3.0 * Vec3(uni(rng), uni(rng), uni(rng));
      origins.push_back(o);
      dirs.push_back((1.2 * Vec3(uni(rng), uni(rng), uni(rng)) - o).normalized());
    }
  }
};

const Mesh& Sphere() {
  static const Mesh mesh = MakeUvSphere(101, 100);  // 20000 triangles
  return mesh;
}

void BM_ClosestHit(benchmark::State& state) {
  const RayTracer rt(Sphere());
  const Rays rays(4096);
  size_t i = 0;
  Hit hit;
  for (auto _ : state) {
    benchmark::DoNotOptimize(rt.Intersect(rays.origins[i], rays.dirs[i], &hit));
    i = (i + 1) % rays.origins.size();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ClosestHit);

void BM_Occluded(benchmark::State& state) {
  const RayTracer rt(Sphere());
  const Rays rays(4096);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(rt.Occluded(rays.origins[i], rays.dirs[i], 0, 10));
    i = (i + 1) % rays.origins.size();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Occluded);

}  // namespace
}  // namespace svbrdf

BENCHMARK_MAIN();
