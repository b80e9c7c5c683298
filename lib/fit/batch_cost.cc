// Every fit's time is spent in the Jet arithmetic of this file's cost
// functions. GCC leaves Eigen's fixed-size vector loops of Jets with 5, 7 or
// 8 derivatives out of line (a call per Jet operation); forcing Eigen's
// strong inlining here removes those calls from every coated, Cook-Torrance
// or conductor fit (tests/bench/fit_bench; bench_results/per_stage.md).
// Only inlining changes: the results are bitwise the same.
#define EIGEN_STRONG_INLINE inline __attribute__((always_inline))
#include "fit/batch_cost.h"
#include "fit/fit.h"  // SampleBrightness

#include <ceres/autodiff_cost_function.h>
#include <ceres/dynamic_autodiff_cost_function.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <utility>

#include "brdf/model_eval.h"  // instantiates EvalModel for ceres::Jet

// With everything inlined GCC sees the model dispatch of EvalModelBatch read
// more parameters than a Jet count has, in branches of models with other
// counts that never run with it (NumParams() selects the count): false
// -Warray-bounds alarms.
#pragma GCC diagnostic ignored "-Warray-bounds"

namespace svbrdf {
namespace {

// Parameter counts that get a compile-time-sized cost function: those of the
// lib/brdf labels (lambert 3, oren_nayar 4, phong/blinn_phong/cosine_lobe 7,
// cook_torrance 8, lafortune-L 3+6L, lafortune-L-aniso 3+7L,
// conductor 4 (schlick) or 7 (exact, f82), coated 5, principled 6 or 8). NumParams() is a
// runtime value, so the list cannot be derived here; fit_test checks that every
// label lands in it, and an unlisted count still works via the dynamic path.
using FixedSizes = std::integer_sequence<int, 3, 4, 5, 6, 7, 8, 9, 10, 15, 17, 21, 24>;

// Residual r robustified to r sqrt(rho(r^2) / r^2) with the Cauchy loss
// rho(s) = c^2 log(1 + s / c^2) (as ceres::CauchyLoss), so that its square is
// rho(r^2). A ceres::LossFunction would act on the squared norm of a whole
// block, i.e. of many samples at once, and could not single out outliers.
template <class T>
T CauchyResidual(const T& r, double c) {
  using std::log1p;
  using std::sqrt;
  const T u = r * r / (c * c);
  // log1p(u)/u -> 1 as u -> 0; the series avoids 0/0 and its NaN derivative.
  const T ratio = u < T(1e-8) ? T(1.0) - u * 0.5 : log1p(u) / u;
  return r * sqrt(ratio);
}

struct BatchResidual {
  ModelSpec spec;
  const double* rows;  // PackedSamples rows of this batch
  int count;
  double robust_scale;  // 0: plain residuals
  const double* pairs = nullptr;  // PackedSamples::pairs of this batch, or null

  template <class T>
  bool Eval(const T* p, T* residuals) const {
    if (pairs) return EvalFootprint(p, residuals);
    // The model's values first (one parameter read for the whole batch),
    // written into the residuals, then turned into residuals in place.
    EvalModelBatch(spec, p, count, [this](int i, Vec3T<T>* wi, Vec3T<T>* wo) {
      const double* s = rows + i * PackedSamples::kStride;
      *wi = Vec3T<T>{T(s[0]), T(s[1]), T(s[2])};
      *wo = Vec3T<T>{T(s[3]), T(s[4]), T(s[5])};
    }, residuals);
    for (int i = 0; i < count; ++i) {
      const double* s = rows + i * PackedSamples::kStride;
      for (int c = 0; c < 3; ++c) {
        const T r = residuals[3 * i + c] * s[6] - s[7 + c];
        residuals[3 * i + c] = robust_scale > 0 ? CauchyResidual(r, robust_scale) : r;
      }
    }
    return true;  // non-finite residuals are caught by RememberingCost (step rejected / FAILURE)
  }

