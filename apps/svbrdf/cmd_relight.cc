#include <chrono>
#include <cstdio>
#include <memory>

#include "apps/svbrdf/commands.h"
#include "io/material.h"
#include "io/output_folder.h"
#include "io/scene.h"
#include "relight/relight.h"

namespace svbrdf::cli {

void RegisterRelight(CLI::App& app, Runner* run) {
  struct Args {
    std::string material, scene, out;
    RelightOptions options;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand(
      "relight",
      "Render every image entry of a scene.json (its camera, pose, light, exposure) with a material folder,\n"
      "into OUT/<entry file> (+ mask). Example: svbrdf relight material capture/heldout/scene.json --out relit");
  c->add_option("material", a->material, "material folder (material.json)")->required();
  c->add_option("scene", a->scene, "scene.json giving views and lights")->required();
  c->add_option("--out", a->out, "output folder")->required();
  c->add_option("--spp", a->options.samples_per_pixel,
                "supersampling: n x n samples per pixel (1 = pixel centre). Default: --spp 8 --adaptive-rounds 16\n"
                "(a photo's pixel integrates its area; --envmap: 1)");
  c->add_option("--adaptive-rounds", a->options.adaptive_max_rounds,
                 "adaptive supersampling: up to this many rounds of --spp n x n samples per pixel, until the pixel's "
                 "sRGB standard error is below --adaptive-tolerance (0 = off; photos whose pixels integrate their area "
                 "over sub-pixel geometry need it: --spp 8 --adaptive-rounds 16 matched a fixed --spp 16 on a scan)");
  c->add_option("--adaptive-tolerance", a->options.adaptive_tolerance,
                "--adaptive-rounds: target standard error of a pixel's sRGB value (default 0.001)");
  c->add_option("--bounces", a->options.bounces,
                "indirect light: path-traced surface bounces after the first hit (0 = direct only; default: the\n"
                "bounces the material was fitted without, material.json info.interreflection, else 0);\n"
                "to score against photos of objects that light themselves (concave shapes, real captures)");
  c->add_option("--bounce-samples", a->options.bounce_samples, "--bounces: indirect paths per pixel sample");
  c->add_option("--threads", a->options.threads, "worker threads (0 = all cores)");
  c->add_option("--seed", a->options.seed, "seed of the supersampling jitter");
  c->add_flag("--preview", a->options.png_preview, "also write sRGB PNG previews");
  c->add_option("--envmap", a->options.envmap,
                "light by a lat-long HDR environment (EXR/HDR, +y up, Mitsuba's envmap convention) instead of the\n"
                "scene's lights; importance sampled with shadows. Example:\n"
                "  svbrdf relight material capture/heldout/scene.json --out relit_env --envmap studio.exr --samples 256");
  c->add_option("--samples", a->options.env_samples, "--envmap: environment (+ as many cosine) samples per pixel sample");
  c->add_option("--envmap-scale", a->options.envmap_scale, "--envmap: multiplies the environment's radiance");
  c->callback([a, c, run] {
    // A photo's pixel is the integral over its area: integrated until
    // converged by default (RelightOptions::PixelIntegrating). --envmap
    // renders take their own --samples.
    if (c->count("--spp") == 0 && c->count("--adaptive-rounds") == 0 && a->options.envmap.empty()) {
      const RelightOptions d = RelightOptions::PixelIntegrating();
      a->options.samples_per_pixel = d.samples_per_pixel;
      a->options.adaptive_max_rounds = d.adaptive_max_rounds;
    }
    const bool bounces_given = c->count("--bounces") > 0;
    *run = [a, bounces_given] {
      const auto t0 = std::chrono::steady_clock::now();
      const Material material = LoadMaterial(a->material);
      if (!bounces_given && MaterialBounces(material) > 0) {
        a->options.bounces = MaterialBounces(material);
        std::fprintf(stderr, "relight: %d indirect bounces (the material was fitted to direct light; --bounces 0: "
                     "direct only)\n", a->options.bounces);
      }
      const Scene scene = LoadScene(a->scene);
      OutputFolder out(a->out);
      const int n = RelightScene(material, scene, out.path(), a->options);
      out.Commit();
      std::printf("relit %d images in %.2f s into %s\n", n,
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), a->out.c_str());
      return 0;
    };
  });
}

}  // namespace svbrdf::cli
