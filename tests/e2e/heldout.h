// End-to-end tests' scoring: a material relit on a capture's held-out views
// (CAPTURE/heldout/scene.json) and compared with its photos inside the masks.
#pragma once
#include <string>

#include "evaluate/metrics.h"
#include "io/material.h"
#include "io/scene.h"
#include "relight/relight.h"

namespace svbrdf::e2e {

inline SceneComparison HeldOutComparison(const Material& material, const std::string& capture_dir,
                                         const std::string& relit_dir) {
  const Scene held = LoadScene(capture_dir + "/heldout/scene.json");
  RelightOptions rl;
  rl.progress = false;
  RelightScene(material, held, relit_dir, rl);
  return CompareToScene(held, relit_dir);
}

}  // namespace svbrdf::e2e
