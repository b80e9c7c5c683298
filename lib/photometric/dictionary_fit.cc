#include "photometric/dictionary_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "brdf/cook_torrance.h"
#include "brdf/fresnel.h"
#include "brdf/model.h"
#include "brdf/oren_nayar.h"
#include "cluster/nnls.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"

namespace svbrdf {

namespace {

void SetParam(BasisMaterial* b, const std::string& name, double value) {
  const std::vector<ParamInfo> info = b->spec.Params();
  for (size_t i = 0; i < info.size(); ++i)
    if (info[i].name == name) {
      b->params[i] = value;
      return;
    }
  throw Error(Msg("internal: model ", b->spec.Label(), " has no parameter ", name));
}

BasisMaterial Make(const std::string& name, const std::string& label) {
  BasisMaterial b;
  b.name = name;
  b.spec = ModelSpec::FromLabel(label);
  b.params = b.spec.InitialParams();
  return b;
}

void SetRgb(BasisMaterial* b, const std::string& prefix, double v) {
  for (const char* c : {"_r", "_g", "_b"}) SetParam(b, prefix + c, v);
}

// Light that enters a dielectric body through its smooth surface, scatters
// diffusely inside and leaves again is weighted by the interface's
// transmittance both ways: (1 - F(cos_i; eta)) (1 - F(cos_o; eta)), which
// falls towards grazing incidence (a plastic, glaze or paint's diffuse is
// darker there than Lambert's). eta <= 1: plain Lambert (factor 1).
double DiffuseThroughInterface(double cos_i, double cos_o, double eta) {
  if (!(eta > 1.0)) return 1.0;
  return (1.0 - brdf::FresnelDielectric(cos_i, eta)) * (1.0 - brdf::FresnelDielectric(cos_o, eta));
}

// The basis BRDFs here are grey (one value for every channel): evaluated
// directly from the model headers, without the per-call parameter unpacking
// of EvalModelD, since the normal search evaluates them millions of times.
class GreyBasis {
 public:
  // diffuse_eta > 1: Lambert atoms are a diffuse body under a smooth
  // interface of that index (DiffuseThroughInterface).
  explicit GreyBasis(const std::vector<BasisMaterial>& basis, double diffuse_eta = 1.0)
      : basis_(basis), diffuse_eta_(diffuse_eta) {
    for (const BasisMaterial& b : basis) {
      Lobe l;
      l.family = b.spec.family;
      const std::vector<ParamInfo> info = b.spec.Params();
      auto param = [&](const std::string& name) {
        for (size_t i = 0; i < info.size(); ++i)
          if (info[i].name == name) return b.params[i];
        return 0.0;
      };
      if (l.family == Family::kOrenNayar) {
        l.on.rd = brdf::RgbT<double>::Constant(param("rd_r"));
        l.on.sigma = param("sigma");
      } else if (l.family == Family::kCookTorrance) {
        l.ct.rd = brdf::RgbT<double>::Constant(param("rd_r"));
        l.ct.rs = brdf::RgbT<double>::Constant(param("rs_r"));
        l.ct.m = param("roughness");
        l.ct.n = param("ior");
        l.ct.distribution = b.spec.distribution;
        l.ct.shadowing = b.spec.shadowing;
        l.ct.fresnel = b.spec.fresnel;
      } else if (l.family == Family::kLambert) {
        l.rd = param("rd_r");
      }
      lobes_.push_back(l);
    }
  }
  int size() const { return int(lobes_.size()); }
  // Writes f_k(wi, wo) * cos(wi) into a (local frame, both above the horizon).
  void Eval(const Vec3& wi, const Vec3& wo, double* a) const {
    for (size_t k = 0; k < lobes_.size(); ++k) {
      const Lobe& l = lobes_[k];
      double f;
      switch (l.family) {
        case Family::kLambert: f = l.rd / kPi * DiffuseThroughInterface(wi.z(), wo.z(), diffuse_eta_); break;
        case Family::kOrenNayar: f = l.on.f(wi, wo)[0]; break;
        case Family::kCookTorrance: f = l.ct.f(wi, wo)[0]; break;
        default: f = EvalModelD(basis_[k].spec, basis_[k].params.data(), wi, wo)[0]; break;
      }
      a[k] = f * wi.z();
    }
  }

