// Runs the svbrdf CLI as a child process (for tests that must see exit codes,
// signals and what a crash leaves on disk). Header-only, tests only.
#pragma once
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace svbrdf::test {

struct CliRun {
  int status = -1;     // raw wait status
  std::string output;  // stdout and stderr together
  bool timed_out = false;
  bool Signaled() const { return WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status) >= 128); }
  int ExitCode() const { return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status); }
  bool Ok() const { return !timed_out && WIFEXITED(status) && WEXITSTATUS(status) == 0; }
};

// Starts `SVBRDF_CLI args...` with output into `log`; returns its pid.
inline pid_t StartCli(const std::vector<std::string>& args, const std::string& log) {
  std::vector<std::string> all = {SVBRDF_CLI};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  pid_t pid = -1;
  if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&fa);
  return pid;
}

inline std::string ReadText(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

// Runs the CLI to completion (killed after `timeout_s`), output captured via `log`.
inline CliRun RunCliArgs(const std::vector<std::string>& args, const std::string& log, double timeout_s = 120) {
  CliRun r;
  const pid_t pid = StartCli(args, log);
  if (pid < 0) {
    r.output = "cannot start " + std::string(SVBRDF_CLI);
    return r;
  }
  const auto start = std::chrono::steady_clock::now();
  for (;;) {
    const pid_t done = waitpid(pid, &r.status, WNOHANG);
    if (done == pid) break;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > timeout_s) {
      r.timed_out = true;
      kill(pid, SIGKILL);
      waitpid(pid, &r.status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  r.output = ReadText(log);
  return r;
}

// Entries of `dir` whose names contain ".tmp-" or ".old-": left-overs of an
// output that was never committed.
inline std::vector<std::string> TempLeftovers(const std::string& dir) {
  std::vector<std::string> found;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.find(".tmp-") != std::string::npos || name.find(".old-") != std::string::npos) found.push_back(name);
  }
  return found;
}

}  // namespace svbrdf::test
