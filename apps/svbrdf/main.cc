// svbrdf: recover spatially varying BRDFs from photographs and relight them.
#include <cstdio>
#include <exception>

#include <glog/logging.h>

#include "apps/svbrdf/commands.h"
#include "core/error.h"
#include "io/output_folder.h"

int main(int argc, char** argv) {
  // First, before any thread exists: SIGINT/SIGTERM remove unfinished output folders.
  svbrdf::RemoveOutputsOnSignal();
  CLI::App app{
      "svbrdf - spatially varying BRDF reconstruction and relighting.\n"
      "Typical use:\n"
      "  svbrdf synth --preset default --out capture\n"
      "  svbrdf reconstruct capture/scene.json --out material\n"
      "  svbrdf relight material capture/heldout/scene.json --out relit\n"
      "  svbrdf evaluate relit capture/heldout/scene.json"};
  app.require_subcommand(1);
  // Ceres logs through glog; keep its informational lines off the terminal,
  // and its errors on stderr only (glog's default also writes log files into
  // /tmp, which nobody asked for).
  FLAGS_minloglevel = 2;
  FLAGS_logtostderr = true;
  google::InitGoogleLogging(argv[0]);
  svbrdf::cli::Runner run;
  svbrdf::cli::RegisterSynth(app, &run);
  svbrdf::cli::RegisterRelight(app, &run);
  svbrdf::cli::RegisterReconstruct(app, &run);
  svbrdf::cli::RegisterEvaluate(app, &run);
  svbrdf::cli::RegisterCalibrate(app, &run);
  svbrdf::cli::RegisterCapture(app, &run);
  svbrdf::cli::RegisterExport(app, &run);
  svbrdf::cli::RegisterImportPs(app, &run);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    return run ? run() : 1;
  } catch (const svbrdf::Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 3;
  }
}
