#include "export/mitsuba.h"

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "atlas/atlas.h"
#include "core/error.h"
#include "export/directions.h"
#include "export/nearest_form.h"
#include "export/xml.h"
#include "io/image.h"
#include "io/mesh.h"

namespace svbrdf {

namespace fs = std::filesystem;
using json = nlohmann::json;

void MitsubaExportOptions::Check() const {
  if (spp < 1 || spp > 1 << 16) throw Error(Msg("export: --spp must be in [1, 65536], got ", spp));
}

double SpotBeamWidth(double exponent, double cutoff, double* error) {
  // Integrals over the cone in alpha with the solid-angle weight sin(alpha).
  const int n = 400;
  auto cost = [&](double bw, double* ref) {
    double diff = 0, norm = 0;
    for (int i = 0; i < n; ++i) {
      const double a = (i + 0.5) * cutoff / n;
      const double ours = std::pow(std::max(0.0, std::cos(a)), exponent);
      const double theirs = a <= bw ? 1.0 : (cutoff - a) / (cutoff - bw);
      diff += (ours - theirs) * (ours - theirs) * std::sin(a);
      norm += ours * ours * std::sin(a);
    }
    if (ref) *ref = norm;
    return diff;
  };
  double best = 0, best_cost = 1e300;
  for (int i = 0; i <= 200; ++i) {
    const double bw = cutoff * std::min(i / 200.0, 0.9999);  // beam_width = cutoff_angle would divide by 0
    const double c = cost(bw, nullptr);
    if (c < best_cost) best_cost = c, best = bw;
  }
  double norm = 0;
  cost(best, &norm);
  if (error) *error = norm > 0 ? std::sqrt(best_cost / norm) : 0.0;
  return best;
}

namespace {

XmlElement Named(const std::string& type, const std::string& name, const std::string& value) {
  XmlElement e(type);
  e.Attr("name", name).Attr("value", value);
  return e;
}
std::string Triple(const Vec3& v) { return Msg(XmlNumber(v[0]), ", ", XmlNumber(v[1]), ", ", XmlNumber(v[2])); }
std::string TripleRgb(const Rgb& v) { return Msg(XmlNumber(v[0]), ", ", XmlNumber(v[1]), ", ", XmlNumber(v[2])); }

XmlElement Bitmap(const std::string& name, const std::string& file) {
  XmlElement t("texture");
  t.Attr("type", "bitmap").Attr("name", name);
  t.Add(Named("string", "filename", file));
  t.Add(Named("string", "filter_type", "bilinear"));
  t.Add(Named("string", "wrap_mode", "clamp"));
  t.Add(Named("boolean", "raw", "true"));  // linear data: no colour-space conversion, no clamping
  return t;
}

// One lobe of the sum: a roughconductor with a baked reflectance texture, or a
// (rough)plastic with baked coat and base textures (see the header).
XmlElement Lobe(const NearestForm& f, const std::string& specular, const std::string& base) {
  XmlElement b("bsdf");
  const bool smooth = f.lobe == NearestForm::Lobe::kPlastic || f.lobe == NearestForm::Lobe::kConductor;
  const bool plastic = f.lobe == NearestForm::Lobe::kPlastic || f.lobe == NearestForm::Lobe::kRoughPlastic;
  b.Attr("type", f.lobe == NearestForm::Lobe::kConductor ? "conductor"
                 : f.lobe == NearestForm::Lobe::kPlastic ? "plastic"
                 : plastic                               ? "roughplastic"
                                                         : "roughconductor");
  if (!smooth) {
    b.Add(Named("string", "distribution", f.distribution == Distribution::kGGX ? "ggx" : "beckmann"));
    b.Add(Named("float", "alpha", XmlNumber(f.alpha)));
  }
  if (plastic) {
    b.Add(Named("float", "int_ior", XmlNumber(f.ior)));
    b.Add(Named("float", "ext_ior", "1"));
    b.Add(Named("boolean", "nonlinear", "true"));
    b.Add(Bitmap("diffuse_reflectance", base));
  } else if (!f.fresnel) {
    b.Add(Named("string", "material", "none"));
  } else if (f.k.isZero() && f.eta.maxCoeff() == f.eta.minCoeff()) {  // a dielectric
    b.Add(Named("float", "eta", XmlNumber(f.eta[0])));
    b.Add(Named("float", "k", "0"));
  } else {
    b.Add(Named("rgb", "eta", TripleRgb(f.eta)));
    b.Add(Named("rgb", "k", TripleRgb(f.k)));
  }
  b.Add(Bitmap("specular_reflectance", specular));
  return b;
}

json LobeReport(const NearestForm& f) {
  const char* dist = f.distribution == Distribution::kGGX ? "ggx" : "beckmann";
  if (f.lobe == NearestForm::Lobe::kPlastic)
    return {{"plugin", "plastic"}, {"int_ior", f.ior}, {"nonlinear", true},
            {"diffuse_reflectance", {f.base[0], f.base[1], f.base[2]}},
            {"internal_reflectance_mitsuba", f.smooth_internal_reflectance}};
  if (f.lobe == NearestForm::Lobe::kRoughPlastic)
    return {{"plugin", "roughplastic"}, {"distribution", dist}, {"alpha", f.alpha}, {"int_ior", f.ior},
            {"nonlinear", true}, {"diffuse_reflectance", {f.base[0], f.base[1], f.base[2]}},
            {"internal_reflectance_mitsuba", f.plastic.internal_reflectance}};
  json j = f.lobe == NearestForm::Lobe::kConductor
               ? json{{"plugin", "conductor"}, {"specular_reflectance", {f.rs[0], f.rs[1], f.rs[2]}}}
               : json{{"plugin", "roughconductor"}, {"distribution", dist}, {"alpha", f.alpha},
                      {"specular_reflectance", {f.rs[0], f.rs[1], f.rs[2]}}};
  if (f.fresnel) {
    j["eta"] = {f.eta[0], f.eta[1], f.eta[2]};
    j["k"] = {f.k[0], f.k[1], f.k[2]};
  } else {
    j["material"] = "none (F = 1)";
  }
  if (f.max_fresnel_error > 0) j["max_fresnel_error"] = f.max_fresnel_error;
  return j;
}

// Normal map -> Mitsuba's tangent-space `normalmap`, encoded 0.5 n + 0.5.
// Mitsuba's frame is ours (normal_map_space.h): N its interpolated shading
// normal, T its dp_du made orthogonal to N, B = N x T (its OBJ loader flips
// v, which negates dP/dv, not dP/du). So a tangent-space map is copied
// (and keeps the mesh's turn within a texel in Mitsuba as in relight); a
// world-space one is converted at the texel centres.
Image TangentSpaceNormals(const Material& m) {
  Image out(m.width, m.height, 3, 0.5f);
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) out.at(x, y, 2) = 1.0f;
  auto put = [&](int x, int y, const Vec3& local) {
    for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(0.5 * local[c] + 0.5);
  };
  auto value = [&](int x, int y) { return Vec3(m.normal_map.at(x, y, 0), m.normal_map.at(x, y, 1), m.normal_map.at(x, y, 2)); };
  if (m.normal_map_space == NormalMapSpace::kTangent) {
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x)
        if (value(x, y).squaredNorm() > 1e-12) put(x, y, value(x, y).normalized());
    return out;
  }
  const Atlas atlas = BuildAtlas(m.mesh, m.width, m.height);
  for (const Texel& t : atlas.texels) {
    const Vec3 w = value(t.x, t.y);
    if (!(w.squaredNorm() > 1e-12)) continue;
    put(t.x, t.y, MapValueFromNormal(w, NormalMapSpace::kTangent, t.normal, t.tangent));
  }
  return out;
}