 private:
  struct Lobe {
    Family family = Family::kLambert;
    double rd = 1;
    brdf::OrenNayar<double> on{};   // value-initialised: a lobe of another family leaves them unset
    brdf::CookTorrance<double> ct{};
  };
  const std::vector<BasisMaterial>& basis_;
  double diffuse_eta_ = 1.0;
  std::vector<Lobe> lobes_;
};

double Luminance(const float* v) { return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]; }

// The rows of one pixel's least-squares problem, flat (row i's K basis
// values at a[i * K]): the normal search builds millions of them.
struct Rows {
  int K = 0;
  std::vector<double> a;  // weighted basis values
  std::vector<double> b;  // weighted observation
  std::vector<int> light, channel;
  const double* Row(size_t i) const { return &a[i * K]; }
  void Add(const double* row, double scale, double value, int l, int c) {
    for (int k = 0; k < K; ++k) a.push_back(row[k] * scale);
    b.push_back(value), light.push_back(l), channel.push_back(c);
  }
};

double Dot(const double* a, const Eigen::MatrixXd& w, int c, int K) {
  double s = 0;
  for (int k = 0; k < K; ++k) s += a[k] * w(k, c);
  return s;
}

// Which photos a solve uses beyond `use` and the shadow flags.
struct Gates {
  bool min_cos = true;  // leave out grazing light
  bool robust = true;   // refit without outliers
};

Rows BuildRows(const PsObservations& obs, const GreyBasis& basis, long p, const Vec3& n, int channels,
               const std::vector<uint8_t>* use, const uint8_t* shadowed, const DictionaryFitOptions& o, const Gates& g) {
  Rows r;
  r.K = basis.size();
  const Frame fr = Frame::FromNormal(n);
  const Vec3 wo = fr.ToLocal(obs.to_viewer);
  for (int l = 0; l < obs.lights; ++l) {
    if (use && !(*use)[l]) continue;
    if (shadowed && shadowed[l]) continue;
    const size_t i = obs.At(p, l);
    const Vec3 wi = fr.ToLocal(obs.to_light[l]);
    if (g.min_cos && wi.z() < o.min_cos) continue;
    double a[16] = {0};
    if (wi.z() > 0 && wo.z() > 0) basis.Eval(wi, wo, a);
    if (channels == 1) {
      if (!obs.UsableRgb(i)) continue;
      const double sw = std::sqrt((double(obs.weight[i]) * obs.weight[i] + double(obs.weight[i + 1]) * obs.weight[i + 1] +
                                   double(obs.weight[i + 2]) * obs.weight[i + 2]) / 3);
      r.Add(a, sw, Luminance(&obs.value[i]) * sw, l, 0);
    } else {
      for (int c = 0; c < 3; ++c) {
        const double sw = obs.weight[i + c];
        if (sw <= 0) continue;
        r.Add(a, sw, obs.value[i + c] * sw, l, c);
      }
    }
  }
  return r;
}

// NNLS per channel over the rows with keep[i]; residuals into `res`.
PixelSolve Solve(const Rows& r, int K, int channels, const std::vector<char>& keep, std::vector<double>* res,
                 const Eigen::MatrixXd* prior, double prior_rows) {
  PixelSolve s;
  s.w = Eigen::MatrixXd::Zero(K, channels);
  for (int c = 0; c < channels; ++c) {
    Eigen::MatrixXd AtA = Eigen::MatrixXd::Zero(K, K);
    Eigen::VectorXd Atb = Eigen::VectorXd::Zero(K);
    int rows = 0;
    for (size_t i = 0; i < r.b.size(); ++i)
      if (keep[i] && r.channel[i] == c) {
        const double* a = r.Row(i);
        for (int j = 0; j < K; ++j) {
          Atb[j] += r.b[i] * a[j];
          for (int k = 0; k <= j; ++k) AtA(j, k) += a[j] * a[k];
        }
        ++rows;
      }
    if (rows == 0) continue;
    // A weak ridge: neighbouring lobes are nearly collinear over one pixel's
    // photos, and without it they may trade huge opposite weights.
    AtA.diagonal().array() += 1e-4 * AtA.diagonal().mean() + 1e-30;
    if (prior && prior_rows > 0) {
      // Pull towards the object's typical weights, as strong as `prior_rows`
      // average photos: decides what the pixel's own photos leave open.
      const double lambda = prior_rows * AtA.trace() / (K * rows);
      AtA.diagonal().array() += lambda;
      Atb += lambda * prior->col(c);
    }
    s.w.col(c) = NnlsNormal(AtA, Atb);
  }
  res->assign(r.b.size(), 0.0);
  for (size_t i = 0; i < r.b.size(); ++i) {
    (*res)[i] = r.b[i] - Dot(r.Row(i), s.w, r.channel[i], K);
    if (keep[i]) s.sse += (*res)[i] * (*res)[i], s.used += 1;
  }
  return s;
}

PixelSolve SolveRows(const Rows& r, int K, int channels, const DictionaryFitOptions& o, bool robust,
                     std::vector<char>* keep_out = nullptr, const Eigen::MatrixXd* prior = nullptr) {
  std::vector<char> keep(r.b.size(), 1);
  std::vector<double> res;
  PixelSolve s = Solve(r, K, channels, keep, &res, prior, o.prior_rows);
  if (robust && o.outlier_sigmas > 0 && r.b.size() > size_t(4 * K)) {
    std::vector<double> mag(res.size());
    for (size_t i = 0; i < res.size(); ++i) mag[i] = std::abs(res[i]);
    std::nth_element(mag.begin(), mag.begin() + mag.size() / 2, mag.end());
    const double scale = 1.4826 * mag[mag.size() / 2];
    bool any = false;
    for (size_t i = 0; i < res.size(); ++i)
      if (std::abs(res[i]) > o.outlier_sigmas * scale && scale > 0) keep[i] = 0, any = true;
    if (any) s = Solve(r, K, channels, keep, &res, prior, o.prior_rows);
  }
  if (keep_out) *keep_out = keep;
  return s;
}

Vec3 NormalAt(const Image& normals_cam, int pixel, int width) {
  const int x = pixel % width, y = pixel / width;
  return Vec3(normals_cam.at(x, y, 0), normals_cam.at(x, y, 1), normals_cam.at(x, y, 2));
}

const uint8_t* ShadowRow(const std::vector<uint8_t>& shadowed, long p, int lights) {
  return shadowed.empty() ? nullptr : &shadowed[size_t(p) * lights];
}

// Error of predicting each light fold's photos of pixel p from the other
// folds' fit under normal n (photos `use`, null: all the pixel's photos).
double FoldError(const PsObservations& obs, const GreyBasis& grey, long p, const Vec3& n,
                 const std::vector<uint8_t>* use, const uint8_t* sh, const DictionaryFitOptions& o) {
  const int K = grey.size();
  std::vector<uint8_t> all(obs.lights, 1);
  if (!use) use = &all;
  double e = 0;
  for (int f = 0; f < o.folds; ++f) {
    std::vector<uint8_t> train(*use), test(*use);
    for (int l = 0; l < obs.lights; ++l) train[l] = (*use)[l] && l % o.folds != f, test[l] = (*use)[l] && l % o.folds == f;
    const PixelSolve fit = SolveRows(BuildRows(obs, grey, p, n, 1, &train, sh, o, Gates{false, false}), K, 1, o, false);
    const Rows r = BuildRows(obs, grey, p, n, 1, &test, sh, o, Gates{false, false});
    for (size_t i = 0; i < r.b.size(); ++i) {
      const double d = r.b[i] - Dot(r.Row(i), fit.w, 0, K);
      e += d * d;
    }
  }
  return e;
}

// Compass search over camera-facing unit normals: the 8 directions around
// the current normal at steps of 4 degrees, halved down to 0.25 when none
// scores lower; candidates more than `max_turn` (radians) from `start` are
// not tried. The lowest score goes to `best` (optional).
template <class Score>
Vec3 CompassSearch(const Vec3& start, const Score& score, int max_evaluations, double max_turn, double* best) {
  const double cos_max_turn = std::cos(std::min(max_turn, kPi));
  Vec3 n = start;
  double best_score = score(n);
  double step = 4.0 * kPi / 180;
  int evaluations = 0;
  while (step > 0.25 * kPi / 180 && evaluations < max_evaluations) {
    const Frame fr = Frame::FromNormal(n);
    Vec3 best_n = n;
    for (int k = 0; k < 8; ++k) {
      const double a = 2 * kPi * k / 8;
      const Vec3 m = (n + std::tan(step) * (std::cos(a) * fr.t + std::sin(a) * fr.b)).normalized();
      if (m.z() > -0.02 || m.dot(start) < cos_max_turn) continue;
      const double e = score(m);
      ++evaluations;
      if (e < best_score) best_score = e, best_n = m;
    }
    if (best_n == n) step *= 0.5;
    else n = best_n;
  }
  if (best) *best = best_score;
  return n;
}

// Pattern search on pixel p's luminance fit (steps of 4 degrees halved down
// to 0.25) from `start`, on the photos the start's robust fit keeps; the
// result is kept only if it predicts those photos left out of the fit (light
// folds) better than the start: a flat or biased objective (a lobe that
// absorbs the tilt) must not move the normal.
Vec3 SearchNormal(const PsObservations& obs, const GreyBasis& grey, long p, const Vec3& start, const uint8_t* sh,
                  const DictionaryFitOptions& o) {
  const int K = grey.size();
  // The photos (and rows) the search scores on are fixed at the start, so
  // that every candidate normal is judged on the same data.
  const Rows r0 = BuildRows(obs, grey, p, start, 1, nullptr, sh, o, Gates{});
  if (r0.b.size() < size_t(K + 3)) return start;
  std::vector<char> keep;
  SolveRows(r0, K, 1, o, true, &keep);
  std::vector<uint8_t> use(obs.lights, 0);
  for (size_t i = 0; i < r0.b.size(); ++i)
    if (keep[i]) use[r0.light[i]] = 1;
  auto score = [&](const Vec3& m) {
    const Rows r = BuildRows(obs, grey, p, m, 1, &use, sh, o, Gates{false, false});
    return SolveRows(r, K, 1, o, false).sse;
  };
  const Vec3 n = CompassSearch(start, score, 80, kPi, nullptr);
  return FoldError(obs, grey, p, n, &use, sh, o) < FoldError(obs, grey, p, start, &use, sh, o) ? n : start;
}

// Half vector between the viewer and the light of pixel p's brightest
// usable photo (NaN if it has none).
Vec3 BrightestHalfVector(const PsObservations& obs, long p, const uint8_t* sh) {
  double best = 0;
  int light = -1;
  for (int l = 0; l < obs.lights; ++l) {
    const size_t i = obs.At(p, l);
    if ((sh && sh[l]) || !obs.UsableRgb(i)) continue;
    const double v = Luminance(&obs.value[i]);
    if (v > best) best = v, light = l;
  }
  if (light < 0) return Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  return (obs.to_light[light] + obs.to_viewer).normalized();
}

// A pixel's photos for the one-lobe normal search: luminance under a unit
// light of its usable photos outside the height field's cast shadows, its
// darkest quarter left out (attached and cast shadows the height field
// misses, interreflection, 8-bit quantisation).
struct LobeRows {
  std::vector<int> light;
  std::vector<double> value;
};

LobeRows OneLobeRows(const PsObservations& obs, long p, const uint8_t* sh) {
  std::vector<std::pair<double, int>> lum;
  for (int l = 0; l < obs.lights; ++l) {
    const size_t i = obs.At(p, l);
    if ((sh && sh[l]) || !obs.UsableRgb(i)) continue;
    lum.emplace_back(Luminance(&obs.value[i]), l);
  }
  std::sort(lum.begin(), lum.end());
  LobeRows r;
  for (size_t k = lum.size() / 4; k < lum.size(); ++k) r.light.push_back(lum[k].second), r.value.push_back(lum[k].first);
  return r;
}

// The best non-negative a0 Lambert + a1 lobe fit to the rows under normal n
// (unweighted: the photos' own units under a unit light): its squared
// residual, and its weights if asked.
double OneLobeFit(const PsObservations& obs, const GreyBasis& two, const LobeRows& r, const Vec3& n,
                  double* w = nullptr) {
  const Frame fr = Frame::FromNormal(n);
  const Vec3 wo = fr.ToLocal(obs.to_viewer);
  double aa = 0, ab = 0, bb = 0, ay = 0, by = 0, yy = 0;
  for (size_t k = 0; k < r.light.size(); ++k) {
    const Vec3 wi = fr.ToLocal(obs.to_light[r.light[k]]);
    double a[2] = {0, 0};
    if (wi.z() > 0 && wo.z() > 0) two.Eval(wi, wo, a);
    const double y = r.value[k];
    aa += a[0] * a[0], ab += a[0] * a[1], bb += a[1] * a[1], ay += a[0] * y, by += a[1] * y, yy += y * y;
  }
  // 2 x 2 non-negative least squares: the joint solution if both weights
  // are >= 0, else the better single-atom fit (or none).
  double w0 = 0, w1 = 0, best = yy;
  const double det = aa * bb - ab * ab;
  if (det > 1e-12 * (aa * bb + 1e-300) && (bb * ay - ab * by) >= 0 && (aa * by - ab * ay) >= 0) {
    w0 = (bb * ay - ab * by) / det, w1 = (aa * by - ab * ay) / det;
    best = yy - w0 * ay - w1 * by;
  } else {
    if (aa > 0 && ay > 0 && yy - ay * ay / aa < best) best = yy - ay * ay / aa, w0 = ay / aa, w1 = 0;
    if (bb > 0 && by > 0 && yy - by * by / bb < best) best = yy - by * by / bb, w0 = 0, w1 = by / bb;
  }
  if (w) w[0] = w0, w[1] = w1;
  return std::max(0.0, best);
}

// The photos the search fits, once the lobe is chosen: those the pair
// describes at the start. A photo darker than kLobeShadowRatio of the
// pair's prediction (fitted to the rows above at the start), or lit at
// cos < kLobeMinCos, is a shadow the height field missed (a leaf on a lid,
// a handle), interreflection or a count near zero; dropping a fixed share
// (the darkest quarter) leaves such photos in wherever more than a quarter
// of a pixel's lights are hidden, and they pull its normal. Highlights stay:
// the lobe describes them. The prediction is the chosen pair's, not a
// Lambertian one, so that a diffuse darker at grazing light than Lambert
// (under an interface) keeps its grazing photos. A pixel left with fewer
// than kMinLobeRows photos keeps the rows above.
constexpr double kLobeShadowRatio = 0.7, kLobeMinCos = 0.15;
constexpr size_t kMinLobeRows = 8;

LobeRows LitLobeRows(const PsObservations& obs, const GreyBasis& two, long p, const uint8_t* sh, const Vec3& start,
                     LobeRows quartile) {
  double w[2];
  OneLobeFit(obs, two, quartile, start, w);
  const Frame fr = Frame::FromNormal(start);
  const Vec3 wo = fr.ToLocal(obs.to_viewer);
  LobeRows r;
  for (int l = 0; l < obs.lights; ++l) {
    const size_t i = obs.At(p, l);
    if ((sh && sh[l]) || !obs.UsableRgb(i)) continue;
    const Vec3 wi = fr.ToLocal(obs.to_light[l]);
    if (wi.z() <= kLobeMinCos || wo.z() <= 0) continue;
    double a[2];
    two.Eval(wi, wo, a);
    const double v = Luminance(&obs.value[i]);
    if (v > kLobeShadowRatio * (w[0] * a[0] + w[1] * a[1])) r.light.push_back(l), r.value.push_back(v);
  }
  return r.light.size() >= kMinLobeRows && w[0] + w[1] > 0 ? r : quartile;
}

// Compass search (steps of 4 degrees halved down to 0.25) from `start`,
// within kOneLobeTurn of it. The model choice searches as far as the final
// search: held closer, a pixel whose start is off by more cannot reach the
// true model's fit, and a wrong model that bends towards the start's error
// wins the choice. (A tighter bound only served rows that keep shadows:
// those pull a wide search away. LitLobeRows leaves them out; see
// docs/measurements.md.)
constexpr double kOneLobeTurn = 15.0 * kPi / 180;
Vec3 OneLobeSearch(const PsObservations& obs, const GreyBasis& two, const LobeRows& r, const Vec3& start,
                   double* sse_out) {
  return CompassSearch(start, [&](const Vec3& m) { return OneLobeFit(obs, two, r, m); }, 120, kOneLobeTurn, sse_out);
}

}  // namespace

