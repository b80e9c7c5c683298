#include "core/progress.h"

#include <ctime>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <unistd.h>

namespace svbrdf {

Progress::Progress(std::string label, long total, bool enabled)
    : label_(std::move(label)), total_(total), enabled_(enabled), tty_(isatty(2) == 1),
      start_(std::chrono::steady_clock::now()), last_draw_(start_) {}

Progress::~Progress() { Finish(); }

void Progress::Tick(long n) {
  done_ += n;
  if (!enabled_ || !tty_) return;  // logs get the final line only
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  if (now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  Draw(false);
}

void Progress::Finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_) return;
  finished_ = true;
  if (enabled_) Draw(true);
}

void Progress::Draw(bool final_line) {
  const long done = std::min<long>(done_, total_);
  const double frac = total_ > 0 ? double(done) / total_ : 1.0;
  const int width = 30;
  const int filled = static_cast<int>(frac * width);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::string bar(filled, '#');
  bar.resize(width, '.');
  std::fprintf(stderr, "\r  %-22s [%s] %5.1f%% %ld/%ld %6.2fs%s", label_.c_str(), bar.c_str(), 100 * frac, done,
               total_, secs, final_line ? "\n" : "");
  std::fflush(stderr);
}

void StageTimer::Start(const std::string& name) {
  if (!current_.empty()) Stop();
  current_ = name;
  t0_ = std::chrono::steady_clock::now();
  cpu0_ = ProcessCpuSeconds();
}

void StageTimer::Stop() {
  if (current_.empty()) return;
  stages_.push_back({current_, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(),
                     ProcessCpuSeconds() - cpu0_});
  current_.clear();
}

double StageTimer::Total() const {
  double s = 0;
  for (const auto& st : stages_) s += st.seconds;
  return s;
}

std::string StageTimer::Report() const {
  std::ostringstream os;
  char line[160];
  for (const auto& st : stages_) {
    std::snprintf(line, sizeof line, "  %-24s %9.3f s   CPU %8.3f s\n", st.name.c_str(), st.seconds, st.cpu_seconds);
    os << line;
  }
  std::snprintf(line, sizeof line, "  %-24s %9.3f s   peak memory %.0f MB\n", "total", Total(), PeakMemoryMB());
  os << line;
  return os.str();
}

double ProcessCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double ProcessAgeSeconds() {
  // Field 22 of /proc/self/stat is the start time in clock ticks since boot;
  // the command name (field 2) may hold spaces, so parse after its ')'.
  std::ifstream stat("/proc/self/stat"), uptime("/proc/uptime");
  std::string line;
  double up = 0;
  if (!std::getline(stat, line) || !(uptime >> up)) return 0.0;
  const size_t close = line.rfind(')');
  if (close == std::string::npos) return 0.0;
  std::istringstream fields(line.substr(close + 1));
  std::string field;
  for (int i = 3; i <= 22 && fields >> field; ++i)
    if (i == 22) {
      const long ticks = sysconf(_SC_CLK_TCK);
      const double age = up - std::stod(field) / double(ticks > 0 ? ticks : 100);
      return age > 0 && age < 1e7 ? age : 0.0;
    }
  return 0.0;
}

double PeakMemoryMB() {
  std::ifstream in("/proc/self/status");
  std::string key;
  while (in >> key) {
    if (key == "VmHWM:") {
      double kb = 0;
      in >> kb;
      return kb / 1024.0;
    }
    std::string rest;
    std::getline(in, rest);
  }
  return 0.0;
}

}  // namespace svbrdf
