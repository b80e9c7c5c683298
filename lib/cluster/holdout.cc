#include "cluster/holdout.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/rng.h"

namespace svbrdf {

std::vector<char> HeldOutImages(int num_images, double holdout_fraction, uint64_t seed) {
  constexpr uint64_t kSalt = 0x401d;  // the hash stream of the hold-out choice
  std::vector<std::pair<double, int>> order;
  for (int im = 0; im < num_images; ++im) order.emplace_back(HashUniform(seed, uint64_t(im), kSalt), im);
  std::sort(order.begin(), order.end());
  std::vector<char> held(std::max(0, num_images), 0);
  const int num_held = std::max(1, int(std::lround(holdout_fraction * num_images)));
  for (int j = 0; j < num_held && num_images > 1; ++j) held[order[j].second] = 1;
  return held;
}

}  // namespace svbrdf
