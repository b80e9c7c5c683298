// Light sources of the dataset contract (shared/spec/dataset.md) and the
// lecture: point (isotropic, I/r^2), directional, spot (I0 cos^n alpha, hard
// cutoff), goniometric (IESNA LM-63 table) and the camera-frame flash (a point
// light whose position is given in the camera frame of each image).
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "core/types.h"

namespace svbrdf {

// Candela table of an IESNA LM-63 file (type C photometry), sampled bilinearly
// in (vertical angle from the light axis, horizontal angle around it).
struct IesProfile {
  std::vector<double> vertical_deg;    // ascending, from 0 (axis)
  std::vector<double> horizontal_deg;  // ascending, from 0
  std::vector<double> candela;         // horizontal-major: [h * nv + v]
  double multiplier = 1.0;             // file's candela multiplier, already applied to `candela`
  // Relative intensity (candela) towards (vertical angle, horizontal angle), radians.
  double Intensity(double vertical_rad, double horizontal_rad) const;
  double MaxCandela() const;
};

// Parses an LM-63 file (1986/1991/1995/2002); throws Error naming the file and what is wrong.
IesProfile LoadIes(const std::string& path);
IesProfile ParseIes(const std::string& text, const std::string& context);

enum class LightType { kPoint, kDirectional, kSpot, kGoniometric };

struct Light {
  int id = 0;
  LightType type = LightType::kPoint;
  bool camera_frame = false;          // "frame": "camera" (flash)
  Vec3 position = Vec3::Zero();       // point, spot, goniometric (world or camera frame)
  Rgb intensity = Rgb::Zero();        // W/sr per channel (point, spot peak)
  Vec3 to_light = Vec3::UnitZ();      // directional: unit direction towards the light
  Rgb irradiance = Rgb::Zero();       // directional: irradiance on a surface facing it
  Vec3 direction = -Vec3::UnitZ();    // spot, goniometric: axis of the beam
  double exponent = 1.0;              // spot
  double cutoff_deg = 90.0;           // spot
  Vec3 up = Vec3::UnitY();            // goniometric: horizontal angle 0 direction
  std::string ies;                    // goniometric: path as written in scene.json
  double scale = 1.0;                 // goniometric: W/sr per candela of the file
  std::shared_ptr<const IesProfile> profile;  // goniometric: loaded table
};

// What a light delivers at a world point: direction towards the light, its
// distance (infinity for directional), and the irradiance on a surface facing
// the light (I/r^2, per channel). Irradiance on a surface with normal n is
// `normal_irradiance * max(0, n . wi)`.
struct LightSample {
  Vec3 wi = Vec3::UnitZ();
  double distance = 0;
  Rgb normal_irradiance = Rgb::Zero();
};

// `cam_centre_world` and `world_from_cam_rotation` place camera-frame lights;
// they are ignored for world-frame lights.
LightSample SampleLight(const Light& light, const Vec3& x_world, const Eigen::Quaterniond& world_from_cam,
                        const Vec3& cam_centre_world);

}  // namespace svbrdf
