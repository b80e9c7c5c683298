// One exception type for every user-facing failure. Messages name the file,
// field or view at fault; the CLI prints them and exits non-zero.
#pragma once
#include <sstream>
#include <stdexcept>
#include <string>

namespace svbrdf {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

// Builds a message from streamable parts: throw Error(Msg(file, ": field '", f, "' ..."))
template <class... Args>
std::string Msg(const Args&... args) {
  std::ostringstream os;
  (os << ... << args);
  return os.str();
}

}  // namespace svbrdf
