#include "io/output_folder.h"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <set>
#include <thread>

#include "core/error.h"

namespace svbrdf {
namespace fs = std::filesystem;
namespace {

// Uncommitted temporary folders; the mutex also makes a Commit() and the
// signal watcher's clean-up mutually exclusive (a signal during a commit
// waits for it, so the destination is never left half swapped).
std::mutex& RegistryMutex() {
  static std::mutex m;
  return m;
}
std::set<std::string>& Registry() {
  static std::set<std::string> r;
  return r;
}

void RemoveTree(const std::string& path) {
  // A worker thread may still be writing into it: retry a few times.
  for (int attempt = 0; attempt < 5; ++attempt) {
    std::error_code ec;
    fs::remove_all(path, ec);
    if (!fs::exists(path, ec)) return;
  }
}

}  // namespace

OutputFolder::OutputFolder(const std::string& final_path) {
  fs::path dest = fs::path(final_path).lexically_normal();
  if (dest.filename().empty()) dest = dest.parent_path();  // "out/" -> "out"
  if (dest.empty() || dest == "." || dest == "..")
    throw Error(Msg(final_path, ": output folder needs a name (not the current or parent folder)"));
  final_ = dest.string();
  std::error_code ec;
  if (fs::exists(dest, ec) && !fs::is_directory(dest, ec))
    throw Error(Msg(final_, ": exists and is not a folder; choose another output path"));
  tmp_ = Msg(final_, ".tmp-", getpid());
  try {
    if (!dest.parent_path().empty()) fs::create_directories(dest.parent_path());
    std::lock_guard<std::mutex> lock(RegistryMutex());
    fs::remove_all(tmp_);  // left over by an earlier process with the same id
    fs::create_directory(tmp_);
    Registry().insert(tmp_);
  } catch (const fs::filesystem_error& e) {
    throw Error(Msg(final_, ": cannot create output folder: ", e.code().message()));
  }
}

OutputFolder::~OutputFolder() {
  if (committed_) return;
  std::lock_guard<std::mutex> lock(RegistryMutex());
  RemoveTree(tmp_);
  Registry().erase(tmp_);
}

void OutputFolder::Commit() {
  if (committed_) return;
  std::lock_guard<std::mutex> lock(RegistryMutex());
  std::error_code ec;
  if (!fs::exists(final_, ec)) {
    if (std::rename(tmp_.c_str(), final_.c_str()) != 0)
      throw Error(Msg(final_, ": cannot move the finished output into place: ", std::strerror(errno)));
  } else if (renameat2(AT_FDCWD, tmp_.c_str(), AT_FDCWD, final_.c_str(), RENAME_EXCHANGE) == 0) {
    RemoveTree(tmp_);  // now holds the previous result
  } else {
    // No atomic exchange on this file system: move the previous result
    // aside, move the new one in, and put the old one back if that fails.
    const std::string old = Msg(final_, ".old-", getpid());
    RemoveTree(old);
    if (std::rename(final_.c_str(), old.c_str()) != 0)
      throw Error(Msg(final_, ": cannot replace the previous output: ", std::strerror(errno)));
    if (std::rename(tmp_.c_str(), final_.c_str()) != 0) {
      const int err = errno;
      std::rename(old.c_str(), final_.c_str());
      throw Error(Msg(final_, ": cannot move the finished output into place: ", std::strerror(err)));
    }
    RemoveTree(old);
  }
  Registry().erase(tmp_);
  committed_ = true;
}

void RemoveOutputsOnSignal() {
  static std::once_flag once;
  std::call_once(once, [] {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    std::thread([set] {
      int sig = 0;
      while (sigwait(&set, &sig) != 0) {
      }
      // Hold the lock to the end: no commit can start after the clean-up.
      RegistryMutex().lock();
      for (const std::string& tmp : Registry()) RemoveTree(tmp);
      // End with the signal's own status (a shell sees 128 + sig).
      signal(sig, SIG_DFL);
      sigset_t one;
      sigemptyset(&one);
      sigaddset(&one, sig);
      pthread_sigmask(SIG_UNBLOCK, &one, nullptr);
      raise(sig);
      _exit(128 + sig);
    }).detach();
  });
}

}  // namespace svbrdf
