#include "io/image.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>

#include "core/error.h"
#include "io/files.h"

namespace svbrdf {
namespace {

namespace OIIO = OIIO_NAMESPACE;

std::string LowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// Largest finite half-float value: where a half file clips.
constexpr float kHalfMax = 65504.0f;

bool IsFloatType(OIIO::TypeDesc t) {
  return t.basetype == OIIO::TypeDesc::FLOAT || t.basetype == OIIO::TypeDesc::HALF ||
         t.basetype == OIIO::TypeDesc::DOUBLE;
}

// Quantises [0,1] floats to an unsigned integer type, rounding to nearest.
template <class T>
std::vector<T> Quantise(const std::vector<float>& v) {
  constexpr float kMax = static_cast<float>(std::numeric_limits<T>::max());
  std::vector<T> out(v.size());
  for (size_t i = 0; i < v.size(); ++i) out[i] = static_cast<T>(std::lround(std::clamp(v[i], 0.0f, 1.0f) * kMax));
  return out;
}

}  // namespace

float SrgbToLinear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

float LinearToSrgb(float v) {
  return v <= 0.0031308f ? v * 12.92f : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

Image ReadImage(const std::string& path, ColorSpace space) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw Error(Msg(path, ": cannot read image: ", OIIO::geterror()));
  const OIIO::ImageSpec& spec = in->spec();
  // A corrupt header must not allocate gigabytes (or overflow the size).
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.width > 65536 || spec.height > 65536 ||
      spec.nchannels > 64 || double(spec.width) * spec.height * spec.nchannels > double(1L << 29))
    throw Error(Msg(path, ": unsupported image size ", spec.width, "x", spec.height, " with ", spec.nchannels,
                    " channels (corrupt header?)"));
  Image img(spec.width, spec.height, spec.nchannels);
  // Integer formats are normalised to [0, 1] by OpenImageIO's conversion to float.
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, img.pixels.data()))
    throw Error(Msg(path, ": cannot read image: ", in->geterror()));
  const bool is_float = IsFloatType(spec.format);
  img.saturation_level = spec.format.basetype == OIIO::TypeDesc::HALF ? kHalfMax
                         : is_float                                  ? std::numeric_limits<float>::infinity()
                                                                     : 1.0f;
  img.bits = is_float ? 0 : int(spec.format.size() * 8);
  // The scene's colour space applies to integer files only: EXR/HDR are linear by definition.
  const std::string ext = LowerExtension(path);
  if (space == ColorSpace::kSRGB && !is_float && ext != ".exr" && ext != ".hdr") {
    for (size_t i = 0; i < img.pixels.size(); ++i)
      if (static_cast<int>(i % img.channels) != spec.alpha_channel) img.pixels[i] = SrgbToLinear(img.pixels[i]);
  }
  return img;
}

