// A minimal XML element tree and writer (for Mitsuba scene files): elements
// with ordered attributes, children and comments; text is escaped.
#pragma once
#include <string>
#include <utility>
#include <vector>

namespace svbrdf {

struct XmlElement {
  std::string tag;
  std::vector<std::pair<std::string, std::string>> attributes;
  std::vector<XmlElement> children;
  std::string comment;  // written as <!-- comment --> before the element when not empty

  explicit XmlElement(std::string t) : tag(std::move(t)) {}
  XmlElement& Attr(const std::string& name, const std::string& value) {
    attributes.emplace_back(name, value);
    return *this;
  }
  XmlElement& Add(XmlElement child) {
    children.push_back(std::move(child));
    return children.back();
  }
  XmlElement& Comment(std::string c) {
    comment = std::move(c);
    return *this;
  }
  std::string ToString(int indent = 0) const;
};

// Shortest decimal text that reads back as the same double.
std::string XmlNumber(double v);

}  // namespace svbrdf
