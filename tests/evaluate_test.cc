#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "evaluate/html.h"
#include "evaluate/metrics.h"

namespace svbrdf {
namespace {

TEST(Evaluate, AdjustedRandIndex) {
  EXPECT_DOUBLE_EQ(AdjustedRandIndex({0, 0, 1, 1, 2, 2}, {5, 5, 3, 3, 9, 9}), 1.0);  // same partition, other names
  EXPECT_LT(AdjustedRandIndex({0, 0, 1, 1, 2, 2}, {0, 1, 2, 0, 1, 2}), 0.0);          // worse than chance
  // Hubert & Arabie's example value: a = {0,0,0,1,1,1}, b = {0,0,1,1,2,2} -> 0.2424...
  EXPECT_NEAR(AdjustedRandIndex({0, 0, 0, 1, 1, 1}, {0, 0, 1, 1, 2, 2}), 0.24242424, 1e-6);
  EXPECT_THROW(AdjustedRandIndex({0}, {0, 1}), Error);
}

TEST(Evaluate, PsnrOfAKnownError) {
  Image a(10, 10, 3, 0.5f), b(10, 10, 3, 0.5f);
  EXPECT_GT(CompareImages(a, b, nullptr).psnr_srgb, 100);
  // Shift the sRGB value by exactly 0.01 everywhere: PSNR = 40 dB.
  const float target = SrgbToLinear(LinearToSrgb(0.5f) + 0.01f);
  for (float& v : b.pixels) v = target;
  const ImageMetrics m = CompareImages(a, b, nullptr);
  EXPECT_NEAR(m.psnr_srgb, 40.0, 0.01);
  EXPECT_NEAR(m.rel_rmse_linear, std::abs(target - 0.5) / 0.5, 1e-6);
  // Exposure is divided out; a mask restricts the pixels.
  Image mask(10, 10, 1, 0.0f);
  mask.at(3, 3, 0) = 1;
  EXPECT_EQ(CompareImages(a, b, &mask, 2.0).pixels, 1);
  EXPECT_THROW(CompareImages(a, Image(5, 5, 3), nullptr), Error);
}

TEST(Evaluate, FalseColourMapsAreInRange) {
  Image labels(4, 1, 1);
  for (int x = 0; x < 4; ++x) labels.at(x, 0, 0) = float(x - 1);
  const Image l = LabelMap(labels);
  EXPECT_EQ(l.at(0, 0, 0), 0.0f);  // label -1 is black
  EXPECT_NE(l.at(1, 0, 0), l.at(2, 0, 0));
  const Image r = ColorRamp(labels, -1, 2);
  for (float v : r.pixels) EXPECT_TRUE(v >= 0 && v <= 1);
}

TEST(Html, Base64MatchesRfc4648Vectors) {
  EXPECT_EQ(Base64(""), "");
  EXPECT_EQ(Base64("f"), "Zg==");
  EXPECT_EQ(Base64("fo"), "Zm8=");
  EXPECT_EQ(Base64("foo"), "Zm9v");
  EXPECT_EQ(Base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(Base64(std::string("\xff\x00\x10", 3)), "/wAQ");
}

TEST(Html, PageEscapesTextAndEmbedsPictures) {
  HtmlPage page("a <b> & c");
  page.Table({"x"}, {{"1 < 2"}});
  const std::string png = ::testing::TempDir() + "/html_test.png";
  WriteImage(png, Image(2, 2, 3, 0.5f), PixelFormat::kUInt8, ColorSpace::kSRGB);
  page.Figures({{png, "grey"}});
  const std::string html = page.ToString();
  EXPECT_NE(html.find("a &lt;b&gt; &amp; c"), std::string::npos);
  EXPECT_NE(html.find("1 &lt; 2"), std::string::npos);
  EXPECT_NE(html.find("src=\"data:image/png;base64,iVBORw0KGgo"), std::string::npos);  // PNG signature
  EXPECT_EQ(html.find(png), std::string::npos);  // no reference to an outside file
}

}  // namespace
}  // namespace svbrdf