struct Bounds {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  Vec3 Centre() const { return 0.5 * (lo + hi); }
  double Radius() const { return 0.5 * (hi - lo).norm(); }
};

// to_world of a sensor: Mitsuba's camera looks along +z with +y up and +x to
// the left, ours (COLMAP) has +y down and +x right, so its columns are
// (-x, -y, z) of world_from_cam's rotation `r`, x and y scaled by `scale`.
void AddSensorToWorld(const Mat3& r, double scale, const Vec3& origin, XmlElement* s) {
  std::string m;
  for (int i = 0; i < 3; ++i)
    m += Msg(XmlNumber(-scale * r(i, 0)), " ", XmlNumber(-scale * r(i, 1)), " ", XmlNumber(r(i, 2)), " ",
             XmlNumber(origin[i]), " ");
  m += "0 0 0 1";
  XmlElement& tr = s->Add(XmlElement("transform"));
  tr.Attr("name", "to_world");
  tr.Add(XmlElement("matrix")).Attr("value", m);
}

void AddSamplerAndFilm(const Camera& cam, int spp, XmlElement* s) {
  XmlElement& sampler = s->Add(XmlElement("sampler"));
  sampler.Attr("type", "independent");
  sampler.Add(Named("integer", "sample_count", std::to_string(spp)));
  XmlElement& film = s->Add(XmlElement("film"));
  film.Attr("type", "hdrfilm");
  film.Add(Named("integer", "width", std::to_string(cam.width)));
  film.Add(Named("integer", "height", std::to_string(cam.height)));
  film.Add(Named("string", "pixel_format", "rgb"));
  film.Add(Named("string", "component_format", "float32"));
  film.Add(XmlElement("rfilter")).Attr("type", "box");
}

