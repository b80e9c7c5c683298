#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "apps/svbrdf/commands.h"
#include "core/error.h"
#include "export/gltf.h"
#include "export/mitsuba.h"
#include "io/material.h"
#include "io/output_folder.h"
#include "io/scene.h"

namespace svbrdf::cli {

namespace fs = std::filesystem;

void RegisterExport(CLI::App& app, Runner* run) {
  struct Args {
    std::string material, format, out, scene;
    MitsubaExportOptions mitsuba;
    GltfExportOptions gltf;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand(
      "export",
      "Export a material folder for other tools: a Mitsuba 3 scene (XML, mesh, textures; with --scene, one view\n"
      "file per image entry with its camera and light) or glTF 2.0 with baked metallic-roughness PBR textures.\n"
      "Examples:\n"
      "  svbrdf export material --format mitsuba --scene capture/heldout/scene.json --out material_mitsuba\n"
      "  svbrdf export material --format gltf --out material_gltf");
  c->add_option("material", a->material, "material folder (material.json)")->required();
  c->add_option("--format", a->format, "mitsuba or gltf")->required()->check(CLI::IsMember({"mitsuba", "gltf"}));
  c->add_option("--out", a->out, "output folder (written under a temporary name, renamed when complete)")->required();
  c->add_option("--scene", a->scene, "mitsuba: scene.json whose cameras, poses and lights become view files");
  c->add_option("--spp", a->mitsuba.spp, "mitsuba: samples per pixel of the sensors");
  c->add_option("--threads", a->gltf.threads, "gltf: worker threads of the per-texel fit (0 = all cores)");
  c->callback([a, run] {
    *run = [a] {
      const auto t0 = std::chrono::steady_clock::now();
      const Material material = LoadMaterial(a->material);
      std::unique_ptr<Scene> scene;
      if (!a->scene.empty()) scene = std::make_unique<Scene>(LoadScene(a->scene));
      // Written under a temporary sibling name, renamed when complete.
      OutputFolder out(a->out);
      const fs::path dir = out.final_path();
      nlohmann::json report;
      if (a->format == "mitsuba") report = ExportMitsuba(material, scene.get(), a->mitsuba, out.path());
      else report = ExportGltf(material, a->gltf, out.path());
      out.Commit();
      for (const auto& w : report.value("warnings", nlohmann::json::array()))
        std::fprintf(stderr, "warning: %s\n", w.get<std::string>().c_str());
      std::printf("exported %s (%s) in %.2f s into %s\n", a->material.c_str(), a->format.c_str(),
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), dir.c_str());
      return 0;
    };
  });
}

}  // namespace svbrdf::cli
