// Atomic file writing shared by every writer in io/: write to a temporary
// sibling, then rename, so a reader (or a crash) never sees half a file.
#pragma once
#include <string>

namespace svbrdf {

// "<path>.tmp-<pid>.<ext>": same folder (rename stays on one file system) and
// same extension (OpenImageIO picks the format from it).
std::string TempSiblingPath(const std::string& path);
// Renames `tmp` over `path`; on failure removes `tmp` and throws Error.
void CommitTemp(const std::string& tmp, const std::string& path);
// Whole file as bytes; throws Error naming the file.
std::string ReadFileBytes(const std::string& path);
// Escapes & < > " for XML and HTML text and attribute values.
std::string MarkupEscape(const std::string& text);

}  // namespace svbrdf
