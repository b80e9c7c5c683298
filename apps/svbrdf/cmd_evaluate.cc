#include <cstdio>
#include <memory>

#include "apps/svbrdf/commands.h"
#include "evaluate/metrics.h"
#include "io/scene.h"

namespace svbrdf::cli {

void RegisterEvaluate(CLI::App& app, Runner* run) {
  struct Args {
    std::string rendered, scene;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand(
      "evaluate",
      "Compare images rendered by `relight` with the photographs of a scene.json, inside its masks:\n"
      "PSNR of sRGB-encoded radiance and linear relative RMSE per image.\n"
      "Example: svbrdf evaluate relit capture/heldout/scene.json");
  c->add_option("rendered", a->rendered, "folder written by relight")->required();
  c->add_option("scene", a->scene, "scene.json of the photographs")->required();
  c->callback([a, run] {
    *run = [a] {
      const Scene scene = LoadScene(a->scene);
      const SceneComparison cmp = CompareToScene(scene, a->rendered);
      for (size_t i = 0; i < cmp.files.size(); ++i)
        std::printf("%-28s PSNR %6.2f dB  rel. RMSE %.4f  (%ld px)\n", cmp.files[i].c_str(),
                    cmp.per_image[i].psnr_srgb, cmp.per_image[i].rel_rmse_linear, cmp.per_image[i].pixels);
      std::printf("mean PSNR %.2f dB (min %.2f), mean rel. RMSE %.4f over %zu images\n", cmp.mean_psnr_srgb,
                  cmp.min_psnr_srgb, cmp.mean_rel_rmse, cmp.files.size());
      return 0;
    };
  });
}

}  // namespace svbrdf::cli
