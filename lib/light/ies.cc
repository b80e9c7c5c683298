// IESNA LM-63 photometric files (type C photometry).
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "light/light.h"

namespace svbrdf {
namespace {

// Reads the whitespace- or comma-separated numbers after TILT=NONE, naming
// what each one is when it is missing or not a number.
class NumberReader {
 public:
  NumberReader(const std::string& text, const std::string& context) : context_(context) {
    std::string clean = text;
    std::replace(clean.begin(), clean.end(), ',', ' ');  // some writers separate with commas
    std::istringstream in(clean);
    std::string token;
    while (in >> token) tokens_.push_back(token);
  }
  double Next(const std::string& what) {
    if (pos_ >= tokens_.size()) throw Error(Msg(context_, ": file truncated: missing ", what));
    const std::string& t = tokens_[pos_++];
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(t.c_str(), &end);
    if (end == t.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
      throw Error(Msg(context_, ": ", what, ": expected a number, got '", t, "'"));
    return v;
  }
  int NextCount(const std::string& what, int min_value) {
    const double v = Next(what);
    if (v != std::floor(v) || v < min_value || v > 1e6)
      throw Error(Msg(context_, ": ", what, ": expected an integer >= ", min_value, ", got ", v));
    return static_cast<int>(v);
  }
  std::vector<double> NextAscending(int n, const std::string& what) {
    std::vector<double> out(n);
    for (int i = 0; i < n; ++i) {
      out[i] = Next(Msg(what, " ", i + 1, " of ", n));
      if (i > 0 && !(out[i] > out[i - 1])) throw Error(Msg(context_, ": ", what, " are not strictly ascending"));
    }
    return out;
  }
  size_t Remaining() const { return tokens_.size() - pos_; }

 private:
  std::string context_;
  std::vector<std::string> tokens_;
  size_t pos_ = 0;
};

// Index i and weight t with x in [xs[i], xs[i+1]]; xs ascending, x clamped.
void Bracket(const std::vector<double>& xs, double x, int* i, double* t) {
  if (xs.size() == 1 || x <= xs.front()) {
    *i = 0;
    *t = 0;
    return;
  }
  if (x >= xs.back()) {
    *i = static_cast<int>(xs.size()) - 2;
    *t = 1;
    return;
  }
  *i = static_cast<int>(std::upper_bound(xs.begin(), xs.end(), x) - xs.begin()) - 1;
  *t = (x - xs[*i]) / (xs[*i + 1] - xs[*i]);
}

// Folds a horizontal angle (degrees, [0, 360)) into the range the table
// covers, using LM-63's symmetry conventions for type C photometry.
double FoldHorizontal(double h, const std::vector<double>& hs) {
  const double first = hs.front(), last = hs.back();
  if (hs.size() == 1) return first;                      // rotationally symmetric
  if (first == 0 && last == 90) {                        // symmetric in each quadrant
    if (h > 180) h = 360 - h;
    return h > 90 ? 180 - h : h;
  }
  if (first == 0 && last == 180) return h > 180 ? 360 - h : h;  // symmetric about the 0-180 plane
  if (first == 90 && last == 270) {                      // symmetric about the 90-270 plane
    if (h < 90) return 180 - h;
    if (h > 270) return 540 - h;
  }
  return h;
}

}  // namespace

IesProfile ParseIes(const std::string& text, const std::string& context) {
  // Header: optional "IESNA:LM-63-..." line and [KEYWORD] lines (or free text
  // in LM-63-1986), up to the TILT= line.
  std::istringstream in(text);
  std::string line;
  bool found_tilt = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t start = line.find_first_not_of(" \t");
    if (start == std::string::npos || line.compare(start, 5, "TILT=") != 0) continue;
    std::string tilt = line.substr(start + 5);
    tilt.erase(tilt.find_last_not_of(" \t") + 1);
    if (tilt != "NONE")
      throw Error(Msg(context, ": TILT=", tilt, " is not supported (only TILT=NONE; tilt tables are not implemented)"));
    found_tilt = true;
    break;
  }
  if (!found_tilt) throw Error(Msg(context, ": not an IESNA LM-63 file: no TILT= line"));
  std::string rest((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  NumberReader r(rest, context);

  r.NextCount("number of lamps", 1);
  r.Next("lumens per lamp");  // -1 for absolute photometry; not needed for candela
  IesProfile p;
  p.multiplier = r.Next("candela multiplier");
  if (p.multiplier < 0) throw Error(Msg(context, ": candela multiplier ", p.multiplier, " is negative"));
  const int nv = r.NextCount("number of vertical angles", 1);
  const int nh = r.NextCount("number of horizontal angles", 1);
  // 8 more header numbers, the angles and the table must all be there (checked
  // before allocating nv x nh values from two corrupt counts).
  const size_t needed = size_t(8) + nv + nh + size_t(nv) * nh;
  if (r.Remaining() < needed)
    throw Error(Msg(context, ": file truncated: ", nv, " vertical x ", nh, " horizontal angles need ", needed,
                    " more values, found ", r.Remaining()));
  const int type = r.NextCount("photometric type", 1);
  if (type != 1) throw Error(Msg(context, ": photometric type ", type, " is not supported (only type C = 1)"));
  r.Next("units type");
  r.Next("luminous width");
  r.Next("luminous length");
  r.Next("luminous height");
  r.Next("ballast factor");
  r.Next("future use / ballast-lamp factor");
  r.Next("input watts");
  p.vertical_deg = r.NextAscending(nv, "vertical angle");
  p.horizontal_deg = r.NextAscending(nh, "horizontal angle");
  if (p.vertical_deg.front() < 0 || p.vertical_deg.back() > 180)
    throw Error(Msg(context, ": vertical angles must lie in [0, 180]"));
  if (p.horizontal_deg.front() < 0 || p.horizontal_deg.back() > 360)
    throw Error(Msg(context, ": horizontal angles must lie in [0, 360]"));
  p.candela.resize(size_t(nv) * nh);
  for (int h = 0; h < nh; ++h)
    for (int v = 0; v < nv; ++v) {
      const double cd = r.Next("candela value");
      if (cd < 0) throw Error(Msg(context, ": candela value ", h * nv + v + 1, " is negative"));
      p.candela[size_t(h) * nv + v] = cd * p.multiplier;
    }
  if (r.Remaining() != 0)
    throw Error(Msg(context, ": ", r.Remaining(), " extra value(s) after the ", size_t(nv) * nh,
                    " candela values (wrong angle counts?)"));
  return p;
}

IesProfile LoadIes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(Msg(path, ": cannot open IES file"));
  std::ostringstream s;
  s << f.rdbuf();
  return ParseIes(s.str(), path);
}

double IesProfile::Intensity(double vertical_rad, double horizontal_rad) const {
  const double v = vertical_rad * 180.0 / kPi;
  // Outside the vertical range the file says nothing: no light (e.g. a
  // downlight measured over 0-90 emits nothing upwards).
  if (v < vertical_deg.front() - 1e-9 || v > vertical_deg.back() + 1e-9) return 0.0;
  double h = std::fmod(horizontal_rad * 180.0 / kPi, 360.0);
  if (h < 0) h += 360.0;
  h = FoldHorizontal(h, horizontal_deg);
  const int nv = static_cast<int>(vertical_deg.size());
  int iv, ih;
  double tv, th;
  Bracket(vertical_deg, v, &iv, &tv);
  const int iv1 = std::min(iv + 1, nv - 1);
  int ih1;
  if (horizontal_deg.size() > 1 && horizontal_deg.front() == 0 && h > horizontal_deg.back()) {
    // Full-circle table not closed at 360: wrap between the last and first angle.
    ih = static_cast<int>(horizontal_deg.size()) - 1;
    ih1 = 0;
    th = (h - horizontal_deg.back()) / (360.0 - horizontal_deg.back());
  } else {
    Bracket(horizontal_deg, h, &ih, &th);
    ih1 = std::min<int>(ih + 1, horizontal_deg.size() - 1);
  }
  auto cd = [&](int hi, int vi) { return candela[size_t(hi) * nv + vi]; };
  const double a = (1 - tv) * cd(ih, iv) + tv * cd(ih, iv1);
  const double b = (1 - tv) * cd(ih1, iv) + tv * cd(ih1, iv1);
  return (1 - th) * a + th * b;
}

double IesProfile::MaxCandela() const {
  return candela.empty() ? 0.0 : *std::max_element(candela.begin(), candela.end());
}

}  // namespace svbrdf