std::vector<BasisMaterial> DictionaryCandidates() {
  std::vector<BasisMaterial> out;
  BasisMaterial lambert = Make("diffuse", "lambert");
  SetRgb(&lambert, "rd", 1.0);
  out.push_back(lambert);
  for (double sigma : {0.3, 0.6}) {
    BasisMaterial on = Make(Msg("oren_nayar_sigma", sigma), "oren_nayar");
    SetRgb(&on, "rd", 1.0);
    SetParam(&on, "sigma", sigma);
    out.push_back(on);
  }
  const struct {
    const char* label;
    const char* tag;
  } lobes[] = {{"cook_torrance-beckmann-nofresnel", "beckmann"}, {"cook_torrance-ggx-smith-nofresnel", "ggx"}};
  for (const auto& lobe : lobes)
    for (double m : {0.04, 0.08, 0.14, 0.22, 0.35, 0.5}) {
      BasisMaterial b = Make(Msg("specular_", lobe.tag, "_m", m), lobe.label);
      SetRgb(&b, "rd", 0.0);
      SetRgb(&b, "rs", 1.0);
      SetParam(&b, "roughness", m);
      out.push_back(b);
    }
  return out;
}

void DictionaryFitOptions::Check() const {
  if (folds < 2 || folds > 10) throw Error(Msg("photometric: folds must be in [2, 10], got ", folds));
  if (selection_pixels < 50) throw Error(Msg("photometric: selection_pixels must be >= 50, got ", selection_pixels));
  if (!(min_gain >= 0 && min_gain < 1)) throw Error(Msg("photometric: min_gain must be in [0, 1), got ", min_gain));
  if (max_basis < 1 || max_basis > 8) throw Error(Msg("photometric: max_basis must be in [1, 8], got ", max_basis));
  if (outlier_sigmas != 0 && !(outlier_sigmas > 1))
    throw Error(Msg("photometric: outlier_sigmas must be > 1 or 0, got ", outlier_sigmas));
  if (!(prior_rows >= 0) || !std::isfinite(prior_rows))
    throw Error(Msg("photometric: prior_rows must be a finite number >= 0, got ", prior_rows));
  if (!(search_misfit >= 0) || !std::isfinite(search_misfit))
    throw Error(Msg("photometric: search_misfit must be a finite number >= 0, got ", search_misfit));
  if (!(min_cos >= 0 && min_cos <= 0.5)) throw Error(Msg("photometric: min_cos must be in [0, 0.5], got ", min_cos));
  if (residual_window < -1 || residual_window > 10)
    throw Error(Msg("photometric: residual_window must be in [-1, 10], got ", residual_window));
  if (one_lobe_diffuse_etas.empty()) throw Error("photometric: one_lobe_diffuse_etas is empty");
  for (double eta : one_lobe_diffuse_etas)
    if (!(eta >= 1 && eta <= 3))
      throw Error(Msg("photometric: one_lobe_diffuse_etas must each be in [1, 3], got ", eta));
}

