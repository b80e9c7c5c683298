#include "evaluate/html.h"

#include <filesystem>

#include "io/files.h"
#include "io/scene.h"

namespace svbrdf {

std::string Base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = (unsigned char)bytes[i] << 16 | (unsigned char)bytes[i + 1] << 8 | (unsigned char)bytes[i + 2];
    out += {k[v >> 18], k[(v >> 12) & 63], k[(v >> 6) & 63], k[v & 63]};
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = (unsigned char)bytes[i] << 16;
    out += {k[v >> 18], k[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == bytes.size()) {
    const unsigned v = (unsigned char)bytes[i] << 16 | (unsigned char)bytes[i + 1] << 8;
    out += {k[v >> 18], k[(v >> 12) & 63], k[(v >> 6) & 63], '='};
  }
  return out;
}

HtmlPage::HtmlPage(std::string title) : title_(std::move(title)) {}

void HtmlPage::Heading(const std::string& text) { body_ += "<h2>" + MarkupEscape(text) + "</h2>\n"; }
void HtmlPage::Paragraph(const std::string& text) { body_ += "<p>" + MarkupEscape(text) + "</p>\n"; }
void HtmlPage::Warning(const std::string& text) { body_ += "<p class=\"warn\">&#9888; " + MarkupEscape(text) + "</p>\n"; }
void HtmlPage::Preformatted(const std::string& text) { body_ += "<pre>" + MarkupEscape(text) + "</pre>\n"; }

void HtmlPage::Figures(const std::vector<std::pair<std::string, std::string>>& files, int max_width_px) {
  body_ += "<div class=\"row\">\n";
  for (const auto& [file, caption] : files) {
    std::string ext = std::filesystem::path(file).extension().string();
    const std::string mime = ext == ".jpg" || ext == ".jpeg" ? "image/jpeg" : "image/png";
    body_ += "<figure><img style=\"max-width:" + std::to_string(max_width_px) + "px\" src=\"data:" + mime + ";base64," +
             Base64(ReadFileBytes(file)) + "\" alt=\"" + MarkupEscape(caption) + "\"><figcaption>" + MarkupEscape(caption) +
             "</figcaption></figure>\n";
  }
  body_ += "</div>\n";
}

void HtmlPage::Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
  body_ += "<table><tr>";
  for (const auto& h : header) body_ += "<th>" + MarkupEscape(h) + "</th>";
  body_ += "</tr>\n";
  for (const auto& r : rows) {
    body_ += "<tr>";
    for (const auto& c : r) body_ += "<td>" + MarkupEscape(c) + "</td>";
    body_ += "</tr>\n";
  }
  body_ += "</table>\n";
}

std::string HtmlPage::ToString() const {
  return "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" + MarkupEscape(title_) +
         "</title>\n<style>body{font-family:sans-serif;margin:2em;max-width:1400px}"
         "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:2px 8px;text-align:left;"
         "font-size:90%}.row{display:flex;flex-wrap:wrap;gap:12px}figure{margin:0}"
         "img{image-rendering:pixelated;width:100%}figcaption{font-size:85%;color:#444}.warn{color:#a40}"
         "</style></head><body>\n<h1>" +
         MarkupEscape(title_) + "</h1>\n" + body_ + "</body></html>\n";
}

void HtmlPage::Save(const std::string& path) const { WriteFileAtomic(path, ToString()); }

}  // namespace svbrdf
