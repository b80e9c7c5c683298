#include <cstdio>
#include <memory>

#include "apps/svbrdf/commands.h"
#include "calib/intrinsics.h"
#include "core/error.h"
#include "io/output_folder.h"

namespace svbrdf::cli {

void RegisterCalibrate(CLI::App& app, Runner* run) {
  struct Args {
    std::string pattern = "chessboard", corners = "9x6", model = "OPENCV", dictionary = "DICT_4X4_50", out;
    std::string layout = "new";
    double square = 0.025, marker = 0;
    double reject_factor = 4.0;
    std::vector<std::string> images;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand(
      "calibrate",
      "Camera intrinsics from photos of a calibration board (OpenCV). Writes DIR/cameras.txt\n"
      "(COLMAP text format and pixel convention), DIR/calibration.json (RMS, per-view errors,\n"
      "rejected views and why, board poses), DIR/corners.png and DIR/residuals.png.\n"
      "Example: svbrdf calibrate --pattern chessboard --corners 9x6 --square 0.025 --out calib left*.jpg");
  c->add_option("--pattern", a->pattern, "chessboard | charuco | circles");
  c->add_option("--corners", a->corners,
                "COLSxROWS: inner corners (chessboard), circle centres (circles) or squares (charuco)");
  c->add_option("--square", a->square, "square side (circle spacing) in metres");
  c->add_option("--marker", a->marker, "charuco: marker side in metres (default 0.7 x square)");
  c->add_option("--dictionary", a->dictionary, "charuco: ArUco dictionary, e.g. DICT_4X4_50");
  c->add_option("--charuco-layout", a->layout,
                "charuco: new (OpenCV >= 4.6) | legacy (older OpenCV, or setLegacyPattern(true));\n"
                "they differ for an even number of rows (legacy: a marker in the top-left square)")
      ->check(CLI::IsMember({"new", "legacy"}));
  c->add_option("--model", a->model, "SIMPLE_PINHOLE | PINHOLE | SIMPLE_RADIAL | RADIAL | OPENCV");
  c->add_option("--reject-factor", a->reject_factor, "reject views with RMS above this x the median RMS");
  c->add_option("--out", a->out, "output folder")->required();
  c->add_option("images", a->images, "photos of the board")->required();
  c->callback([a, run] {
    *run = [a] {
      CalibrateOptions o;
      o.board.pattern = BoardPatternFromName(a->pattern);
      ParseColsRows(a->corners, &o.board.cols, &o.board.rows, "--corners");
      o.board.square = a->square;
      o.board.marker = a->marker;
      o.board.dictionary = a->dictionary;
      o.board.legacy_layout = a->layout == "legacy";
      o.model = CameraModelFromName(a->model, "--model");
      o.reject_factor = a->reject_factor;
      const CalibrationResult r = CalibrateIntrinsics(a->images, o);
      OutputFolder out(a->out);  // complete or absent, also on errors and signals
      WriteCalibration(r, a->images, out.path());
      out.Commit();
      for (const auto& v : r.views)
        std::printf("  %-24s %s\n", v.name.c_str(),
                    v.used ? Msg(v.points.size(), " points, RMS ", v.rms, " px").c_str()
                           : Msg("rejected: ", v.why).c_str());
      std::printf("%s", Msg(CameraModelName(r.camera.model), " camera from ", r.used_views, " of ", r.views.size(),
                            " views: RMS ", r.rms, " px (", r.rms_all_found, " px before rejection)\n", "params:")
                            .c_str());
      for (double p : r.camera.params) std::printf(" %.6g", p);
      std::printf("\nwrote %s/{cameras.txt, calibration.json, corners.png, residuals.png}\n", a->out.c_str());
      return 0;
    };
  });
}

}  // namespace svbrdf::cli
