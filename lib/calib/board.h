// Calibration targets: chessboard, ChArUco and symmetric circle grids.
//
// Board frame: origin at the first inner corner (chessboard, circles) or at
// the outer corner of the ChArUco board, x along the columns, y along the
// rows, z = x cross y (into the table for a board seen from above in the
// drawn orientation), in metres. Detected image points use COLMAP's pixel
// convention (centre of the top-left pixel at (0.5, 0.5)): OpenCV's detectors
// report (0, 0) for that centre, so 0.5 is added once, here, and every later
// stage (intrinsics, PnP, bundle adjustment) stays in COLMAP's convention.
#pragma once
#include <string>
#include <vector>

#include "core/types.h"
#include "io/image.h"

namespace svbrdf {

enum class BoardPattern { kChessboard, kCharuco, kCircles };

// Parameters (name, meaning, range):
//   pattern   chessboard | charuco | circles
//   cols,rows chessboard/circles: inner corners (circle centres) per row and
//             column, >= 2 (OpenCV's left01..14.jpg: 9 x 6);
//             charuco: squares per row and column, >= 3
//   square    side of one square (circle spacing), metres, > 0
//   marker    charuco: marker side, metres, in (0, square)
//   dictionary charuco: OpenCV predefined dictionary name (DICT_4X4_50, ...)
//   legacy_layout charuco: the layout of OpenCV before 4.6 (and of boards
//             printed with its `setLegacyPattern(true)`), which differs from
//             today's only for an even number of rows: its top-left square
//             holds a marker, today's is black. Marker ids run row by row
//             from the top left in both.
struct BoardSpec {
  BoardPattern pattern = BoardPattern::kChessboard;
  int cols = 9, rows = 6;
  double square = 0.025;
  double marker = 0.0;  // 0: 0.7 * square
  std::string dictionary = "DICT_4X4_50";
  bool legacy_layout = false;

  void Check() const;
  double MarkerSide() const { return marker > 0 ? marker : 0.7 * square; }
  // Board-frame coordinates of every point a detection can report; the ids
  // of a detection index this list.
  std::vector<Vec3> ObjectPoints() const;
};

BoardPattern BoardPatternFromName(const std::string& name);  // throws Error
std::string BoardPatternName(BoardPattern p);
// "9x6" -> (9, 6); throws Error naming the option otherwise.
void ParseColsRows(const std::string& text, int* cols, int* rows, const std::string& context);

struct BoardDetection {
  bool found = false;
  std::string why;               // why not found (empty when found)
  std::vector<Vec2> points;      // COLMAP pixel convention
  std::vector<int> ids;          // index into BoardSpec::ObjectPoints()
};

// Finds the board in an image (any channel count, any value range: it is
// tone-mapped to 8 bits for the detectors) and refines the points to
// sub-pixel accuracy.
BoardDetection DetectBoard(const Image& image, const BoardSpec& board);

// The printed board as an image (1 channel, values 0 black .. 1 white) at
// `pixels_per_square`, and the affine map from board-frame (x, y) metres to
// texture pixel coordinates (COLMAP convention), measured by detecting the
// board in its own drawing so that it matches the detector's conventions.
struct BoardTexture {
  Image image;
  Eigen::Matrix<double, 2, 3> texture_from_board;
  // White quiet zone drawn around the pattern, pixels on each side: how far
  // the printed paper reaches beyond the pattern is not known.
  int quiet_zone_px = 0;
};
BoardTexture DrawBoard(const BoardSpec& board, int pixels_per_square);

// The ChArUco board of `synth-raw` and its tests: 11x8 squares of 3.5 cm,
// 2.6 cm markers (38.5 x 28 cm, A3). 70 inner corners: with the 6x5 board of
// 6 cm (20 corners) a dozen views leave the principal point far less
// certain than here (simulated detection noise).
BoardSpec DefaultRawBoard();

// 8-bit grey tone mapping used for detection and pictures: scaled so that the
// 99th percentile is white, then sRGB-like gamma for linear input.
Image ToDisplayGrey(const Image& image, bool linear_input);

}  // namespace svbrdf
