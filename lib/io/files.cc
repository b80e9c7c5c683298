#include "io/files.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "io/scene.h"

namespace svbrdf {
namespace fs = std::filesystem;

std::string TempSiblingPath(const std::string& path) {
  return Msg(path, ".tmp-", getpid(), fs::path(path).extension().string());
}

void CommitTemp(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(Msg(path, ": cannot write (rename from temporary file failed: ", ec.message(), ")"));
  }
}

std::string ReadFileBytes(const std::string& path) {
  // A folder opens as an empty stream on Linux: say what it is instead of
  // failing later on "empty" contents.
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    std::string hint;
    for (const char* name : {"scene.json", "material.json"})
      if (fs::exists(fs::path(path) / name, ec)) hint = Msg(" (did you mean ", (fs::path(path) / name).string(), "?)");
    throw Error(Msg(path, ": is a folder, not a file", hint));
  }
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(Msg(path, ": cannot open for reading"));
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

void WriteFileAtomic(const std::string& path, const std::string& contents) {
  const std::string tmp = TempSiblingPath(path);
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw Error(Msg(path, ": cannot open for writing (", tmp, ")"));
    f << contents;
    f.close();
    if (!f) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw Error(Msg(path, ": write failed (disk full?)"));
    }
  }
  CommitTemp(tmp, path);
}

nlohmann::json ReadJsonFile(const std::string& path) {
  const std::string text = ReadFileBytes(path);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is the 1-based position where parsing failed.
    throw Error(Msg(path, ": invalid JSON at byte ", e.byte, ": ", e.what()));
  } catch (const nlohmann::json::exception& e) {
    // e.g. out_of_range for a number too large for a double (1e999).
    throw Error(Msg(path, ": invalid JSON: ", e.what()));
  }
}

std::string MarkupEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace svbrdf