void WriteImage(const std::string& path, const Image& image, PixelFormat format, ColorSpace space) {
  if (image.width <= 0 || image.height <= 0 || image.channels <= 0 ||
      image.pixels.size() != size_t(image.width) * image.height * image.channels)
    throw Error(Msg(path, ": cannot write an empty or inconsistent image (", image.width, "x", image.height, "x",
                    image.channels, ", ", image.pixels.size(), " values)"));
  const std::string ext = LowerExtension(path);
  const bool integer = format == PixelFormat::kUInt8 || format == PixelFormat::kUInt16;
  if (integer && (ext == ".exr" || ext == ".hdr"))
    throw Error(Msg(path, ": ", ext, " stores floating point; use PixelFormat::kFloat or kHalf"));
  if (!integer && (ext == ".png" || ext == ".jpg" || ext == ".jpeg"))
    throw Error(Msg(path, ": ", ext, " stores integers; use PixelFormat::kUInt8 or kUInt16"));
  if (format == PixelFormat::kUInt16 && (ext == ".jpg" || ext == ".jpeg"))
    throw Error(Msg(path, ": JPEG holds 8 bits only"));

  OIIO::TypeDesc type = OIIO::TypeDesc::FLOAT;
  switch (format) {
    case PixelFormat::kFloat: type = OIIO::TypeDesc::FLOAT; break;
    case PixelFormat::kHalf: type = OIIO::TypeDesc::HALF; break;
    case PixelFormat::kUInt16: type = OIIO::TypeDesc::UINT16; break;
    case PixelFormat::kUInt8: type = OIIO::TypeDesc::UINT8; break;
  }
  OIIO::ImageSpec spec(image.width, image.height, image.channels, type);
  const bool srgb = integer && space == ColorSpace::kSRGB;
  spec.attribute("oiio:ColorSpace", srgb ? "sRGB" : "Linear");
  if (ext == ".jpg" || ext == ".jpeg") spec.attribute("Compression", "jpeg:98");

  std::vector<float> values = image.pixels;
  if (srgb)
    for (float& v : values) v = LinearToSrgb(std::clamp(v, 0.0f, 1.0f));

  const std::string tmp = TempSiblingPath(path);
  auto out = OIIO::ImageOutput::create(tmp);
  if (!out) throw Error(Msg(path, ": no writer for this format: ", OIIO::geterror()));
  bool ok = out->open(tmp, spec);
  // Quantise here (round to nearest) rather than rely on the library's conversion.
  if (ok && format == PixelFormat::kUInt8) ok = out->write_image(OIIO::TypeDesc::UINT8, Quantise<uint8_t>(values).data());
  else if (ok && format == PixelFormat::kUInt16) ok = out->write_image(OIIO::TypeDesc::UINT16, Quantise<uint16_t>(values).data());
  else if (ok) ok = out->write_image(OIIO::TypeDesc::FLOAT, values.data());
  const std::string err = ok ? "" : out->geterror();
  ok = out->close() && ok;
  if (!ok) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw Error(Msg(path, ": cannot write image: ", err.empty() ? out->geterror() : err));
  }
  CommitTemp(tmp, path);
}

Image ReadLabelImage(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw Error(Msg(path, ": cannot read label image: ", OIIO::geterror()));
  const OIIO::TypeDesc format = in->spec().format;
  in->close();
  if (format != OIIO::TypeDesc::UINT8 && format != OIIO::TypeDesc::UINT16)
    throw Error(Msg(path, ": label image must be 8- or 16-bit unsigned integer, is ", format.c_str()));
  Image img = ReadImage(path);
  // Undo the [0,1] normalisation of ReadImage to get the stored integers back.
  const float scale = format == OIIO::TypeDesc::UINT8 ? 255.0f : 65535.0f;
  for (float& v : img.pixels) v = std::round(v * scale);
  img.saturation_level = std::numeric_limits<float>::infinity();  // ids are not radiance
  return img;
}

void WriteLabelImage(const std::string& path, const Image& labels) {
  float max_id = 0;
  for (float v : labels.pixels) {
    if (!(v >= 0 && v <= 65535 && v == std::round(v)))
      throw Error(Msg(path, ": label value ", v, " is not an integer in [0, 65535]"));
    max_id = std::max(max_id, v);
  }
  const bool eight_bit = max_id <= 255;
  Image normalised = labels;
  for (float& v : normalised.pixels) v /= eight_bit ? 255.0f : 65535.0f;
  WriteImage(path, normalised, eight_bit ? PixelFormat::kUInt8 : PixelFormat::kUInt16);
}

float Image::Bilinear(double px, double py, int c) const {
  // Pixel (i, j) has its centre at (i + 0.5, j + 0.5).
  // NaN coordinates (from degenerate geometry) read the corner, never outside.
  const double x = std::isnan(px) ? 0.0 : std::clamp(px - 0.5, 0.0, double(width - 1));
  const double y = std::isnan(py) ? 0.0 : std::clamp(py - 0.5, 0.0, double(height - 1));
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
  const double tx = x - x0, ty = y - y0;
  const double top = (1 - tx) * at(x0, y0, c) + tx * at(x1, y0, c);
  const double bottom = (1 - tx) * at(x0, y1, c) + tx * at(x1, y1, c);
  return static_cast<float>((1 - ty) * top + ty * bottom);
}

double SaturatedFraction(const Image& image, const Image* mask) {
  long counted = 0, saturated = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      if (mask && mask->at(x, y, 0) <= 0) continue;
      ++counted;
      for (int c = 0; c < image.channels; ++c)
        if (image.at(x, y, c) >= image.saturation_level) {
          ++saturated;
          break;
        }
    }
  return counted == 0 ? 0.0 : double(saturated) / counted;
}

}  // namespace svbrdf