PixelSolve SolvePixel(const PsObservations& obs, const std::vector<BasisMaterial>& basis, long p, const Vec3& n,
                      int channels, const std::vector<uint8_t>* use, const uint8_t* shadowed,
                      const DictionaryFitOptions& o, const Eigen::MatrixXd* prior) {
  const Rows r = BuildRows(obs, GreyBasis(basis), p, n, channels, use, shadowed, o, Gates{});
  return SolveRows(r, int(basis.size()), channels, o, true, nullptr, prior);
}

BasisSelection SelectBasis(const PsObservations& obs, const Image& normals_cam, const std::vector<uint8_t>& shadowed,
                           const DictionaryFitOptions& o) {
  o.Check();
  std::vector<BasisMaterial> dict;
  for (const BasisMaterial& b : DictionaryCandidates())
    if (!o.allow_model || o.allow_model(b.spec)) dict.push_back(b);
  if (dict.empty() || dict[0].spec.family != Family::kLambert)
    throw Error("photometric: the allowed dictionary models must include Lambert");
  const GreyBasis grey(dict);
  const long P = obs.P();
  const long stride = std::max<long>(1, P / o.selection_pixels);
  std::vector<long> subset;
  for (long p = stride / 2; p < P; p += stride) subset.push_back(p);
  // Each subset pixel's luminance rows for the whole dictionary, once: a
  // candidate basis is a choice of columns.
  std::vector<Rows> rows(subset.size());
  ParallelFor(long(subset.size()), o.threads, [&](long s) {
    const long p = subset[s];
    rows[s] = BuildRows(obs, grey, p, NormalAt(normals_cam, obs.pixel[p], obs.width), 1, nullptr,
                        ShadowRow(shadowed, p, obs.lights), o, Gates{});
  }, 16);
  // Cross-validated luminance error of a basis (columns `cols`): each fold's
  // photos predicted from the others' fit.
  auto cv_error = [&](const std::vector<int>& cols) {
    const int K = int(cols.size());
    std::vector<double> err(subset.size(), 0.0);
    ParallelFor(long(subset.size()), o.threads, [&](long s) {
      const Rows& full = rows[s];
      for (int f = 0; f < o.folds; ++f) {
        Rows train, test;
        train.K = test.K = K;
        for (size_t i = 0; i < full.b.size(); ++i) {
          Rows& dst = full.light[i] % o.folds == f ? test : train;
          double a[16];
          for (int k = 0; k < K; ++k) a[k] = full.Row(i)[cols[k]];
          dst.Add(a, 1.0, full.b[i], full.light[i], 0);
        }
        if (train.b.empty()) continue;
        const PixelSolve fit = SolveRows(train, K, 1, o, true);
        for (size_t i = 0; i < test.b.size(); ++i) {
          const double e = test.b[i] - Dot(test.Row(i), fit.w, 0, K);
          err[s] += e * e;
        }
      }
    }, 16);
    double sum = 0;
    for (double e : err) sum += e;
    return sum;
  };
  BasisSelection sel;
  std::vector<int> cols = {0};
  sel.cv_error.push_back(cv_error(cols));
  sel.log.push_back(Msg(dict[0].name, ": cross-validated error ", sel.cv_error.back()));
  std::vector<char> taken(dict.size(), 0);
  taken[0] = 1;
  while (int(cols.size()) < o.max_basis) {
    int best = -1;
    double best_err = 0;
    for (size_t c = 1; c < dict.size(); ++c) {
      if (taken[c]) continue;
      std::vector<int> trial = cols;
      trial.push_back(int(c));
      const double e = cv_error(trial);
      if (best < 0 || e < best_err) best = int(c), best_err = e;
    }
    if (best < 0) break;
    const double gain = 1.0 - best_err / sel.cv_error.back();
    const bool accept = gain > o.min_gain;
    sel.log.push_back(Msg("+ ", dict[best].name, ": cross-validated error ", best_err, " (", 100 * gain, " % lower): ",
                          accept ? "kept" : "rejected"));
    if (!accept) break;
    taken[best] = 1;
    cols.push_back(best);
    sel.cv_error.push_back(best_err);
  }
  for (int c : cols) sel.basis.push_back(dict[c]);
  return sel;
}

