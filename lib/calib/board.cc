#include "calib/board.h"

#include <algorithm>
#include <cmath>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/cv_bridge.h"
#include "core/error.h"

namespace svbrdf {

BoardPattern BoardPatternFromName(const std::string& name) {
  if (name == "chessboard") return BoardPattern::kChessboard;
  if (name == "charuco") return BoardPattern::kCharuco;
  if (name == "circles") return BoardPattern::kCircles;
  throw Error(Msg("board pattern '", name, "' unknown; expected chessboard, charuco or circles"));
}

std::string BoardPatternName(BoardPattern p) {
  switch (p) {
    case BoardPattern::kChessboard: return "chessboard";
    case BoardPattern::kCharuco: return "charuco";
    case BoardPattern::kCircles: return "circles";
  }
  return "?";
}

void ParseColsRows(const std::string& text, int* cols, int* rows, const std::string& context) {
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", cols, &x, rows, &extra) != 3 || (x != 'x' && x != 'X'))
    throw Error(Msg(context, ": expected COLSxROWS (e.g. 9x6), got '", text, "'"));
}

namespace {

cv::Ptr<cv::aruco::Dictionary> DictionaryByName(const std::string& name) {
  static const std::pair<const char*, cv::aruco::PREDEFINED_DICTIONARY_NAME> kNames[] = {
      {"DICT_4X4_50", cv::aruco::DICT_4X4_50},     {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
      {"DICT_4X4_250", cv::aruco::DICT_4X4_250},   {"DICT_5X5_50", cv::aruco::DICT_5X5_50},
      {"DICT_5X5_100", cv::aruco::DICT_5X5_100},   {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
      {"DICT_6X6_50", cv::aruco::DICT_6X6_50},     {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
      {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL}};
  for (const auto& [n, id] : kNames)
    if (name == n) return cv::aruco::getPredefinedDictionary(id);
  throw Error(Msg("board dictionary '", name, "' unknown; expected e.g. DICT_4X4_50, DICT_5X5_100, DICT_6X6_250"));
}

// Debian's OpenCV 4.6 builds today's layout only (black top-left square).
// The legacy layout (marker in the top-left square when the row count is
// even) is built from it: same inner corners, markers moved to the other
// squares, ids again row by row, and the corner-to-marker neighbourhoods
// recomputed the way OpenCV's CharucoBoard::create does.
cv::Ptr<cv::aruco::CharucoBoard> MakeCharuco(const BoardSpec& b) {
  auto cb = cv::aruco::CharucoBoard::create(b.cols, b.rows, float(b.square), float(b.MarkerSide()),
                                            DictionaryByName(b.dictionary));
  if (!b.legacy_layout || b.rows % 2 == 1) return cb;
  const float sq = float(b.square), m = float(b.MarkerSide()), d = 0.5f * (sq - m);
  std::vector<std::vector<cv::Point3f>> obj;
  for (int r = 0; r < b.rows; ++r)
    for (int c = 0; c < b.cols; ++c) {
      if ((r + c) % 2 != 0) continue;  // legacy, even rows: markers where row + column is even
      const float x = c * sq + d, y = r * sq + d;
      obj.push_back({{x, y, 0}, {x + m, y, 0}, {x + m, y + m, 0}, {x, y + m, 0}});  // OpenCV's corner order
    }
  cb->objPoints = obj;
  cb->ids.resize(obj.size());
  for (size_t i = 0; i < obj.size(); ++i) cb->ids[i] = int(i);
  cb->nearestMarkerIdx.assign(cb->chessboardCorners.size(), {});
  cb->nearestMarkerCorners.assign(cb->chessboardCorners.size(), {});
  const double tie = std::pow(0.01 * sq, 2);
  for (size_t i = 0; i < cb->chessboardCorners.size(); ++i) {
    const cv::Point3f corner = cb->chessboardCorners[i];
    double best = -1;
    auto& near = cb->nearestMarkerIdx[i];
    for (size_t j = 0; j < obj.size(); ++j) {
      const cv::Point3f centre = 0.25f * (obj[j][0] + obj[j][1] + obj[j][2] + obj[j][3]);
      const double dist = std::pow(double(centre.x - corner.x), 2) + std::pow(double(centre.y - corner.y), 2);
      if (best < 0 || std::abs(dist - best) < tie) {
        near.push_back(int(j));
        if (best < 0 || dist < best) best = dist;
      } else if (dist < best) {
        near.assign(1, int(j));
        best = dist;
      }
    }
    for (int j : near) {
      int nearest = 0;
      double nd = 1e30;
      for (int k = 0; k < 4; ++k) {
        const double dk = cv::norm(obj[j][k] - corner);
        if (dk < nd) nd = dk, nearest = k;
      }
      cb->nearestMarkerCorners[i].push_back(nearest);
    }
  }
  return cb;
}

// The printed ChArUco board: black squares where no marker sits, markers in
// the others (OpenCV's own drawing knows today's layout only).
cv::Mat DrawCharuco(const BoardSpec& b, int pps) {
  const auto cb = MakeCharuco(b);
  cv::Mat img(cv::Size(b.cols * pps, b.rows * pps), CV_8U, cv::Scalar(255));
  const double to_px = pps / b.square;
  std::vector<bool> has_marker(size_t(b.cols * b.rows), false);
  for (size_t j = 0; j < cb->objPoints.size(); ++j) {
    const cv::Point3f& tl = cb->objPoints[j][0];
    const int c = int(tl.x / b.square), r = int(tl.y / b.square);
    has_marker[size_t(r * b.cols + c)] = true;
    const int side = int(std::lround(b.MarkerSide() * to_px));
    cv::Mat marker;
    cb->dictionary->drawMarker(cb->ids[j], side, marker, 1);
    marker.copyTo(img(cv::Rect(int(std::lround(tl.x * to_px)), int(std::lround(tl.y * to_px)), side, side)));
  }
  for (int r = 0; r < b.rows; ++r)
    for (int c = 0; c < b.cols; ++c)
      if (!has_marker[size_t(r * b.cols + c)]) img(cv::Rect(c * pps, r * pps, pps, pps)).setTo(0);
  return img;
}

}  // namespace

void BoardSpec::Check() const {
  const int min_n = pattern == BoardPattern::kCharuco ? 3 : 2;
  if (cols < min_n || rows < min_n || cols > 200 || rows > 200)
    throw Error(Msg("board: ", cols, "x", rows, " is not a valid size for ", BoardPatternName(pattern),
                    " (each at least ", min_n, ")"));
  if (!(square > 0)) throw Error("board: square size must be > 0 metres");
  if (pattern == BoardPattern::kCharuco) {
    if (!(MarkerSide() < square)) throw Error("board: marker side must be smaller than the square");
    const int markers = cols * rows / 2;
    if (DictionaryByName(dictionary)->bytesList.rows < markers)
      throw Error(Msg("board: dictionary ", dictionary, " has fewer than the ", markers, " markers needed"));
  }
}

std::vector<Vec3> BoardSpec::ObjectPoints() const {
  std::vector<Vec3> pts;
  if (pattern == BoardPattern::kCharuco) {
    const auto cb = MakeCharuco(*this);  // keep the board alive while iterating its corners
    for (const cv::Point3f& p : cb->chessboardCorners) pts.emplace_back(p.x, p.y, p.z);
    return pts;
  }
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) pts.emplace_back(i * square, j * square, 0.0);
  return pts;
}

Image ToDisplayGrey(const Image& image, bool linear_input) {
  Image grey(image.width, image.height, 1);
  const int nc = image.channels;
  for (size_t p = 0; p < grey.pixels.size(); ++p) {
    double s = 0;
    for (int c = 0; c < std::min(nc, 3); ++c) s += image.pixels[p * nc + c];
    grey.pixels[p] = float(s / std::min(nc, 3));
  }
  std::vector<float> sorted = grey.pixels;
  const size_t k = std::min(sorted.size() - 1, size_t(0.99 * sorted.size()));
  std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
  const float scale = sorted[k] > 0 ? 1.0f / sorted[k] : 1.0f;
  for (float& v : grey.pixels) {
    v = std::clamp(v * scale, 0.0f, 1.0f);
    if (linear_input) v = LinearToSrgb(v);
  }
  return grey;
}

BoardDetection DetectBoard(const Image& image, const BoardSpec& board) {
  board.Check();
  BoardDetection det;
  const cv::Mat grey = ToCv8(ToDisplayGrey(image, IsHighDynamicRange(image)));
  std::vector<cv::Point2f> pts;
  std::vector<int> ids;
  if (board.pattern == BoardPattern::kChessboard) {
    const cv::Size size(board.cols, board.rows);
    if (!cv::findChessboardCorners(grey, size, pts, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
      det.why = Msg("no ", board.cols, "x", board.rows, " chessboard found");
      return det;
    }
    // Refinement window: OpenCV's sample uses 11 x 11 on 640 x 480; keep it
    // inside one square for small or distant boards.
    double spacing = 1e9;
    for (int j = 0; j < board.rows; ++j)
      for (int i = 0; i + 1 < board.cols; ++i)
        spacing = std::min<double>(spacing, cv::norm(pts[j * board.cols + i + 1] - pts[j * board.cols + i]));
    const int win = std::clamp(int(spacing * 0.4), 2, 11);
    cv::cornerSubPix(grey, pts, cv::Size(win, win), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 1e-4));
    for (size_t i = 0; i < pts.size(); ++i) ids.push_back(int(i));
  } else if (board.pattern == BoardPattern::kCircles) {
    if (!cv::findCirclesGrid(grey, cv::Size(board.cols, board.rows), pts, cv::CALIB_CB_SYMMETRIC_GRID)) {
      det.why = Msg("no ", board.cols, "x", board.rows, " circle grid found");
      return det;
    }
    for (size_t i = 0; i < pts.size(); ++i) ids.push_back(int(i));
  } else {
    const auto cb = MakeCharuco(board);
    std::vector<std::vector<cv::Point2f>> marker_corners;
    std::vector<int> marker_ids;
    auto params = cv::aruco::DetectorParameters::create();
    params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
    cv::aruco::detectMarkers(grey, cb->dictionary, marker_corners, marker_ids, params);
    if (marker_ids.size() < 2) {
      det.why = Msg("only ", marker_ids.size(), " ArUco markers of ", board.dictionary, " found");
      return det;
    }
    cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, grey, cb, pts, ids);
    if (pts.size() < 6) {
      det.why = Msg("only ", pts.size(), " ChArUco corners found (need 6)");
      return det;
    }
    // interpolateCornersCharuco's own refinement leaves a sub-pixel bias; refine
    // again with a window small enough to stay clear of the markers (their
    // edges are 0.15 squares from the corner for the default marker size).
    double spacing = 1e9;
    for (size_t i = 0; i < pts.size(); ++i)
      for (size_t j = i + 1; j < pts.size(); ++j) spacing = std::min<double>(spacing, cv::norm(pts[i] - pts[j]));
    const int win = std::clamp(int(spacing * 0.12), 2, 11);
    cv::cornerSubPix(grey, pts, cv::Size(win, win), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4));
  }
  det.found = true;
  for (size_t i = 0; i < pts.size(); ++i) {
    det.points.emplace_back(pts[i].x + 0.5, pts[i].y + 0.5);  // OpenCV -> COLMAP pixel convention
    det.ids.push_back(ids[i]);
  }
  return det;
}

namespace {

// The printed pattern at `pps` pixels a square, with a white quiet zone of
// one square all round.
cv::Mat DrawPattern(const BoardSpec& board, int pps) {
  cv::Mat img;
  if (board.pattern == BoardPattern::kCharuco) {
    if (board.legacy_layout)
      img = DrawCharuco(board, pps);
    else
      MakeCharuco(board)->draw(cv::Size(board.cols * pps, board.rows * pps), img, 0, 1);
  } else {
    // (cols+1) x (rows+1) squares for cols x rows inner corners; circles on white.
    img = cv::Mat(cv::Size((board.cols + 1) * pps, (board.rows + 1) * pps), CV_8U, cv::Scalar(255));
    for (int j = 0; j <= board.rows; ++j)
      for (int i = 0; i <= board.cols; ++i) {
        if (board.pattern == BoardPattern::kChessboard) {
          if ((i + j) % 2 == 0) img(cv::Rect(i * pps, j * pps, pps, pps)).setTo(0);
        } else if (i < board.cols && j < board.rows) {
          cv::circle(img, cv::Point((i + 1) * pps * 16 - 8, (j + 1) * pps * 16 - 8), int(0.3 * pps * 16), cv::Scalar(0),
                     cv::FILLED, cv::LINE_AA, 4);
        }
      }
  }
  cv::copyMakeBorder(img, img, pps, pps, pps, pps, cv::BORDER_CONSTANT, cv::Scalar(255));
  return img;
}

}  // namespace

BoardTexture DrawBoard(const BoardSpec& board, int pps) {
  board.Check();
  if (pps < 8) throw Error("DrawBoard: pixels_per_square must be >= 8");
  BoardTexture out;
  out.image = FromCv(DrawPattern(board, pps));
  out.quiet_zone_px = pps;
  // The map from board to texture follows the detector's conventions (which
  // corner is the origin, axis directions): fitted to the board's detection
  // in its own drawing. ArUco's detector misses markers of sharp synthetic
  // drawings at some scales (wide markers at 48 px a square and up), so the
  // drawing is detected at the first scale that works; the map scales with
  // it exactly (pixel edges at integers).
  BoardDetection det;
  int detect_pps = 0;
  for (int p : {pps, 40, 32, 48, 24, 64}) {
    det = DetectBoard(p == pps ? out.image : FromCv(DrawPattern(board, p)), board);
    if (det.found) {
      detect_pps = p;
      break;
    }
  }
  if (!det.found) throw Error(Msg("DrawBoard: the drawn board is not detected (", det.why, ")"));
  const std::vector<Vec3> obj = board.ObjectPoints();
  Eigen::MatrixXd A(det.points.size(), 3);
  Eigen::MatrixXd b(det.points.size(), 2);
  for (size_t i = 0; i < det.points.size(); ++i) {
    A.row(i) << obj[det.ids[i]].x(), obj[det.ids[i]].y(), 1.0;
    b.row(i) = det.points[i].transpose();
  }
  out.texture_from_board = (double(pps) / detect_pps) * A.colPivHouseholderQr().solve(b).transpose();
  // The drawing is exact: squares are `pps` pixels and axes are aligned, so
  // snap the measured map to that (removes the detector's sub-pixel noise).
  const double unit = pps / board.square;
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 2; ++c) out.texture_from_board(r, c) = unit * std::round(out.texture_from_board(r, c) / unit);
    out.texture_from_board(r, 2) = std::round(out.texture_from_board(r, 2));
  }
  return out;
}

BoardSpec DefaultRawBoard() {
  BoardSpec b;
  b.pattern = BoardPattern::kCharuco;
  b.cols = 11;
  b.rows = 8;
  b.square = 0.035;
  b.marker = 0.026;
  return b;
}

}  // namespace svbrdf
