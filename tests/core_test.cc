// Core utilities: the process clocks that per-stage timings and time
// budgets rely on.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "core/progress.h"

namespace svbrdf {
namespace {

TEST(ProcessClock, AgeCountsFromTheProgramStart) {
  const double a = ProcessAgeSeconds();
  EXPECT_GE(a, 0.0);     // /proc's 10 ms ticks: a fast start reads 0
  EXPECT_LT(a, 3600.0);  // not since boot
  std::this_thread::sleep_for(std::chrono::milliseconds(120));
  const double b = ProcessAgeSeconds();
  EXPECT_GE(b, 0.1);
  EXPECT_GE(b - a, 0.08);  // /proc resolution is 10 ms
  EXPECT_LT(b - a, 60.0);
}

TEST(ProcessClock, CpuSecondsGrowWithWork) {
  const double c0 = ProcessCpuSeconds();
  volatile double x = 0;
  for (int i = 0; i < 20000000; ++i) x = x + 1e-9 * i;
  EXPECT_GT(ProcessCpuSeconds(), c0);
}

}  // namespace
}  // namespace svbrdf
