// Unit tests of the gather module's pure parts (the captures' tests are in
// tests/e2e/gather_test.cc).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "gather/footprint_quadrature.h"

using namespace svbrdf;

namespace {

// The rays of one lookup: 4 pixels of n x n rays whose normals turn by
// `turn` (in tilt units) per pixel across x, plus a ripple within each pixel
// along y, lookup weights bilinear at (fx, fy).
std::vector<FootprintRay> LookupRays(int n, double turn, double fx, double fy) {
  std::vector<FootprintRay> rays;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx)
      for (int sy = 0; sy < n; ++sy)
        for (int sx = 0; sx < n; ++sx) {
          const double u = dx + (sx + 0.5) / n, v = dy + (sy + 0.5) / n;
          FootprintRay r;
          r.a = turn * (u - 1);
          r.b = 0.5 * turn * std::sin(2 * M_PI * v);
          r.w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) / (n * n);
          r.entry = dx + 2 * dy;
          rays.push_back(r);
        }
  return rays;
}

// A lobe as narrow as the footprint's turn, as a function of the tilt.
double Lobe(double a, double b, double width) { return std::exp(-((a - 0.01) * (a - 0.01) + b * b) / (width * width)); }

double LobeMean(const std::vector<FootprintRay>& rays, double width) {
  double s = 0, w = 0;
  for (const FootprintRay& r : rays) s += r.w * Lobe(r.a, r.b, width), w += r.w;
  return s / w;
}

double LobeQuadrature(const float* q, int entries, double width) {
  double s = 0;
  for (int e = 0; e < entries; ++e) s += q[3 * e + 2] * Lobe(q[3 * e], q[3 * e + 1], width);
  return s;
}

}  // namespace

// The reduction keeps what a quadrature must (weights summing to 1, the
// mean tilt) and lowers the within-entry spread below the pixels' means'.
TEST(FootprintQuadrature, KeepsTheMeanAndLowersTheSpread) {
  for (double fx : {0.5, 0.1}) {
    std::vector<FootprintRay> rays = LookupRays(2, 0.07, fx, 0.3);
    const int count = int(rays.size());
    const double pixels_spread = FootprintSpread(rays.data(), count, 4);
    double ma = 0, mb = 0;
    for (const FootprintRay& r : rays) ma += r.w * r.a, mb += r.w * r.b;
    float q[12];
    ASSERT_TRUE(ReduceFootprintRays(rays.data(), count, 4, q));
    double w = 0, qa = 0, qb = 0;
    for (int e = 0; e < 4; ++e) w += q[3 * e + 2], qa += q[3 * e + 2] * q[3 * e], qb += q[3 * e + 2] * q[3 * e + 1];
    EXPECT_NEAR(w, 1.0, 1e-6);
    EXPECT_NEAR(qa, ma, 1e-6);
    EXPECT_NEAR(qb, mb, 1e-6);
    const double spread = FootprintSpread(rays.data(), count, 4);
    EXPECT_LT(spread, 0.7 * pixels_spread) << "fx " << fx;
  }
}

// Its purpose: a lobe as narrow as the turn of the normal within the
// lookup, averaged over the 4 entries, comes closer to its mean over all
// the rays (what the photo integrates) than over the pixels' mean tilts.
TEST(FootprintQuadrature, AveragesANarrowLobeCloserToTheRaysThanThePixelMeans) {
  for (double fx : {0.5, 0.2}) {
    std::vector<FootprintRay> rays = LookupRays(4, 0.07, fx, 0.5);
    const double exact = LobeMean(rays, 0.06);
    // The pixels' means: the entries as they start.
    std::vector<FootprintRay> pixels = rays;
    float qp[12], q[12];
    {
      std::vector<double> a(4, 0), b(4, 0), w(4, 0);
      double total = 0;
      for (const FootprintRay& r : pixels) a[r.entry] += r.w * r.a, b[r.entry] += r.w * r.b, w[r.entry] += r.w, total += r.w;
      for (int e = 0; e < 4; ++e) qp[3 * e] = float(a[e] / w[e]), qp[3 * e + 1] = float(b[e] / w[e]), qp[3 * e + 2] = float(w[e] / total);
    }
    ASSERT_TRUE(ReduceFootprintRays(rays.data(), int(rays.size()), 4, q));
    const double err_pixels = std::abs(LobeQuadrature(qp, 4, 0.06) - exact);
    const double err = std::abs(LobeQuadrature(q, 4, 0.06) - exact);
    std::printf("fx %.1f: lobe mean over the rays %.4f, error of the pixels' means %.4f, of the reduction %.4f\n", fx,
                exact, err_pixels, err);
    EXPECT_LT(err, 0.5 * err_pixels);
  }
}

// The rays of one pixel (the lookup at its centre) are split too: the
// entries keep their spread. No weighted ray: false, all weights 0.
TEST(FootprintQuadrature, OnePixelsRaysAreSplitAndNoRaysIsFalse) {
  std::vector<FootprintRay> rays = LookupRays(2, 0.05, 0.0, 0.0);  // all weight on pixel 0
  std::vector<FootprintRay> kept;
  for (const FootprintRay& r : rays)
    if (r.w > 0) kept.push_back(r);
  ASSERT_EQ(kept.size(), 4u);
  float q[12];
  ASSERT_TRUE(ReduceFootprintRays(kept.data(), int(kept.size()), 4, q));
  int used = 0;
  double w = 0;
  for (int e = 0; e < 4; ++e) used += q[3 * e + 2] > 0, w += q[3 * e + 2];
  EXPECT_EQ(used, 4);  // four distinct rays, four entries
  EXPECT_NEAR(w, 1.0, 1e-6);
  EXPECT_NEAR(FootprintSpread(kept.data(), int(kept.size()), 4), 0.0, 1e-12);
  EXPECT_FALSE(ReduceFootprintRays(nullptr, 0, 4, q));
  for (int e = 0; e < 4; ++e) EXPECT_EQ(q[3 * e + 2], 0.0f);
}

// More entries or rays than the reduction's fixed bounds: an error, not a
// write past its arrays.
TEST(FootprintQuadrature, BeyondItsBoundsThrows) {
  std::vector<FootprintRay> rays = LookupRays(2, 0.05, 0.5, 0.5);
  float q[3 * (kMaxFootprintEntries + 1)];
  EXPECT_THROW(ReduceFootprintRays(rays.data(), int(rays.size()), kMaxFootprintEntries + 1, q), std::exception);
  std::vector<FootprintRay> many(kMaxFootprintRays + 1, rays[0]);
  EXPECT_THROW(ReduceFootprintRays(many.data(), int(many.size()), 4, q), std::exception);
}