  // PackedSamples::pairs: the model at every sub-sample's directions, summed
  // with their weights per sample.
  template <class T>
  bool EvalFootprint(const T* p, T* residuals) const {
    constexpr int kSub = SampleSet::kFootprintSubsamples, kPair = PackedSamples::kPairStride;
    std::vector<T> f(size_t(3) * kSub * count);
    EvalModelBatch(spec, p, kSub * count, [this](int i, Vec3T<T>* wi, Vec3T<T>* wo) {
      const double* q = pairs + i * kPair;
      *wi = Vec3T<T>{T(q[0]), T(q[1]), T(q[2])};
      *wo = Vec3T<T>{T(q[3]), T(q[4]), T(q[5])};
    }, f.data());
    for (int i = 0; i < count; ++i) {
      const double* s = rows + i * PackedSamples::kStride;
      for (int c = 0; c < 3; ++c) {
        T sum = T(0);
        for (int j = 0; j < kSub; ++j) {
          const double w = pairs[(i * kSub + j) * kPair + 6];
          if (w != 0) sum += f[3 * (i * kSub + j) + c] * w;
        }
        const T r = sum * s[6] - s[7 + c];
        residuals[3 * i + c] = robust_scale > 0 ? CauchyResidual(r, robust_scale) : r;
      }
    }
    return true;
  }
};

template <int N>
struct FixedBatchResidual : BatchResidual {
  template <class T>
  bool operator()(const T* p, T* residuals) const { return Eval(p, residuals); }
};

struct DynamicBatchResidual : BatchResidual {
  template <class T>
  bool operator()(T const* const* p, T* residuals) const { return Eval(p[0], residuals); }
};

template <int... Ns>
ceres::CostFunction* MakeFixed(std::integer_sequence<int, Ns...>, const BatchResidual& r) {
  const int n = r.spec.NumParams();
  ceres::CostFunction* cost = nullptr;
  (void)((n == Ns && (cost = new ceres::AutoDiffCostFunction<FixedBatchResidual<Ns>, ceres::DYNAMIC, Ns>(
                          new FixedBatchResidual<Ns>{r}, 3 * r.count))) ||
         ...);
  return cost;
}

// Returns the residuals of its last evaluation again when asked for the
// same parameters without Jacobians. With bounds, Ceres evaluates every
// trial point twice (its projected line search at step 1, then the trial
// point itself: the same parameters bit for bit). Ceres evaluates a block on
// one thread at a time, so the memory needs no lock.
class RememberingCost : public ceres::CostFunction {
 public:
  explicit RememberingCost(ceres::CostFunction* inner) : inner_(inner) {
    set_num_residuals(inner->num_residuals());
    *mutable_parameter_block_sizes() = inner->parameter_block_sizes();
  }
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const int n = parameter_block_sizes()[0];
    if (jacobians == nullptr && valid_ && std::equal(p[0], p[0] + n, last_params_.begin())) {
      std::copy(last_residuals_.begin(), last_residuals_.end(), residuals);
      return true;
    }
    // A trial point where the model is not finite (a lobe exponent pushed
    // far out) is reported as a failed evaluation: Ceres then rejects the
    // step quietly instead of printing the whole block as an error.
    const int m = num_residuals();
    valid_ = inner_->Evaluate(p, residuals, jacobians) &&
             std::all_of(residuals, residuals + m, [](double r) { return std::isfinite(r); }) &&
             (jacobians == nullptr || jacobians[0] == nullptr ||
              std::all_of(jacobians[0], jacobians[0] + m * n, [](double j) { return std::isfinite(j); }));
    if (valid_) {
      last_params_.assign(p[0], p[0] + n);
      last_residuals_.assign(residuals, residuals + num_residuals());
    }
    return valid_;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  mutable bool valid_ = false;
  mutable std::vector<double> last_params_, last_residuals_;
};

template <int... Ns>
constexpr bool IsFixed(std::integer_sequence<int, Ns...>, int n) {
  return ((n == Ns) || ...);
}

}  // namespace

PackedSamples PackedSamples::FromIds(const SampleSet& set, const std::vector<int64_t>& ids,
                                     const std::function<double(double)>& weight) {
  PackedSamples packed;
  packed.values.resize(ids.size() * kStride);
  double* out = packed.values.data();
  for (const int64_t s : ids) {
    for (int k = 0; k < 3; ++k) {
      out[k] = set.wi[k][s];
      out[3 + k] = set.wo[k][s];
      out[7 + k] = set.y[k][s];
    }
    out[6] = set.geom[s];
    if (weight) {
      const double w = weight(SampleBrightness(set, s));
      for (int k = 6; k < 10; ++k) out[k] *= w;
    }
    out += kStride;
  }
  if (set.HasFootprint()) {
    constexpr int kSub = SampleSet::kFootprintSubsamples;
    packed.pairs.assign(ids.size() * kPairStride * kSub, 0.0);
    double* q = packed.pairs.data();
    for (const int64_t s : ids) {
      const Vec3 wi(set.wi[0][s], set.wi[1][s], set.wi[2][s]), wo(set.wo[0][s], set.wo[1][s], set.wo[2][s]);
      const float* fp = &set.footprint[size_t(s) * 3 * kSub];
      for (int j = 0; j < kSub; ++j, q += kPairStride) {
        Vec3 wi_t = wi, wo_t = wo;
        double ratio = 0;
        // A pair below the tilted horizon keeps weight 0 and the sample's own
        // directions (finite, evaluated but not counted).
        if (fp[3 * j + 2] > 0 && TiltedSampleDirections(wi, wo, double(fp[3 * j]), double(fp[3 * j + 1]), &wi_t, &wo_t, &ratio))
          q[6] = fp[3 * j + 2] * ratio;
        else
          wi_t = wi, wo_t = wo;
        for (int k = 0; k < 3; ++k) q[k] = wi_t[k], q[3 + k] = wo_t[k];
      }
    }
  }
  return packed;
}

ceres::CostFunction* MakeBatchCost(const ModelSpec& spec, const PackedSamples& packed, int64_t begin, int count,
                                   double robust_scale) {
  const BatchResidual r{spec, packed.row(begin), count, robust_scale,
                        packed.HasFootprint() ? packed.pairs_of(begin) : nullptr};
  if (ceres::CostFunction* cost = MakeFixed(FixedSizes{}, r)) return new RememberingCost(cost);
  // Stride 8: jets of 8 derivatives per pass over the residuals.
  auto* cost = new ceres::DynamicAutoDiffCostFunction<DynamicBatchResidual, 8>(new DynamicBatchResidual{r});
  cost->AddParameterBlock(spec.NumParams());
  cost->SetNumResiduals(3 * count);
  return new RememberingCost(cost);
}

bool HasFixedSizeCost(int num_params) { return IsFixed(FixedSizes{}, num_params); }

}  // namespace svbrdf
