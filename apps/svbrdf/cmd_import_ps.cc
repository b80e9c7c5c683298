#include <cstdio>
#include <memory>

#include "apps/svbrdf/commands.h"
#include "photometric/ps_folder.h"

namespace svbrdf::cli {

void RegisterImportPs(CLI::App& app, Runner* run) {
  auto o = std::make_shared<ImportPsOptions>();
  CLI::App* c = app.add_subcommand(
      "import-ps",
      "Turn a photometric-stereo folder (DiLiGenT's layout: NNN.png or filenames.txt, light_directions.txt,\n"
      "light_intensities.txt, mask.png; 8- or 16-bit linear photos, one directional light each) into a capture:\n"
      "CAP/scene.json (training photos), CAP/heldout/scene.json (lights N, 2N, ...), an ORTHOGRAPHIC camera,\n"
      "masks without saturated pixels and an image-plane mesh (a height field from --normals, else a plane whose\n"
      "normals the capture declares unknown: reconstruct then estimates them from the photos).\n"
      "Example: svbrdf import-ps data/cat --out cap && svbrdf reconstruct cap/scene.json --out mat");
  c->add_option("dir", o->in_dir, "photometric-stereo folder")->required();
  c->add_option("--out", o->out_dir, "capture folder to write")->required();
  c->add_option("--hold-out-every", o->hold_out_every, "lights N, 2N, ... (1-based) are held out for evaluation");
  c->add_option("--normals", o->normals_file,
                "float RGB EXR of unit normals (x right, y up, z towards the camera; zero outside the object):\n"
                "the mesh carries them (a scan's normals, or ground truth)");
  c->add_option("--truth-normals", o->truth_normals_file,
                "the same kind of file kept as ground truth for the report only (normals stay unknown)");
  c->add_option("--erode", o->erode_px, "held-out photo masks: the object mask eroded by this many pixels");
  c->add_option("--erode-training", o->erode_training_px, "training photo masks: the same (0: every object pixel)");
  c->add_option("--quantization", o->quantization,
                "how 8-bit photos were quantised: floor (truncated, as DiLiGenT's 8-bit copies; a count k is stored\n"
                "as k + 1/2, 0 stays 0) or round (stored as is); 16-bit and float photos are copied as they are")
      ->check(CLI::IsMember({"floor", "round"}));
  c->add_option("--pixels-per-metre", o->pixels_per_metre, "metric scale of the orthographic camera (nominal)");
  c->callback([o, run] {
    *run = [o] {
      const ImportPsResult r = ImportPs(*o);
      std::printf("capture: %s/scene.json (%d photos), %s/heldout/scene.json (%d photos); %ld object pixels, %ld "
                  "saturated pixel values left out of the masks\n",
                  o->out_dir.c_str(), r.training, o->out_dir.c_str(), r.held_out, r.object_pixels, r.saturated_samples);
      if (r.dequantized > 0)
        std::printf("8-bit photos: %d stored as 16-bit PNG with each floored count k at k + 1/2 (--quantization)\n",
                    r.dequantized);
      return 0;
    };
  });
}

}  // namespace svbrdf::cli
