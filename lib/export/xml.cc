#include "export/xml.h"

#include "io/files.h"

#include <charconv>

namespace svbrdf {

std::string XmlNumber(double v) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, end);
}

std::string XmlElement::ToString(int indent) const {
  const std::string pad(indent, ' ');
  std::string out;
  if (!comment.empty()) {
    std::string c = comment;
    for (size_t p = c.find("--"); p != std::string::npos; p = c.find("--")) c.replace(p, 2, "- ");
    out += pad + "<!-- " + c + " -->\n";
  }
  out += pad + "<" + tag;
  for (const auto& [k, v] : attributes) out += " " + k + "=\"" + MarkupEscape(v) + "\"";
  if (children.empty()) return out + "/>\n";
  out += ">\n";
  for (const XmlElement& c : children) out += c.ToString(indent + 2);
  return out + pad + "</" + tag + ">\n";
}

}  // namespace svbrdf
