// report.html of a reconstruction: one self-contained page (pictures
// embedded) with the cluster, weight, confidence and residual maps, the
// held-out photo next to its relit twin, per-stage timings, the chosen
// models with their parameters, and warnings.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/progress.h"

namespace svbrdf {

// summary["timings_s"] and summary["cpu_s"]: wall and CPU seconds per stage
// name, summed over the stage's entries (a stage entered twice, as
// "fit + cluster" around the interreflection's second pass, counts both).
void AddStageTimes(const StageTimer& timer, nlohmann::json* summary);

// Warnings a reader should see, derived from the summary (weak signal,
// many rejected samples, a poor held-out match, ...) plus summary["warnings"].
std::vector<std::string> ReportWarnings(const nlohmann::json& summary);

// Writes report_dir/report.html from summary.json's content and the PNGs
// that RunReconstruction wrote into report_dir.
void WriteReportHtml(const nlohmann::json& summary, const std::string& report_dir);

}  // namespace svbrdf
