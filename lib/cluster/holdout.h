// Which photos are held out for validation. Every stage that decides on
// unseen photos (the clustering's split test and model choice, the normal
// refinement's keep-or-not decision) must use the same photos, so the rule
// lives here once.
#pragma once
#include <cstdint>
#include <vector>

namespace svbrdf {

// Per image: 1 if held out. Images are ordered by a seeded hash and the first
// round(holdout_fraction * num_images) are held out (at least one, none when
// there is only one photo): whole photos, so that held-out error measures
// what relighting needs (new views and lights).
std::vector<char> HeldOutImages(int num_images, double holdout_fraction, uint64_t seed);

}  // namespace svbrdf