Image RefineNormals(const PsObservations& obs, const std::vector<BasisMaterial>& basis, const Image& normals_cam,
                    const std::vector<uint8_t>& shadowed, const DictionaryFitOptions& o, const Image* search) {
  Image out = normals_cam;
  const GreyBasis grey(basis);
  Progress bar("refine normals", obs.P(), true);
  ParallelFor(obs.P(), o.threads, [&](long p) {
    if (search && search->pixels[obs.pixel[p]] < 0.5f) {
      bar.Tick();
      return;
    }
    const Vec3 start = NormalAt(normals_cam, obs.pixel[p], obs.width);
    const uint8_t* sh = ShadowRow(shadowed, p, obs.lights);
    Vec3 n = SearchNormal(obs, grey, p, start, sh, o);
    // A second start from the specular cue: the half vector of the pixel's
    // brightest photo, which is where a glossy pixel's normal lies and where
    // a Lambertian start is furthest from it (metals). Kept only if it
    // predicts all the pixel's photos left out of the fit better.
    const Vec3 cue = BrightestHalfVector(obs, p, sh);
    if (cue.allFinite() && std::acos(std::clamp(cue.dot(n), -1.0, 1.0)) > 6 * kPi / 180) {
      const Vec3 m = SearchNormal(obs, grey, p, cue, sh, o);
      if (FoldError(obs, grey, p, m, nullptr, sh, o) < 0.9 * FoldError(obs, grey, p, n, nullptr, sh, o)) n = m;
    }
    const int x = obs.pixel[p] % obs.width, y = obs.pixel[p] / obs.width;
    for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(n[c]);
    bar.Tick();
  }, 64);
  return out;
}

