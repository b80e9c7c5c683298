// The `reconstruct` job on a photometric capture (one fixed ORTHOGRAPHIC
// view, one directional light per photo; IsPhotometricCapture): per-pixel
// normals and dictionary SVBRDF (lib/photometric), a height-field mesh with
// one quad per pixel, the material folder, normals_camera.exr and a report.
#pragma once
#include <nlohmann/json.hpp>

#include "core/progress.h"
#include "io/scene.h"
#include "pipeline/reconstruction.h"

namespace svbrdf {

// Writes job.out_dir (material.json, maps, mesh, normals_camera.exr,
// report/); returns the summary (also report/summary.json).
nlohmann::json RunPhotometricReconstruction(const ReconstructionJob& job, const Scene& scene, StageTimer* timer);

}  // namespace svbrdf
