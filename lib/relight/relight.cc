#include "relight/relight.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <random>

#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "core/rng.h"
#include "relight/light_paths.h"

namespace svbrdf {

namespace fs = std::filesystem;

RelightOptions RelightOptions::PixelIntegrating() {
  RelightOptions o;
  o.samples_per_pixel = 8;
  o.adaptive_max_rounds = 16;
  return o;
}

std::string RelightOptions::SamplingDescription() const {
  if (samples_per_pixel <= 1) return "pixel centre";
  if (adaptive_max_rounds > 0)
    return Msg("pixel-integrating: ", samples_per_pixel, " x ", samples_per_pixel, " jittered samples per round, up to ",
               adaptive_max_rounds, " rounds until the sRGB standard error is below ", adaptive_tolerance);
  return Msg("pixel-integrating: ", samples_per_pixel, " x ", samples_per_pixel, " jittered samples");
}

void RelightOptions::Check() const {
  if (samples_per_pixel < 1 || samples_per_pixel > 16)
    throw Error(Msg("relight: --spp must be in [1, 16], got ", samples_per_pixel));
  if (adaptive_max_rounds < 0 || adaptive_max_rounds > 256)
    throw Error(Msg("relight: --adaptive-rounds must be in [0, 256], got ", adaptive_max_rounds));
  if (adaptive_max_rounds > 0 && samples_per_pixel < 2)
    throw Error("relight: --adaptive-rounds needs --spp 2 or more (rounds of n x n stratified samples)");
  if (!(adaptive_tolerance > 0) || !std::isfinite(adaptive_tolerance))
    throw Error(Msg("relight: --adaptive-tolerance must be a finite number > 0, got ", adaptive_tolerance));
  if (env_samples < 1 || env_samples > 1 << 20)
    throw Error(Msg("relight: --samples must be in [1, 1048576], got ", env_samples));
  if (!(envmap_scale > 0) || !std::isfinite(envmap_scale))
    throw Error(Msg("relight: --envmap-scale must be a finite number > 0, got ", envmap_scale));
  if (bounces < 0 || bounces > 64) throw Error(Msg("relight: bounces must be in [0, 64], got ", bounces));
  if (bounce_samples < 1 || bounce_samples > 1024)
    throw Error(Msg("relight: bounce_samples must be in [1, 1024], got ", bounce_samples));
}


RenderedView RenderView(const RayTracer& tracer, const MaterialShader& shader, const Scene& scene, size_t index,
                        const RelightOptions& options) {
  const ImageEntry& entry = scene.images.at(index);
  const Camera& cam = scene.CameraById(entry.camera);
  const Light& light = scene.LightById(entry.light);
  const Rigid3 world_from_cam = entry.cam_from_world.Inverse();
  const LightPaths paths(tracer, shader, light, world_from_cam);

  // Radiance arriving at the camera along a pixel-coordinate ray (0 on a miss).
  auto shade = [&](double px, double py, Rng& rng, bool* hit_out) -> Rgb {
    Vec3 origin_cam, dir_cam;
    cam.PixelRay(Vec2(px, py), &origin_cam, &dir_cam);
    const Vec3 dir = world_from_cam.rotation * dir_cam;
    Hit hit;
    if (!tracer.Intersect(world_from_cam * origin_cam, dir, &hit)) {
      *hit_out = false;
      return Rgb::Zero();
    }
    *hit_out = true;
    const LightPaths::Vertex v = paths.At(hit);
    const Vec3 wo = -dir.normalized();  // towards the viewer (the eye, or -z of an orthographic camera)
    Rgb radiance = paths.Direct(v, wo);
    if (options.bounces > 0) radiance += paths.Indirect(v, wo, options.bounces, options.bounce_samples, rng);
    if (shader.HasTransfer()) {
      // Measured transfer beyond the BRDF (interreflection, light in the
      // shadows): it needs no shadow ray, and the sum stays non-negative.
      const LightSample ls = paths.LightAt(v.x);
      radiance = (radiance + shader.Transfer(v.uv, ls.wi) * ls.normal_irradiance).max(0.0);
    }
    return radiance;
  };

  return RenderPixels(cam, entry, index, options, shade);
}

namespace {

// d sRGB / d linear at linear value v (the encoding's slope; 0 above 1,
// where the encoded value is clipped): converts a linear standard error to
// the sRGB units that PSNR is measured in.
double SrgbSlope(double v) {
  if (v >= 1.0) return 0.0;
  if (v <= 0.0031308) return 12.92;
  return 1.055 / 2.4 * std::pow(v, 1.0 / 2.4 - 1.0);
}

}  // namespace

RenderedView RenderPixels(const Camera& cam, const ImageEntry& entry, size_t index, const RelightOptions& options,
                          const PixelRadiance& shade) {
  const int n = options.samples_per_pixel;
  RenderedView out;
  out.color = Image(cam.width, cam.height, 3);
  out.mask = Image(cam.width, cam.height, 1);
  Progress progress(Msg("render ", entry.file), cam.height, options.progress);
  ParallelFor(cam.height, options.threads, [&](long y) {
    Rng rng(StreamSeed(options.seed, index, y));
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    for (int x = 0; x < cam.width; ++x) {
      bool centre_hit = false;
      Rgb sum = Rgb::Zero();
      if (n == 1) {
        sum = shade(x + 0.5, y + 0.5, rng, &centre_hit);
      } else {
        shade(x + 0.5, y + 0.5, rng, &centre_hit);  // mask from the pixel centre
        // One round: n x n stratified jittered samples; returns their mean,
        // `spread` gets their variance per channel.
        auto round = [&](Rgb* spread) {
          Rgb r = Rgb::Zero(), r2 = Rgb::Zero();
          for (int sy = 0; sy < n; ++sy)
            for (int sx = 0; sx < n; ++sx) {
              bool h;
              const double jy = u01(rng);  // this order reproduces earlier renders bit for bit
              const double jx = u01(rng);
              const Rgb v = shade(x + (sx + jx) / n, y + (sy + jy) / n, rng, &h);
              r += v, r2 += v * v;
            }
          const double count = double(n * n);
          if (spread) *spread = (r2 / count - (r / count).square()).max(0.0);
          return Rgb(r / count);
        };
        // The largest standard error over the channels in sRGB units.
        auto srgb_error = [&](const Rgb& mean, const Rgb& variance_of_mean) {
          double worst = 0;
          for (int c = 0; c < 3; ++c)
            worst = std::max(worst, entry.exposure * std::sqrt(variance_of_mean[c]) * SrgbSlope(entry.exposure * mean[c]));
          return worst;
        };
        Rgb spread;
        sum = round(&spread);
        // Adaptive: a pixel whose first round's samples agree (the naive,
        // for stratified samples pessimistic, standard error) is done; the
        // others take rounds until the spread of the round means says so,
        // after at least kMinRounds (the spread of two or three means is
        // too noisy to stop on). The first round must be fine enough to
        // see a sub-pixel feature: on the Mitsuba bunny's truth rounds of
        // 4 x 4 saturate short of a fixed 16 x 16, finer first rounds all
        // but reach it (bench_results/independent.md).
        constexpr int kMinRounds = 4;
        if (options.adaptive_max_rounds > 1 && srgb_error(sum, spread / double(n * n)) > options.adaptive_tolerance) {
          Rgb mean = sum, m2 = Rgb::Zero();  // Welford over the round means
          for (int r = 2; r <= options.adaptive_max_rounds; ++r) {
            const Rgb v = round(nullptr);
            const Rgb d = v - mean;
            mean += d / double(r);
            m2 += d * (v - mean);
            if (r >= kMinRounds && srgb_error(mean, m2 / (double(r) * (r - 1))) <= options.adaptive_tolerance) break;
          }
          sum = mean;
        }
      }
      for (int c = 0; c < 3; ++c) out.color.at(x, int(y), c) = float(entry.exposure * sum[c]);
      out.mask.at(x, int(y), 0) = centre_hit ? 1.0f : 0.0f;
    }
    progress.Tick();
  });
  progress.Finish();
  return out;
}

void WriteRendered(const std::string& path, const Image& color, ColorSpace integer_space) {
  std::string ext = fs::path(path).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(ch));
  PixelFormat format = PixelFormat::kFloat;
  if (ext == ".png" || ext == ".tif" || ext == ".tiff") format = PixelFormat::kUInt16;
  if (ext == ".jpg" || ext == ".jpeg") format = PixelFormat::kUInt8;
  WriteImage(path, color, format, format == PixelFormat::kFloat ? ColorSpace::kLinear : integer_space);
}