void SolveWeights(const PsObservations& obs, const std::vector<BasisMaterial>& basis, const Image& normals_cam,
                  const std::vector<uint8_t>& shadowed, const DictionaryFitOptions& o, std::vector<Image>* weights,
                  Image* confidence) {
  const int K = int(basis.size());
  std::vector<PixelSolve> fits(obs.P());
  auto solve_all = [&](const Eigen::MatrixXd* prior) {
    ParallelFor(obs.P(), o.threads, [&](long p) {
      const Vec3 n = NormalAt(normals_cam, obs.pixel[p], obs.width);
      fits[p] = SolvePixel(obs, basis, p, n, 3, nullptr, ShadowRow(shadowed, p, obs.lights), o, prior);
    }, 64);
  };
  solve_all(nullptr);
  // The prior: per basis BRDF and channel, the median weight of the pixels
  // that most photos saw.
  Eigen::MatrixXd prior = Eigen::MatrixXd::Zero(K, 3);
  for (int k = 0; k < K; ++k)
    for (int c = 0; c < 3; ++c) {
      std::vector<double> v;
      for (long p = 0; p < obs.P(); ++p)
        if (fits[p].used > obs.lights) v.push_back(fits[p].w(k, c));
      if (v.empty()) continue;
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      prior(k, c) = v[v.size() / 2];
    }
  if (o.prior_rows > 0) solve_all(&prior);
  weights->assign(K, Image(obs.width, obs.height, 3));
  *confidence = Image(obs.width, obs.height, 1);
  for (long p = 0; p < obs.P(); ++p) {
    const int x = obs.pixel[p] % obs.width, y = obs.pixel[p] / obs.width;
    for (int k = 0; k < K; ++k)
      for (int c = 0; c < 3; ++c) (*weights)[k].at(x, y, c) = float(fits[p].w(k, c));
    confidence->at(x, y, 0) = float(fits[p].used) / float(3 * obs.lights);
  }
}

