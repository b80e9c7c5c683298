// Output folders that appear complete or not at all. Every command writes
// into "<parent>/<name>.tmp-<pid>" and Commit() puts it in place in one
// step: a failure, an exception or a signal leaves no folder that looks
// complete, and an existing result at the destination survives until the
// new one replaces it (atomic exchange where the file system has it).
#pragma once
#include <string>

namespace svbrdf {

class OutputFolder {
 public:
  // Creates the empty temporary folder (and the destination's parent).
  // Throws Error when `final_path` exists but is not a folder, or cannot be created.
  explicit OutputFolder(const std::string& final_path);
  // Not committed: removes the temporary folder and everything in it.
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  // Where to write (the temporary folder) until Commit().
  const std::string& path() const { return tmp_; }
  const std::string& final_path() const { return final_; }
  // Replaces `final_path` by the temporary folder; the previous result (if
  // any) is removed only after the new one is in place. Throws Error on failure
  // (the previous result is then kept). Idempotent.
  void Commit();

 private:
  std::string final_, tmp_;
  bool committed_ = false;
};

// Makes SIGINT and SIGTERM remove every uncommitted OutputFolder before the
// process ends with that signal. Call first thing in main(), before any
// thread exists: it blocks both signals in the calling thread (so in every
// thread created later) and hands them to one watcher thread.
void RemoveOutputsOnSignal();

}  // namespace svbrdf
