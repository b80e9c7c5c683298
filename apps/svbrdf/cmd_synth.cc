#include <cstdio>
#include <memory>

#include "apps/svbrdf/commands.h"
#include "core/error.h"
#include "io/scene.h"
#include "synth/capture.h"

namespace svbrdf::cli {

void RegisterSynth(CLI::App& app, Runner* run) {
  struct Args {
    std::string preset = "default", config, out;
    std::string object, lights, format;
    int images = -1, materials = -1, width = -1, height = -1, threads = 0, spp = -1;
    double noise = -1, pose_deg = -1, pose_mm = -1, light_mm = -1, geom_mm = -1, exposure = -1;
    long seed = -1;
    std::string mesh_file;
    bool no_mesh_uvs = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand("synth",
                                   "Make a synthetic capture with exact ground truth (scene.json, images, masks,\n"
                                   "gt/ material folder, heldout/ views).\n"
                                   "Example: svbrdf synth --preset standard --noise 0.01 --out capture");
  c->add_option("--preset", a->preset, "named capture from datasets_synth/ (default, tiny, standard, ...)");
  c->add_option("--config", a->config, "JSON file with synth options (overrides --preset)");
  c->add_option("--out", a->out, "output folder")->required();
  c->add_option("--object", a->object, "sphere | torus | blob | cube");
  c->add_option("--mesh", a->mesh_file, "mesh file (OBJ/PLY, e.g. a scan) instead of --object; scaled to 0.5 m radius");
  c->add_flag("--no-mesh-uvs", a->no_mesh_uvs, "write the capture's mesh.obj without texture coordinates (as a scan)");
  c->add_option("--images", a->images, "number of photos");
  c->add_option("--materials", a->materials, "number of basis materials");
  c->add_option("--width", a->width, "image width");
  c->add_option("--height", a->height, "image height");
  c->add_option("--lights", a->lights, "flash | point | spot | goniometric | mixed");
  c->add_option("--format", a->format, "exr | png16 | png8 | jpg");
  c->add_option("--noise", a->noise, "shot noise, sigma = noise*sqrt(value)");
  c->add_option("--exposure", a->exposure, "exposure factor");
  c->add_option("--pose-error-deg", a->pose_deg, "rotation error written into the poses");
  c->add_option("--pose-error-mm", a->pose_mm, "translation error written into the poses");
  c->add_option("--light-error-mm", a->light_mm, "position error written into the lights");
  c->add_option("--geometry-noise-mm", a->geom_mm, "noise written into the mesh");
  c->add_option("--spp", a->spp, "supersampling, n x n per pixel");
  c->add_option("--seed", a->seed, "random seed");
  c->add_option("--threads", a->threads, "worker threads (0 = all cores)");
  c->callback([a, run] {
    *run = [a] {
      SynthOptions o = a->config.empty() ? SynthPreset(a->preset)
                                         : SynthOptions::FromJson(ReadJsonFile(a->config), a->config);
      if (!a->object.empty()) o.object = a->object;
      if (!a->mesh_file.empty()) o.mesh_file = a->mesh_file;
      if (a->no_mesh_uvs) o.mesh_uvs = false;
      if (a->images > 0) o.num_images = a->images;
      if (a->materials > 0) o.material.num_materials = a->materials, o.material.models.clear(), o.material.params.clear();
      if (a->width > 0) o.width = a->width;
      if (a->height > 0) o.height = a->height;
      if (!a->lights.empty()) o.lights = a->lights;
      if (!a->format.empty()) o.format = a->format;
      if (a->noise >= 0) o.noise = a->noise;
      if (a->exposure > 0) o.exposure = a->exposure;
      if (a->pose_deg >= 0) o.pose_error_deg = a->pose_deg;
      if (a->pose_mm >= 0) o.pose_error_mm = a->pose_mm;
      if (a->light_mm >= 0) o.light_error_mm = a->light_mm;
      if (a->geom_mm >= 0) o.geometry_noise_mm = a->geom_mm;
      if (a->spp > 0) o.spp = a->spp;
      if (a->seed >= 0) o.seed = static_cast<uint64_t>(a->seed);
      o.threads = a->threads;
      const SynthReport r = Synthesize(o, a->out);
      std::printf("synthesized %d images (+%d held out) in %.2f s into %s\n", r.images, o.num_heldout, r.seconds,
                  a->out.c_str());
      if (r.saturated_fraction > 0) std::printf("saturated object pixels: %.2f %%\n", 100 * r.saturated_fraction);
      return 0;
    };
  });
}

}  // namespace svbrdf::cli