int RelightScene(const Material& material, const Scene& scene, const std::string& out_dir,
                 const RelightOptions& options) {
  options.Check();
  // Outputs go under out_dir only: a scene naming "/abs/x.exr" or
  // "../x.exr" must not write (or overwrite) files elsewhere.
  auto inside = [](const std::string& rel) {
    const fs::path p = fs::path(rel).lexically_normal();
    return !rel.empty() && p.is_relative() && !p.empty() && *p.begin() != "..";
  };
  for (size_t i = 0; i < scene.images.size(); ++i) {
    const ImageEntry& e = scene.images[i];
    if (!inside(e.file))
      throw Error(Msg(scene.Resolve("scene.json"), ": images[", i, "].file: \"", e.file,
                      "\" must be a relative path inside the scene folder to be relit"));
    if (!e.mask.empty() && !inside(e.mask))
      throw Error(Msg(scene.Resolve("scene.json"), ": images[", i, "].mask: \"", e.mask,
                      "\" must be a relative path inside the scene folder to be relit"));
  }
  RayTracer tracer(material.mesh);
  MaterialShader shader(material);
  std::unique_ptr<EnvironmentMap> env;
  if (!options.envmap.empty()) {
    const Image img = ReadImage(options.envmap);
    std::vector<float> rgb(size_t(img.width) * img.height * 3);
    for (size_t p = 0; p < size_t(img.width) * img.height; ++p)
      for (int c = 0; c < 3; ++c) rgb[3 * p + c] = img.pixels[p * img.channels + std::min(c, img.channels - 1)];
    env = std::make_unique<EnvironmentMap>(img.width, img.height, std::move(rgb), options.envmap, options.envmap_scale);
    if (env->clamped_negative() > 0)
      std::fprintf(stderr, "warning: %s: %ld negative values set to 0\n", options.envmap.c_str(), env->clamped_negative());
  }
  for (size_t i = 0; i < scene.images.size(); ++i) {
    const ImageEntry& entry = scene.images[i];
    RenderedView view =
        env ? RenderViewEnvironment(tracer, shader, scene, i, *env, options) : RenderView(tracer, shader, scene, i, options);
    for (float v : view.color.pixels)
      if (!std::isfinite(v))
        throw Error(Msg(scene.Resolve("scene.json"), ": images[", i, "] (", entry.file,
                        "): rendered radiance is not finite (light intensity or exposure out of range?)"));
    const fs::path file = fs::path(out_dir) / entry.file;
    fs::create_directories(file.parent_path());
    WriteRendered(file.string(), view.color, scene.images_color_space);
    fs::path mask = entry.mask.empty() ? fs::path(file).replace_extension(".mask.png") : fs::path(out_dir) / entry.mask;
    fs::create_directories(mask.parent_path());
    WriteImage(mask.string(), view.mask, PixelFormat::kUInt8, ColorSpace::kLinear);
    if (options.png_preview) {
      WriteImage(fs::path(file).replace_extension(".preview.png").string(), view.color, PixelFormat::kUInt8,
                 ColorSpace::kSRGB);
    }
  }
  return static_cast<int>(scene.images.size());
}

}  // namespace svbrdf