Image RefineNormalsUnderOneLobe(const PsObservations& obs, const Image& normals_cam,
                                const std::vector<uint8_t>& shadowed, const DictionaryFitOptions& o,
                                const Image& where, std::string* chosen) {
  const std::vector<BasisMaterial> dict = DictionaryCandidates();
  std::vector<BasisMaterial> lobes;
  for (const BasisMaterial& b : dict)
    if (b.spec.family == Family::kCookTorrance && (!o.allow_model || o.allow_model(b.spec))) lobes.push_back(b);
  Image out = normals_cam;
  if (lobes.empty()) return out;
  auto selected = [&](long p) { return where.pixels[obs.pixel[p]] > 0.5f; };
  // The lobe: lowest total relative residual after the search, on pixels
  // spread over the selected ones.
  std::vector<long> subset;
  for (long p = 0; p < obs.P(); ++p)
    if (selected(p)) subset.push_back(p);
  if (subset.empty()) return out;
  const size_t stride = std::max<size_t>(1, subset.size() / std::max(1, o.selection_pixels / 4));
  std::vector<long> probe;
  for (size_t k = stride / 2; k < subset.size(); k += stride) probe.push_back(subset[k]);
  std::vector<LobeRows> probe_rows(probe.size());
  for (size_t k = 0; k < probe.size(); ++k) probe_rows[k] = OneLobeRows(obs, probe[k], ShadowRow(shadowed, probe[k], obs.lights));
  // Candidates: every lobe with each diffuse (Lambert, or a body under an
  // interface of index `one_lobe_diffuse_etas`: DiffuseThroughInterface).
  struct Pairing {
    size_t lobe;
    double eta;
  };
  std::vector<Pairing> pairings;
  for (double eta : o.one_lobe_diffuse_etas)
    for (size_t j = 0; j < lobes.size(); ++j) pairings.push_back({j, eta});
  std::vector<double> total(pairings.size(), 0.0);
  for (size_t j = 0; j < pairings.size(); ++j) {
    const std::vector<BasisMaterial> pair = {dict[0], lobes[pairings[j].lobe]};
    const GreyBasis two(pair, pairings[j].eta);
    std::vector<double> rel(probe.size(), 0.0);
    ParallelFor(long(probe.size()), o.threads, [&](long k) {
      const LobeRows& r = probe_rows[k];
      if (r.light.size() < kMinLobeRows) return;
      double yy = 0, sse = 0;
      for (double v : r.value) yy += v * v;
      OneLobeSearch(obs, two, r, NormalAt(normals_cam, obs.pixel[probe[k]], obs.width), &sse);
      rel[k] = yy > 0 ? sse / yy : 0.0;
    }, 16);
    for (double e : rel) total[j] += e;
  }
  const Pairing best = pairings[size_t(std::min_element(total.begin(), total.end()) - total.begin())];
  if (chosen)
    *chosen = best.eta > 1 ? Msg(lobes[best.lobe].name, ", diffuse under an interface of index ", best.eta)
                           : lobes[best.lobe].name;
  const std::vector<BasisMaterial> pair = {dict[0], lobes[best.lobe]};
  const GreyBasis two(pair, best.eta);
  Progress bar("one-lobe normals", long(subset.size()), true);
  ParallelFor(long(subset.size()), o.threads, [&](long k) {
    const long p = subset[k];
    const Vec3 start = NormalAt(normals_cam, obs.pixel[p], obs.width);
    const uint8_t* sh = ShadowRow(shadowed, p, obs.lights);
    const LobeRows r = LitLobeRows(obs, two, p, sh, start, OneLobeRows(obs, p, sh));
    if (r.light.size() >= kMinLobeRows) {
      const Vec3 n = OneLobeSearch(obs, two, r, start, nullptr);
      const int x = obs.pixel[p] % obs.width, y = obs.pixel[p] / obs.width;
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(n[c]);
    }
    bar.Tick();
  }, 64);
  return out;
}

}  // namespace svbrdf
