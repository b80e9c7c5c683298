// Full relight of one view of the small synthetic "default" scene (sphere,
// 3 basis materials, 320x240, mixed lights): ray casting, shading with the
// per-texel SVBRDF and shadow rays, pixel centres only. Reported as pixels
// (items) per second, with 1 and 2 worker threads.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <unistd.h>

#include "io/material.h"
#include "io/scene.h"
#include "raytrace/raytracer.h"
#include "relight/relight.h"
#include "relight/shader.h"
#include "synth/capture.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

// Synthesised once per process into a temporary folder, removed at exit.
struct Fixture {
  std::string dir;
  Material material;
  Scene scene;
  std::unique_ptr<RayTracer> tracer;
  std::unique_ptr<MaterialShader> shader;

  Fixture() {
    dir = (fs::temp_directory_path() / ("svbrdf_relight_bench_" + std::to_string(getpid()))).string();
    fs::remove_all(dir);
    SynthOptions o = SynthPreset("default");
    o.num_images = 2;
    Synthesize(o, dir);
    material = LoadMaterial(dir + "/gt");
    scene = LoadScene(dir + "/scene.json");
    tracer = std::make_unique<RayTracer>(material.mesh);
    shader = std::make_unique<MaterialShader>(material);
  }
  ~Fixture() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

Fixture& Get() {
  static Fixture f;
  return f;
}

void BM_RenderView(benchmark::State& state) {
  Fixture& f = Get();
  RelightOptions ro;
  ro.progress = false;
  ro.threads = static_cast<int>(state.range(0));
  const Camera& cam = f.scene.CameraById(f.scene.images[0].camera);
  const int64_t pixels = int64_t(cam.width) * cam.height;
  for (auto _ : state) {
    RenderedView v = RenderView(*f.tracer, *f.shader, f.scene, 0, ro);
    benchmark::DoNotOptimize(v.color.pixels.data());
  }
  state.SetItemsProcessed(state.iterations() * pixels);
  state.counters["pixels"] = static_cast<double>(pixels);
}
BENCHMARK(BM_RenderView)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace svbrdf

BENCHMARK_MAIN();
