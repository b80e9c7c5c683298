#include "synth/ground_truth.h"

#include <cmath>
#include <limits>

#include "atlas/atlas.h"
#include "brdf/fresnel.h"
#include "brdf/metals.h"
#include "core/error.h"
#include "core/rng.h"

namespace svbrdf {

void GroundTruthOptions::Check() const {
  if (num_materials < 1 || num_materials > 8) throw Error(Msg("ground truth: num_materials must be 1..8, got ", num_materials));
  if (!models.empty() && int(models.size()) != num_materials)
    throw Error(Msg("ground truth: models lists ", models.size(), " labels for ", num_materials, " materials"));
  if (!params.empty() && int(params.size()) != num_materials)
    throw Error(Msg("ground truth: params lists ", params.size(), " entries for ", num_materials, " materials"));
  if (texture_size < 8 || texture_size > 8192) throw Error(Msg("ground truth: texture_size must be 8..8192, got ", texture_size));
  if (!(blend > 0)) throw Error("ground truth: blend must be > 0");
  if (variation < 0 || variation >= 1) throw Error("ground truth: variation must be in [0, 1)");
  if (bump < 0) throw Error("ground truth: bump must be >= 0");
}

void SetParam(BasisMaterial* b, const std::string& name, double value) {
  const auto params = b->spec.Params();
  std::string valid;
  for (size_t i = 0; i < params.size(); ++i) {
    if (params[i].name == name) {
      b->params[i] = value;
      return;
    }
    valid += (i ? ", " : "") + params[i].name;
  }
  throw Error(Msg("model ", b->spec.Label(), " has no parameter '", name, "' (valid: ", valid, ")"));
}

void SetMetal(BasisMaterial* b, const std::string& metal) {
  const brdf::MetalConstants* m = brdf::FindMetal(metal);
  if (!m) {
    std::string known;
    for (const auto& k : brdf::PublishedMetals()) known += (known.empty() ? "" : ", ") + std::string(k.name);
    throw Error(Msg("unknown metal '", metal, "' (known: ", known, ")"));
  }
  if (b->spec.family != Family::kConductor)
    throw Error(Msg("metal '", metal, "' needs a conductor model, not ", b->spec.Label()));
  const char* channel[3] = {"_r", "_g", "_b"};
  for (int c = 0; c < 3; ++c) {
    if (b->spec.fresnel == FresnelMode::kExact) {
      SetParam(b, std::string("eta") + channel[c], m->eta[c]);
      SetParam(b, std::string("kappa") + channel[c], m->kappa[c]);
      continue;
    }
    SetParam(b, std::string("f0") + channel[c], brdf::ConductorF0(m->eta[c], m->kappa[c]));
    if (b->spec.fresnel == FresnelMode::kF82Tint)
      SetParam(b, std::string("f82_tint") + channel[c], brdf::ConductorF82Tint(m->eta[c], m->kappa[c]));
  }
}

void ApplyParams(BasisMaterial* b, const MaterialParams& p) {
  if (!p.metal.empty()) SetMetal(b, p.metal);
  for (const auto& [name, value] : p.values) SetParam(b, name, value);
  const auto infos = b->spec.Params();
  for (size_t i = 0; i < infos.size(); ++i)
    if (!(b->params[i] >= infos[i].lower && b->params[i] <= infos[i].upper))
      throw Error(Msg("material ", b->name, " (", b->spec.Label(), "): ", infos[i].name, " = ", b->params[i],
                      " is outside its range [", infos[i].lower, ", ", infos[i].upper, "]"));
}

double GetParam(const BasisMaterial& b, const std::string& name) {
  const auto params = b.spec.Params();
  for (size_t i = 0; i < params.size(); ++i)
    if (params[i].name == name) return b.params[i];
  throw Error(Msg("model ", b.spec.Label(), " has no parameter '", name, "'"));
}

bool HasParam(const BasisMaterial& b, const std::string& name) {
  for (const ParamInfo& p : b.spec.Params())
    if (p.name == name) return true;
  return false;
}

namespace {

void SetRgb(BasisMaterial* b, const std::string& prefix, const Rgb& v) {
  SetParam(b, prefix + "_r", v[0]);
  SetParam(b, prefix + "_g", v[1]);
  SetParam(b, prefix + "_b", v[2]);
}

// A small library of distinct, plausible materials. Colours and highlights
// differ enough that clusters are separable, as in real multi-material objects.
struct LibraryEntry {
  const char* label;
  Rgb diffuse;
  Rgb specular;   // rs (cook-torrance, lobes) or lobe albedo (lafortune)
  double shape;   // roughness (cook-torrance), exponent (lafortune/phong), sigma (oren-nayar)
};
const LibraryEntry kLibrary[] = {
    {"cook_torrance-beckmann", {0.55, 0.12, 0.08}, {0.35, 0.35, 0.35}, 0.18},  // red plastic
    {"lafortune-1", {0.08, 0.18, 0.45}, {1.5, 1.5, 1.5}, 30.0},               // blue glossy paint
    {"lambert", {0.25, 0.5, 0.15}, {0, 0, 0}, 0},                             // green matte
    {"oren_nayar", {0.6, 0.5, 0.3}, {0, 0, 0}, 0.5},                          // rough clay
    {"cook_torrance-ggx", {0.04, 0.04, 0.05}, {0.9, 0.7, 0.35}, 0.25},        // brushed gold
    {"lafortune-2", {0.3, 0.3, 0.32}, {0.8, 0.8, 0.8}, 12.0},                 // two-lobe grey satin
    {"blinn_phong", {0.4, 0.1, 0.4}, {0.2, 0.2, 0.2}, 60.0},                  // purple
    {"lambert", {0.7, 0.7, 0.65}, {0, 0, 0}, 0},                              // white matte
};
constexpr int kLibrarySize = sizeof(kLibrary) / sizeof(kLibrary[0]);

}  // namespace

BasisMaterial LibraryMaterial(int i, const std::string& label) {
  const LibraryEntry& e = kLibrary[i % kLibrarySize];
  BasisMaterial b;
  b.name = Msg("m", i);
  b.spec = ModelSpec::FromLabel(label.empty() ? e.label : label);
  b.params = b.spec.InitialParams();
  if (HasParam(b, "rd_r")) SetRgb(&b, "rd", e.diffuse);  // metals and base-colour models have none
  switch (b.spec.family) {
    case Family::kLambert:
      break;
    case Family::kOrenNayar:
      SetParam(&b, "sigma", e.shape > 0 ? e.shape : 0.3);
      break;
    case Family::kPhong:
    case Family::kBlinnPhong:
    case Family::kCosineLobe:
      SetRgb(&b, "rs", e.specular.maxCoeff() > 0 ? e.specular : Rgb(0.2, 0.2, 0.2));
      SetParam(&b, "exponent", e.shape > 1 ? e.shape : 40.0);
      break;
    case Family::kCookTorrance:
      SetRgb(&b, "rs", e.specular.maxCoeff() > 0 ? e.specular : Rgb(0.3, 0.3, 0.3));
      SetParam(&b, "roughness", e.shape > 0 && e.shape < 1 ? e.shape : 0.2);
      SetParam(&b, "ior", 1.5);
      break;
    case Family::kLafortune:
      for (int l = 0; l < b.spec.lobes; ++l) {
        const std::string p = Msg("lobe", l, ".");
        // Lobes get successively broader and dimmer, the second slightly off-specular.
        const double n = (e.shape > 1 ? e.shape : 30.0) / (1 + 2 * l);
        const Rgb rho = (e.specular.maxCoeff() > 0 ? e.specular : Rgb(1, 1, 1)) / (1 + l);
        SetRgb(&b, p + "rho", rho);
        SetParam(&b, p + "cx", l == 0 ? -1.0 : -0.8);
        if (b.spec.anisotropic) SetParam(&b, p + "cy", l == 0 ? -0.7 : -0.8);
        SetParam(&b, p + "cz", l == 0 ? 1.0 : 0.9);
        SetParam(&b, p + "n", n);
      }
      break;
    case Family::kConductor:  // a metal has no diffuse colour: gold, whatever the entry
      SetMetal(&b, "gold");
      SetParam(&b, "roughness", e.shape > 0 && e.shape < 1 ? e.shape : 0.2);
      break;
    case Family::kCoated:
      SetParam(&b, "roughness", e.shape > 0 && e.shape < 1 ? e.shape : 0.15);
      SetParam(&b, "ior", 1.5);
      break;
    case Family::kPlastic:
      SetParam(&b, "ior", 1.5);
      break;
    case Family::kMirror:  // a metal has no diffuse colour: gold's F0, whatever the entry
      SetRgb(&b, "f0", Rgb(0.95, 0.65, 0.33));
      break;
    case Family::kGltf:
    case Family::kPrincipled:
      SetRgb(&b, "base_color", e.diffuse);
      SetParam(&b, "roughness", e.shape > 0 && e.shape < 1 ? e.shape : 0.4);
      break;
  }
  return b;
}

Material MakeGroundTruth(const Mesh& mesh, const GroundTruthOptions& options) {
  options.Check();
  Material m;
  m.mesh = mesh;
  m.width = m.height = options.texture_size;
  for (int k = 0; k < options.num_materials; ++k) {
    m.basis.push_back(LibraryMaterial(k, options.models.empty() ? "" : options.models[k]));
    if (!options.params.empty()) ApplyParams(&m.basis.back(), options.params[k]);
  }

  const Atlas atlas = BuildAtlas(mesh, m.width, m.height, 2, options.cover_small_triangles);
  if (atlas.texels.empty()) throw Error("ground truth: the mesh's UVs cover no texel");

  // Well-spread region seeds: farthest-point sampling over texel positions,
  // starting from a seeded random texel.
  Rng rng(options.seed);
  std::vector<Vec3> seeds{atlas.texels[rng() % atlas.texels.size()].position};
  std::vector<double> nearest(atlas.texels.size(), std::numeric_limits<double>::infinity());
  while (int(seeds.size()) < options.num_materials) {
    size_t best = 0;
    for (size_t t = 0; t < atlas.texels.size(); ++t) {
      nearest[t] = std::min(nearest[t], (atlas.texels[t].position - seeds.back()).norm());
      if (nearest[t] > nearest[best]) best = t;
    }
    seeds.push_back(atlas.texels[best].position);
  }

  for (int k = 0; k < options.num_materials; ++k) m.weights.emplace_back(m.width, m.height, 3, 0.0f);
  m.material_id = Image(m.width, m.height, 1, 0.0f);  // texels outside the atlas: 0 (their weights are 0)
  if (options.bump > 0) m.normal_map = Image(m.width, m.height, 3, 0.0f);
  const Vec3 phase(rng() % 1000 / 1000.0 * 6.28, rng() % 1000 / 1000.0 * 6.28, rng() % 1000 / 1000.0 * 6.28);

  for (const Texel& tx : atlas.texels) {
    std::vector<double> d(options.num_materials);
    double dmin = std::numeric_limits<double>::infinity();
    int id = 0;
    for (int k = 0; k < options.num_materials; ++k) {
      d[k] = (tx.position - seeds[k]).norm();
      if (d[k] < dmin) dmin = d[k], id = k;
    }
    // Soft Voronoi: weight exp(-(d_k - d_min)/blend), normalised.
    double sum = 0;
    for (double& v : d) sum += (v = std::exp(-(v - dmin) / options.blend));
    const Vec3& p = tx.position;
    for (int k = 0; k < options.num_materials; ++k)
      for (int c = 0; c < 3; ++c) {
        // Smooth, channel-dependent variation (paint thickness, dirt).
        const double var = 1.0 + options.variation * std::sin(7.0 * p.x() + 5.0 * p.y() + phase[c] + 2.0 * k) *
                                     std::cos(6.0 * p.z() - 4.0 * p.y() + phase[(c + 1) % 3]);
        m.weights[k].at(tx.x, tx.y, c) = float(d[k] / sum * var);
      }
    m.material_id.at(tx.x, tx.y, 0) = float(id);
    if (options.bump > 0) {
      // Bumps h = bump/f * sin(f x) sin(f y) sin(f z); n' = normalize(n - grad_tangential h).
      const double f = 25.0;
      const Vec3 g(options.bump * std::cos(f * p.x()) * std::sin(f * p.y()) * std::sin(f * p.z()),
                   options.bump * std::sin(f * p.x()) * std::cos(f * p.y()) * std::sin(f * p.z()),
                   options.bump * std::sin(f * p.x()) * std::sin(f * p.y()) * std::cos(f * p.z()));
      const Vec3 gt = g - tx.normal * tx.normal.dot(g);
      const Vec3 n = (tx.normal - gt).normalized();
      for (int c = 0; c < 3; ++c) m.normal_map.at(tx.x, tx.y, c) = float(n[c]);
    }
  }
  m.confidence = Image(m.width, m.height, 1, 1.0f);
  m.extra = {{"source", "svbrdf synth ground truth"}, {"seed", options.seed}};
  return m;
}

}  // namespace svbrdf
