// A self-contained HTML page (no external files: pictures are embedded as
// base64 data URIs) for reports: headings, text, warnings, tables, figures.
#pragma once
#include <string>
#include <utility>
#include <vector>

namespace svbrdf {

class HtmlPage {
 public:
  explicit HtmlPage(std::string title);
  void Heading(const std::string& text);
  void Paragraph(const std::string& text);
  void Warning(const std::string& text);
  // A row of pictures with captions; each file (PNG/JPEG) is embedded.
  void Figures(const std::vector<std::pair<std::string, std::string>>& files_and_captions, int max_width_px = 320);
  void Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);
  void Preformatted(const std::string& text);
  std::string ToString() const;
  // Writes atomically (temporary name, then rename).
  void Save(const std::string& path) const;

 private:
  std::string title_, body_;
};

std::string Base64(const std::string& bytes);

}  // namespace svbrdf
