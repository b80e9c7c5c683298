#include "io/exif.h"

#include <OpenImageIO/imageio.h>

#include "core/error.h"

namespace svbrdf {

double ExifExposure::Relative() const {
  double r = seconds;
  if (iso > 0) r *= iso / 100.0;
  if (f_number > 0) r /= f_number * f_number;
  return r;
}

ExifExposure ReadExifExposure(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw Error(Msg(path, ": cannot open (", OIIO::geterror(), ")"));
  const OIIO::ImageSpec& spec = in->spec();
  ExifExposure e;
  e.seconds = spec.get_float_attribute("ExposureTime", 0.0f);
  e.f_number = spec.get_float_attribute("FNumber", 0.0f);
  e.iso = spec.get_float_attribute("Exif:PhotographicSensitivity", spec.get_float_attribute("Exif:ISOSpeedRatings", 0.0f));
  in->close();
  if (!(e.seconds > 0)) throw Error(Msg(path, ": no EXIF ExposureTime; give the photo's \"exposures\" in capture.json"));
  return e;
}

}  // namespace svbrdf