// Mitsuba's orthographic sensor sees [-1, 1] x [-1/aspect, 1/aspect] of its
// local XY plane along +z (x to the left, y up); to_world scales that square
// to the film's extent in metres and moves its centre to the film centre.
XmlElement OrthographicSensor(const Camera& cam, const Rigid3& cam_from_world, const Bounds& bounds, int spp,
                              json* warnings, const std::string& where) {
  XmlElement s("sensor");
  s.Attr("type", "orthographic");
  const double sx = cam.fx(), sy = cam.fy();
  if (std::abs(sx - sy) > 1e-6 * sx)
    warnings->push_back(Msg(where, ": sx = ", sx, " and sy = ", sy, " differ; Mitsuba has square pixels, sy is ignored"));
  const double half_width = 0.5 * cam.width / sx;  // metres
  const Vec3 centre_cam((0.5 * cam.width - cam.cx()) / sx, (0.5 * cam.height - cam.cy()) / sx, 0.0);
  const Rigid3 world_from_cam = cam_from_world.Inverse();
  const Vec3 origin = world_from_cam * centre_cam;
  const double dist = std::abs((cam_from_world * bounds.Centre()).z());
  s.Add(Named("float", "near_clip", XmlNumber(1e-5)));
  s.Add(Named("float", "far_clip", XmlNumber(10 * (dist + bounds.Radius()))));
  AddSensorToWorld(world_from_cam.rotation.toRotationMatrix(), half_width, origin, &s);
  AddSamplerAndFilm(cam, spp, &s);
  return s;
}

XmlElement Sensor(const Camera& cam, const Rigid3& cam_from_world, const Bounds& bounds, int spp, json* warnings,
                  const std::string& where) {
  if (cam.IsOrthographic()) return OrthographicSensor(cam, cam_from_world, bounds, spp, warnings, where);
  XmlElement s("sensor");
  s.Attr("type", "perspective");
  const double fx = cam.fx(), fy = cam.fy();
  if (std::abs(fx - fy) > 1e-6 * fx)
    warnings->push_back(Msg(where, ": fx = ", fx, " and fy = ", fy, " differ; Mitsuba has square pixels, fy is ignored (",
                            100 * std::abs(fx - fy) / fx, " % vertical scale error)"));
  for (size_t i = 0; i < cam.params.size(); ++i) {
    const int first_distortion = cam.model == CameraModelId::kPinhole || cam.model == CameraModelId::kOpenCV ? 4 : 3;
    if (int(i) >= first_distortion && cam.params[i] != 0) {
      warnings->push_back(Msg(where, ": lens distortion (", CameraModelName(cam.model),
                              ") is ignored; Mitsuba's perspective sensor is a pinhole"));
      break;
    }
  }
  s.Add(Named("string", "fov_axis", "x"));
  s.Add(Named("float", "fov", XmlNumber(2 * std::atan(0.5 * cam.width / fx) * 180 / kPi)));
  // Mitsuba puts the principal point at film position (0.5 - offset_x,
  // 0.5 - offset_y) in units of the film's width and height (probed with
  // Mitsuba 3.9 Sensor.sample_ray; scripts/check_mitsuba_export.py checks it
  // against relight).
  s.Add(Named("float", "principal_point_offset_x", XmlNumber((0.5 * cam.width - cam.cx()) / cam.width)));
  s.Add(Named("float", "principal_point_offset_y", XmlNumber((0.5 * cam.height - cam.cy()) / cam.height)));
  const Vec3 eye = cam_from_world.CentreInWorld();
  const double dist = (bounds.Centre() - eye).norm();
  s.Add(Named("float", "near_clip", XmlNumber(std::max(1e-5, 0.01 * std::max(dist - bounds.Radius(), 0.01 * dist)))));
  s.Add(Named("float", "far_clip", XmlNumber(10 * (dist + bounds.Radius()))));
  // Mitsuba's camera looks along +z with +y up and +x to the left; ours
  // (COLMAP) has +y down and +x right: to_world = world_from_cam diag(-1, -1, 1).
  const Mat3 r = cam_from_world.rotation.conjugate().toRotationMatrix();
  AddSensorToWorld(r, 1.0, eye, &s);
  AddSamplerAndFilm(cam, spp, &s);
  return s;
}

