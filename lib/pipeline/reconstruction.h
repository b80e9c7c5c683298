// The `reconstruct` job end to end: read a capture, gather per-texel
// samples, estimate the SVBRDF (progressive clustering, model selection,
// NNLS weights), refine per-texel normals (lib/normals), write the material folder and a report with pictures and a
// summary JSON. Per-stage timings and peak memory are recorded.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

#include "cluster/reconstruct.h"
#include "gather/gather.h"
#include "normals/refine.h"

namespace svbrdf {

struct ReconstructionJob {
  std::string scene_path;
  std::string out_dir;
  GatherOptions gather;
  ReconstructOptions estimate;
  NormalOptions normals;  // hold-out split, seed and threads are taken from `estimate`
  bool report = true;  // pictures and summary under out_dir/report
};

// Returns the summary (also written to out_dir/report/summary.json).
nlohmann::json RunReconstruction(const ReconstructionJob& job);

}  // namespace svbrdf
