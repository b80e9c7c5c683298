#include "export/xml.h"

#include <charconv>

namespace svbrdf {

std::string XmlEscape(const std::string& text) {
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
  for (const auto& [k, v] : attributes) out += " " + k + "=\"" + XmlEscape(v) + "\"";
  if (children.empty()) return out + "/>\n";
  out += ">\n";
  for (const XmlElement& c : children) out += c.ToString(indent + 2);
  return out + pad + "</" + tag + ">\n";
}

}  // namespace svbrdf