XmlElement Emitter(const Light& light, const ImageEntry& e, const Bounds& bounds, json* warnings,
                   const std::string& where) {
  const Rigid3 world_from_cam = e.cam_from_world.Inverse();
  auto dir_world = [&](const Vec3& d) -> Vec3 { return light.camera_frame ? Vec3(world_from_cam.rotation * d) : d; };
  const Vec3 pos = light.camera_frame ? Vec3(world_from_cam * light.position) : light.position;
  XmlElement em("emitter");
  const double x = e.exposure;
  switch (light.type) {
    case LightType::kPoint:
      em.Attr("type", "point");
      em.Add(Named("point", "position", Triple(pos)));
      em.Add(Named("rgb", "intensity", TripleRgb(x * light.intensity)));
      break;
    case LightType::kDirectional:
      em.Attr("type", "directional");
      em.Add(Named("vector", "direction", Triple(-dir_world(light.to_light).normalized())));
      em.Add(Named("rgb", "irradiance", TripleRgb(x * light.irradiance)));
      break;
    case LightType::kSpot: {
      em.Attr("type", "spot");
      const Vec3 axis = dir_world(light.direction).normalized();
      double err = 0;
      const double cutoff = std::min(light.cutoff_deg, 89.9) * kPi / 180;
      const double bw = SpotBeamWidth(light.exponent, cutoff, &err);
      em.Add(Named("rgb", "intensity", TripleRgb(x * light.intensity)));
      em.Add(Named("float", "cutoff_angle", XmlNumber(cutoff * 180 / kPi)));
      em.Add(Named("float", "beam_width", XmlNumber(bw * 180 / kPi)));
      XmlElement& tr = em.Add(XmlElement("transform"));
      tr.Attr("name", "to_world");
      tr.Add(XmlElement("lookat"))
          .Attr("origin", Triple(pos))
          .Attr("target", Triple(pos + axis))
          .Attr("up", Triple(axis.unitOrthogonal()));
      if (err > 1e-3 || light.cutoff_deg > 89.9)
        warnings->push_back(Msg(where, ": spot light ", light.id, " cos^", light.exponent, " falloff approximated by Mitsuba's linear ramp (beam_width ",
                                bw * 180 / kPi, " deg): relative RMS intensity error ", err, " over the cone"));
      break;
    }
    case LightType::kGoniometric: {
      // Nearest form: a point light with the profile's intensity towards the object's centre.
      em.Attr("type", "point");
      em.Add(Named("point", "position", Triple(pos)));
      const LightSample ls = SampleLight(light, bounds.Centre(), world_from_cam.rotation, world_from_cam.translation);
      em.Add(Named("rgb", "intensity", TripleRgb(x * ls.normal_irradiance * ls.distance * ls.distance)));
      warnings->push_back(Msg(where, ": goniometric light ", light.id,
                              " exported as a point light with its intensity towards the object's centre (Mitsuba 3 has no IES emitter)"));
      break;
    }
  }
  return em;
}

XmlElement SceneRoot() {
  XmlElement s("scene");
  s.Attr("version", "3.0.0");
  return s;
}

XmlElement Include(const std::string& file) {
  XmlElement i("include");
  i.Attr("filename", file);
  return i;
}

// Direct light, as the reconstruction fitted it; a material fitted after
// its photos' interreflection was removed (info.interreflection) gets that
// many bounces back from a path tracer (max_depth counts path segments:
// 2 = direct light).
XmlElement Integrator(const Material& m) {
  XmlElement i("integrator");
  const int bounces = MaterialBounces(m);
  if (bounces == 0) {
    i.Attr("type", "direct").Comment("direct light only, as svbrdf relight and the reconstruction assume");
    return i;
  }
  i.Attr("type", "path").Comment(Msg("the material was fitted to direct light after ", bounces,
                                     " bounces of interreflection were removed: they are rendered here"));
  i.Add(Named("integer", "max_depth", std::to_string(bounces + 2)));
  return i;
}

void WriteXml(const std::string& path, const XmlElement& root, const std::string& header) {
  WriteFileAtomic(path, "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<!-- " + header + " -->\n" + root.ToString());
}

}  // namespace

