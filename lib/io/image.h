// Image files, behind OpenImageIO. Pixels are float, row-major, interleaved
// channels, row 0 at the top.
#pragma once
#include <string>
#include <vector>

namespace svbrdf {

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<float> pixels;
  // Largest value the file's format can hold (1 for integer formats after
  // normalisation, 65504 for half-float files, +inf for float files);
  // values >= this are saturated. A camera's raw values clipped into a
  // half-float EXR land on half's largest finite value, not on infinity.
  float saturation_level = 1.0f;
  // Bits per channel of an integer file (8, 16; what one step of the value
  // is: 1 / (2^bits - 1)); 0 for float files and images made in memory.
  int bits = 0;

  Image() = default;
  Image(int w, int h, int c, float fill = 0.0f) : width(w), height(h), channels(c), pixels(size_t(w) * h * c, fill) {}
  float& at(int x, int y, int c) { return pixels[(size_t(y) * width + x) * channels + c]; }
  float at(int x, int y, int c) const { return pixels[(size_t(y) * width + x) * channels + c]; }
  // Bilinear sample at continuous pixel coordinates with the COLMAP convention
  // (pixel centres at +0.5), clamped at borders.
  float Bilinear(double px, double py, int c) const;
};

// Whether the image holds linear values beyond [0, 1] (a float or half file,
// an HDR merge): shown tone-mapped rather than clamped.
inline bool IsHighDynamicRange(const Image& img) { return img.saturation_level > 1.0f; }

enum class ColorSpace { kLinear, kSRGB };
enum class PixelFormat { kFloat, kHalf, kUInt16, kUInt8 };

float SrgbToLinear(float v);
float LinearToSrgb(float v);

// Reads any format OpenImageIO knows. Integer formats are normalised to
// [0, 1]; if `space` is sRGB and the file is not EXR/HDR, values are decoded
// to linear. Throws Error naming the file on failure.
Image ReadImage(const std::string& path, ColorSpace space = ColorSpace::kLinear);
// Writes with the format implied by `format` (EXR half/float, PNG/TIFF 16 bit,
// PNG/JPEG 8 bit); integer formats are encoded with sRGB if `space` is sRGB,
// clamped to [0,1]. Atomic: writes a temporary file and renames it.
void WriteImage(const std::string& path, const Image& image, PixelFormat format = PixelFormat::kFloat,
                ColorSpace space = ColorSpace::kLinear);

// Label maps (material ids): integer values stored unnormalised in 8- or
// 16-bit PNG, read back as the same integers (as floats).
Image ReadLabelImage(const std::string& path);
void WriteLabelImage(const std::string& path, const Image& labels);  // 8 bit if all ids <= 255, else 16 bit

// Fraction of pixels (of the given mask, if any) with any channel >= saturation_level.
double SaturatedFraction(const Image& image, const Image* mask = nullptr);

}  // namespace svbrdf
