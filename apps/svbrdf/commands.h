// One CLI binary, one small file per subcommand: each file only parses
// options and calls a library module.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>

namespace svbrdf::cli {

// Each Register* adds a subcommand to `app` and sets `run` to be called when it is chosen.
using Runner = std::function<int()>;
void RegisterSynth(CLI::App& app, Runner* run);
void RegisterRelight(CLI::App& app, Runner* run);
void RegisterReconstruct(CLI::App& app, Runner* run);
void RegisterEvaluate(CLI::App& app, Runner* run);
void RegisterCalibrate(CLI::App& app, Runner* run);
void RegisterCapture(CLI::App& app, Runner* run);
void RegisterExport(CLI::App& app, Runner* run);
void RegisterImportPs(CLI::App& app, Runner* run);

}  // namespace svbrdf::cli