nlohmann::json ExportMitsuba(const Material& m, const Scene* scene, const MitsubaExportOptions& o,
                             const std::string& dir) {
  o.Check();
  const DirectionPairs pairs = DirectionPairs::Standard();
  json report;
  report["format"] = "mitsuba3";
  json warnings = json::array();
  const int K = static_cast<int>(m.basis.size());

  // Map every basis material; count the parts of the sum.
  std::vector<NearestForm> forms;
  int lobes = 0;
  for (const BasisMaterial& b : m.basis) {
    forms.push_back(MapToNearestForm(b, pairs));
    lobes += forms.back().has_lobe();
    const NearestForm& f = forms.back();
    json jb = {{"name", b.name}, {"model", b.spec.Label()}, {"exact", f.exact}, {"mapping", f.how},
               {"relative_error", f.error}, {"diffuse_rd", {f.rd[0], f.rd[1], f.rd[2]}}};
    if (f.has_lobe()) jb["lobe"] = LobeReport(f);
    report["basis"].push_back(jb);
    if (!f.exact)
      warnings.push_back(Msg("basis '", b.name, "' (", b.spec.Label(), ") has no exact Mitsuba form: ", f.how,
                             " (relative error ", f.error, "); `svbrdf reconstruct SCENE --for mitsuba` fits only "
                             "models Mitsuba renders exactly"));
  }
  const int parts = 1 + lobes;
  // The material as Mitsuba renders it (every basis replaced by its form),
  // so that relight can render exactly what the Mitsuba scene holds.
  Material as_rendered = m;
  for (int k = 0; k < K; ++k) as_rendered.basis[k] = forms[k].AsBasis(m.basis[k].name);
  as_rendered.extra = {{"source", "svbrdf export --format mitsuba: the basis materials' Mitsuba forms"}, {"from", m.dir}};
  SaveMaterial(as_rendered, (fs::path(dir) / "as_rendered").string());

  // Baked textures (see header): everything times `parts`.
  fs::create_directories(fs::path(dir) / "textures");
  Image diffuse(m.width, m.height, 3, 0.0f);
  std::vector<XmlElement> bsdfs;
  for (int k = 0; k < K; ++k) {
    const Image& w = m.weights[k];
    for (size_t i = 0; i < diffuse.pixels.size(); ++i) diffuse.pixels[i] += float(parts * w.pixels[i] * forms[k].rd[i % 3]);
    if (!forms[k].has_lobe()) continue;
    const NearestForm& f = forms[k];
    const bool smooth = f.lobe == NearestForm::Lobe::kPlastic;
    const bool plastic = smooth || f.lobe == NearestForm::Lobe::kRoughPlastic;
    Image spec(m.width, m.height, 3, 0.0f), base;
    for (size_t i = 0; i < spec.pixels.size(); ++i) spec.pixels[i] = float(parts * w.pixels[i] * (plastic ? 1.0 : f.rs[i % 3]));
    // by index: names may hold any character
    const std::string spec_file = Msg("textures/m", k, "_specular.exr"), base_file = Msg("textures/m", k, "_base.exr");
    WriteImage((fs::path(dir) / spec_file).string(), spec, PixelFormat::kFloat);
    if (plastic) {
      // Weight x coupling, then the diffuse_reflectance with that coupling in Mitsuba.
      const double f_int = smooth ? f.smooth_internal_reflectance : f.plastic.internal_reflectance;
      base = Image(m.width, m.height, 3, 0.0f);
      for (size_t i = 0; i < base.pixels.size(); ++i) {
        const double b = f.base[i % 3];
        base.pixels[i] = float(BaseForCoupling(parts * w.pixels[i] * b / (1 - b * f_int), f_int));
      }
      WriteImage((fs::path(dir) / base_file).string(), base, PixelFormat::kFloat);
    }
    bsdfs.push_back(Lobe(f, spec_file, base_file));
    bsdfs.back().Comment(Msg("basis material ", m.basis[k].name, " (", m.basis[k].spec.Label(), "): ", f.how));
  }
  WriteImage((fs::path(dir) / "textures/diffuse.exr").string(), diffuse, PixelFormat::kFloat);
  XmlElement diffuse_bsdf("bsdf");
  diffuse_bsdf.Attr("type", "diffuse").Comment("sum over basis materials of weight x diffuse albedo");
  diffuse_bsdf.Add(Bitmap("reflectance", "textures/diffuse.exr"));
  bsdfs.insert(bsdfs.begin(), diffuse_bsdf);

  // Nested blend of constant weights = average of the parts.
  XmlElement sum = bsdfs.back();
  for (int i = parts - 2; i >= 0; --i) {
    XmlElement blend("bsdf");
    blend.Attr("type", "blendbsdf");
    blend.Add(Named("float", "weight", XmlNumber(double(parts - i - 1) / (parts - i))));
    blend.Add(bsdfs[i]);
    blend.Add(sum);
    sum = blend;
  }
  if (parts > 1)
    sum.Comment(Msg("average of ", parts, " parts whose textures are multiplied by ", parts, ": their exact sum"));
  if (m.normal_map.width) {
    WriteImage((fs::path(dir) / "textures/normal.exr").string(), TangentSpaceNormals(m), PixelFormat::kFloat);
    XmlElement nm("bsdf");
    nm.Attr("type", "normalmap");
    nm.Add(Bitmap("normalmap", "textures/normal.exr"));
    nm.Add(sum);
    sum = nm;
    report["normal_map"] = "textures/normal.exr (tangent space)";
  }
  sum.Attr("id", "material");

  // Mesh with relight's normals.
  SaveObj(m.mesh, (fs::path(dir) / "mesh.obj").string(), /*write_normals=*/true);
  XmlElement object = SceneRoot();
  object.Add(sum);
  XmlElement& shape = object.Add(XmlElement("shape"));
  shape.Attr("type", "obj");
  shape.Add(Named("string", "filename", "mesh.obj"));
  shape.Add(XmlElement("ref")).Attr("id", "material");
  WriteXml((fs::path(dir) / "object.xml").string(), object, "svbrdf export: the reconstructed object (BSDF + mesh)");

  Bounds bounds;
  for (const Vec3& p : m.mesh.positions) bounds.lo = bounds.lo.cwiseMin(p), bounds.hi = bounds.hi.cwiseMax(p);

  json views = json::array();
  if (scene) {
    for (size_t i = 0; i < scene->images.size(); ++i) {
      const ImageEntry& e = scene->images[i];
      const std::string where = Msg("images[", i, "] (", e.file, ")");
      XmlElement root = SceneRoot();
      root.Add(Include("object.xml"));
      root.Add(Integrator(m));
      root.Add(Sensor(scene->CameraById(e.camera), e.cam_from_world, bounds, o.spp, &warnings, where));
      root.Add(Emitter(scene->LightById(e.light), e, bounds, &warnings, where))
          .Comment(Msg("light ", e.light, ", scaled by the image's exposure ", e.exposure));
      char file_buf[32];
      std::snprintf(file_buf, sizeof(file_buf), "view_%04zu.xml", i);
      const std::string file = file_buf;
      WriteXml((fs::path(dir) / file).string(), root, Msg("svbrdf export: ", e.file));
      if (i == 0) WriteXml((fs::path(dir) / "scene.xml").string(), root, Msg("svbrdf export: first view, ", e.file));
      views.push_back({{"xml", file}, {"image", e.file}, {"mask", e.mask}, {"exposure", e.exposure}});
    }
  }
  if (!scene || scene->images.empty()) {
    // A default view: camera on +z looking at the object, constant white environment.
    Camera cam;
    cam.model = CameraModelId::kPinhole;
    cam.width = 640;
    cam.height = 480;
    cam.params = {640, 640, 320, 240};
    const Vec3 c = bounds.Centre();
    const Rigid3 pose = Rigid3::LookAt(c + Vec3(0, 0, 3 * bounds.Radius() + 1e-6), c, Vec3::UnitY());
    XmlElement root = SceneRoot();
    root.Add(Include("object.xml"));
    root.Add(Integrator(m));
    root.Add(Sensor(cam, pose, bounds, o.spp, &warnings, "default view"));
    XmlElement& env = root.Add(XmlElement("emitter"));
    env.Attr("type", "constant");
    env.Add(Named("rgb", "radiance", "1, 1, 1"));
    WriteXml((fs::path(dir) / "scene.xml").string(), root, "svbrdf export: default view under a white environment");
  }
  WriteFileAtomic((fs::path(dir) / "views.json").string(), views.dump(2));
  report["parts"] = parts;
  report["views"] = views.size();
  report["warnings"] = warnings;
  WriteFileAtomic((fs::path(dir) / "export_report.json").string(), report.dump(2));
  return report;
}

}  // namespace svbrdf
