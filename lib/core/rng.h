// Seeded random numbers. Every stochastic step takes an explicit seed so runs
// are reproducible; per-item streams are derived by hashing (seed, item) so
// results do not depend on thread scheduling.
#pragma once
#include <cstdint>
#include <random>

namespace svbrdf {

// SplitMix64 finaliser: a good 64-bit mix for deriving independent streams.
inline uint64_t HashMix(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

inline uint64_t StreamSeed(uint64_t seed, uint64_t a, uint64_t b = 0) { return HashMix(HashMix(seed ^ HashMix(a)) ^ b); }

// Uniform double in [0, 1) from a hash, for cheap stateless decisions (hold-out split).
inline double HashUniform(uint64_t seed, uint64_t a, uint64_t b = 0) {
  return (StreamSeed(seed, a, b) >> 11) * (1.0 / 9007199254740992.0);
}

using Rng = std::mt19937_64;

}  // namespace svbrdf
