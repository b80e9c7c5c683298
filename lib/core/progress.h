// Progress bars and per-stage timings printed to stderr, and peak memory.
#pragma once
#include <atomic>
#include <chrono>
#include <mutex>
#include <string>
#include <vector>

namespace svbrdf {

// A thread-safe progress bar: Tick() from any worker; redraws at most 10x/s.
class Progress {
 public:
  Progress(std::string label, long total, bool enabled = true);
  ~Progress();
  void Tick(long n = 1);
  void Finish();

 private:
  void Draw(bool final_line);
  std::string label_;
  long total_;
  bool enabled_;
  bool tty_;  // redraw in place only on a terminal
  std::atomic<long> done_{0};
  std::mutex mutex_;
  std::chrono::steady_clock::time_point start_, last_draw_;
  bool finished_ = false;
};

// Records wall time per named stage; Report() prints a table.
class StageTimer {
 public:
  struct Stage {
    std::string name;
    double seconds;
    double cpu_seconds = 0;  // CPU time of the whole process (all threads) in the stage
  };
  void Start(const std::string& name);
  void Stop();  // stops the current stage
  const std::vector<Stage>& stages() const { return stages_; }
  double Total() const;
  std::string Report() const;

 private:
  std::vector<Stage> stages_;
  std::string current_;
  std::chrono::steady_clock::time_point t0_;
  double cpu0_ = 0;
};

double PeakMemoryMB();  // VmHWM of this process, from /proc/self/status
// CPU time (user + sys) of this process so far, all threads: the per-stage
// CPU/wall ratio shows whether both cores worked, whatever else runs.
double ProcessCpuSeconds();
// Wall seconds since this process started (from /proc/self/stat and
// /proc/uptime, 10 ms resolution; 0 where they cannot be read): a time
// budget counts the program's start-up (loading shared libraries) too.
double ProcessAgeSeconds();

}  // namespace svbrdf
