// Exposure settings of a photograph from its EXIF header (OpenImageIO).
#pragma once
#include <string>

namespace svbrdf {

// Exposure settings from a photo's EXIF (OpenImageIO's ExposureTime, FNumber,
// Exif:PhotographicSensitivity); 0 where the file does not say.
struct ExifExposure {
  double seconds = 0, f_number = 0, iso = 0;
  // Light gathered relative to 1 s at f/1, ISO 100: seconds * (iso / 100) / f_number^2,
  // with missing f-number or ISO left out (they cancel when constant over a set).
  double Relative() const;
};
// Reads the header only; throws Error naming the file if it cannot be opened
// or has no ExposureTime.
ExifExposure ReadExifExposure(const std::string& path);

}  // namespace svbrdf
