#include <cstdio>
#include <memory>

#include "apps/svbrdf/commands.h"
#include "calib/board.h"
#include "core/error.h"
#include "registration/capture_job.h"
#include "synth/raw_photos.h"

namespace svbrdf::cli {

void RegisterCapture(CLI::App& app, Runner* run) {
  auto job = std::make_shared<CaptureJob>();
  CLI::App* c = app.add_subcommand(
      "capture",
      "Photographs -> contract capture (scene.json): intrinsics, HDR merge, board poses (PnP +\n"
      "bundle adjustment), silhouette registration of the mesh, lamps from mirror spheres and the\n"
      "board's albedo. Reads PHOTOS_DIR/capture.json (see docs/guide/photographs.md).\n"
      "Example: svbrdf capture raw --out capture && svbrdf reconstruct capture/scene.json --out material");
  c->add_option("photos", job->photos_dir, "folder of photos with capture.json")->required();
  c->add_option("--description", job->description, "description file (default PHOTOS_DIR/capture.json)");
  c->add_option("--out", job->out_dir, "output capture folder")->required();
  c->add_option("--silhouette-iterations", job->silhouette_iterations, "contour re-extractions in registration");
  c->add_option("--threads", job->threads, "worker threads (0 = all cores)");
  c->callback([job, run] {
    *run = [job] {
      const nlohmann::json r = RunCapture(*job);
      std::printf("capture written to %s (report: %s/report/capture_report.json)\n", job->out_dir.c_str(),
                  job->out_dir.c_str());
      std::printf("bundle RMS %.3f px; lights:", r["bundle"]["rms_px"].get<double>());
      for (const auto& l : r["lights"]) std::printf(" #%d from %d rays", l["id"].get<int>(), l["rays"].get<int>());
      std::printf("\n");
      return 0;
    };
  });

  // Synthetic raw photo sets with hidden ground truth, for testing this path.
  struct RawArgs {
    std::string out, object = "cube";
    int images = 16, calibration = 10, lamps = 4, width = 480, height = 360, heldout = 3, spp = 3;
    double noise = 0;
    long seed = 1;
  };
  auto a = std::make_shared<RawArgs>();
  CLI::App* s = app.add_subcommand(
      "synth-raw",
      "Synthetic raw photo set for `capture`: a ChArUco board (11x8 squares of 3.5 cm), mirror spheres,\n"
      "lamps and an object with a hidden ground-truth SVBRDF; brackets of 16-bit linear PNGs,\n"
      "capture.json, and truth/ (the ground-truth capture, kept aside).\n"
      "Example: svbrdf synth-raw --out raw && svbrdf capture raw --out capture");
  s->add_option("--out", a->out, "output folder")->required();
  s->add_option("--object", a->object, "sphere | torus | blob | cube");
  s->add_option("--images", a->images, "object photos");
  s->add_option("--calibration", a->calibration, "board-only photos");
  s->add_option("--lamps", a->lamps, "point lamps");
  s->add_option("--width", a->width, "image width");
  s->add_option("--height", a->height, "image height");
  s->add_option("--heldout", a->heldout, "held-out evaluation views");
  s->add_option("--spp", a->spp, "supersampling of board and spheres (n x n)");
  s->add_option("--noise", a->noise, "shot noise");
  s->add_option("--seed", a->seed, "random seed");
  s->callback([a, run] {
    *run = [a] {
      const BoardSpec b = DefaultRawBoard();
      const BoardTexture tex = DrawBoard(b, 48);
      RawPhotoOptions o;
      o.board_texture = tex.image;
      o.texture_from_board = tex.texture_from_board;
      o.board_json = {{"pattern", "charuco"}, {"cols", b.cols}, {"rows", b.rows}, {"square", b.square},
                      {"marker", b.marker}, {"dictionary", b.dictionary}};
      o.object = a->object;
      o.num_images = a->images;
      o.num_calibration = a->calibration;
      o.num_lamps = a->lamps;
      o.width = a->width;
      o.height = a->height;
      o.num_heldout = a->heldout;
      o.spp = a->spp;
      o.noise = a->noise;
      o.seed = uint64_t(a->seed);
      SynthesizeRawPhotos(o, a->out);
      std::printf("raw photo set in %s (ground-truth capture: %s/truth/scene.json)\n", a->out.c_str(), a->out.c_str());
      return 0;
    };
  });
}

}  // namespace svbrdf::cli
