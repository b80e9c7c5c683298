#include "pipeline/report_html.h"

#include <cstdio>
#include <filesystem>

#include "core/error.h"
#include "evaluate/html.h"

namespace svbrdf {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::string Num(double v, const char* fmt = "%.4g") {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

std::string Text(const json& j) { return j.is_string() ? j.get<std::string>() : j.dump(); }

}  // namespace

std::vector<std::string> ReportWarnings(const json& s) {
  std::vector<std::string> w;
  if (s.contains("warnings") && s["warnings"].is_array())
    for (const auto& x : s["warnings"]) w.push_back(Text(x));
  if (s.contains("samples")) {
    const double kept = s["samples"].value("kept", 0.0), cand = s["samples"].value("candidates", 0.0);
    if (cand > 0 && kept < 0.1 * cand)
      w.push_back(Msg("only ", Num(100 * kept / cand, "%.1f"), " % of the candidate samples were kept; check masks, exposure and poses"));
    const double sat = s["samples"].value("saturated", 0.0);
    if (cand > 0 && sat > 0.05 * cand)
      w.push_back(Msg(Num(100 * sat / cand, "%.1f"), " % of the candidate samples were saturated; lower the exposure"));
  }
  if (s.contains("twin") && s["twin"].value("psnr_srgb", 100.0) < 30)
    w.push_back(Msg("the ", s["twin"].value("kind", std::string("view")), " relit at only ",
                    Num(s["twin"].value("psnr_srgb", 0.0), "%.1f"), " dB PSNR"));
  if (s.value("clusters", 0) == 1) w.push_back("one basis material only: the capture may have too few photos for a split");
  return w;
}

void WriteReportHtml(const json& s, const std::string& dir) {
  HtmlPage page("svbrdf reconstruction report");
  page.Paragraph(Msg("capture: ", s.value("scene", std::string("?")), "; ", s.value("texels", 0), " texels (",
                     s.value("texture_size", 0), " px atlas), ", s.value("clusters", 0), " basis materials, weights ",
                     s.value("weights", std::string("?")), ", held-out sample RMSE ", Num(s.value("heldout_rmse", 0.0))));
  const std::vector<std::string> warnings = ReportWarnings(s);
  page.Heading("Warnings");
  if (warnings.empty()) page.Paragraph("none");
  for (const auto& w : warnings) page.Warning(w);

  auto file = [&](const std::string& name) { return (fs::path(dir) / name).string(); };
  if (s.contains("twin")) {
    const json& t = s["twin"];
    page.Heading("Photo vs relit");
    const std::string tag = fs::exists(file("heldout_photo.png")) ? "heldout" : "input";
    std::vector<std::pair<std::string, std::string>> figs;
    for (const auto& [suffix, caption] : {std::pair<std::string, std::string>{"_photo.png", "photo"},
                                          {"_relit.png", "relit"}, {"_error.png", "|error| (5 % of exposure = top of ramp)"}})
      if (fs::exists(file(tag + suffix))) figs.push_back({file(tag + suffix), caption});
    page.Figures(figs);
    page.Paragraph(Msg(t.value("kind", std::string("view")), " ", t.value("view", std::string()), ": PSNR (sRGB) ",
                       Num(t.value("psnr_srgb", 0.0), "%.2f"), " dB, relative RMSE (linear) ",
                       Num(t.value("rel_rmse_linear", 0.0), "%.4f"), " (relight: ",
                       t.value("relight", std::string("pixel centre")), ", as `svbrdf relight` and `svbrdf evaluate`)"));
  }
  page.Heading("Maps");
  std::vector<std::pair<std::string, std::string>> maps;
  if (fs::exists(file("cluster_map.png"))) maps.push_back({file("cluster_map.png"), "cluster map (basis with the largest weight)"});
  for (int k = 0; fs::exists(file(Msg("weights_m", k, ".png"))); ++k)
    maps.push_back({file(Msg("weights_m", k, ".png")), Msg("weights of m", k, " (RGB = per-channel weight)")});
  if (fs::exists(file("confidence.png"))) maps.push_back({file("confidence.png"), "confidence (0 .. 1)"});
  if (fs::exists(file("residual.png"))) maps.push_back({file("residual.png"), "per-texel fit residual"});
  page.Figures(maps, 256);
  if (s.contains("texels_without_samples"))
    page.Paragraph(Msg(s.value("texels_without_samples", 0), " texels no photo saw; ",
                       s.value("texels_filled_from_neighbours", 0),
                       " of them got their weights from their neighbours on the surface (low confidence)."));

  page.Heading("Basis materials");
  std::vector<std::vector<std::string>> rows;
  if (s.contains("basis"))
    for (const auto& b : s["basis"]) {
      std::string params;
      if (b.contains("params"))
        for (const auto& [k, v] : b["params"].items()) params += k + " = " + (v.is_number() ? Num(v.get<double>()) : Text(v)) + ", ";
      if (params.size() >= 2) params.resize(params.size() - 2);
      rows.push_back({b.value("name", std::string()), b.value("label", b.value("model", std::string())), params});
    }
  page.Table({"name", "model", "parameters"}, rows);
  if (s.contains("model_selection")) {
    rows.clear();
    for (const auto& m : s["model_selection"])
      rows.push_back({Text(m["cluster"]), Text(m["model"]), Num(m.value("heldout_rmse", 0.0)), Text(m["params"]),
                      m.value("chosen", false) ? "chosen" : ""});
    page.Paragraph("Model selection (fewest parameters within 1 % of the best held-out error):");
    page.Table({"cluster", "model", "held-out RMSE", "parameters", ""}, rows);
  }
  if (s.contains("cluster_history")) {
    rows.clear();
    for (const auto& h : s["cluster_history"])
      rows.push_back({Text(h["clusters"]), Num(h.value("train_rmse", 0.0)), Num(h.value("heldout_rmse", 0.0)),
                      h.value("accepted", false) ? "yes" : "no"});
    page.Paragraph("Progressive clustering:");
    page.Table({"clusters", "train RMSE", "held-out RMSE", "split kept"}, rows);
  }
  if (s.contains("pruned_materials") && !s["pruned_materials"].empty()) {
    rows.clear();
    for (const auto& p : s["pruned_materials"])
      rows.push_back({Text(p["model"]), Text(p["texels"]), Num(100 * p.value("heldout_drop", 0.0), "%.1f"),
                      Num(p.value("z", 0.0), "%.1f")});
    page.Paragraph("Materials removed after the split search (the others, mixed by the weights, explain them):");
    page.Table({"model", "texels", "held-out error drop it brought (%)", "z"}, rows);
  }
  page.Heading("Samples");
  rows.clear();
  if (s.contains("samples"))
    for (const auto& [k, v] : s["samples"].items()) rows.push_back({k, Text(v)});
  page.Table({"count", "value"}, rows);
  page.Heading("Timings");
  rows.clear();
  if (s.contains("timings_s"))
    for (const auto& [k, v] : s["timings_s"].items()) rows.push_back({k, Num(v.get<double>(), "%.2f")});
  rows.push_back({"total", Num(s.value("total_s", 0.0), "%.2f")});
  rows.push_back({"peak memory (MB)", Num(s.value("peak_memory_mb", 0.0), "%.0f")});
  page.Table({"stage", "seconds"}, rows);
  page.Save((fs::path(dir) / "report.html").string());
}

void AddStageTimes(const StageTimer& timer, nlohmann::json* summary) {
  nlohmann::json wall = nlohmann::json::object(), cpu = nlohmann::json::object();
  for (const auto& st : timer.stages()) {
    wall[st.name] = wall.value(st.name, 0.0) + st.seconds;
    cpu[st.name] = cpu.value(st.name, 0.0) + st.cpu_seconds;
  }
  (*summary)["timings_s"] = wall;
  (*summary)["cpu_s"] = cpu;
}

}  // namespace svbrdf
