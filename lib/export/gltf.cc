// glTF 2.0 writer (see gltf.h).
#include "export/gltf.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>

#include "atlas/atlas.h"
#include "core/error.h"
#include "io/files.h"
#include "io/image.h"
#include "io/scene.h"

namespace svbrdf {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// glTF constants (specification section 5).
constexpr int kFloat = 5126, kUInt = 5125, kArrayBuffer = 34962, kElementArrayBuffer = 34963;

struct SplitMesh {
  std::vector<float> positions, normals, uvs, tangents;  // 3, 3, 2, 4 floats per vertex
  std::vector<uint32_t> indices;
  std::vector<Vec3i> corner_vertex;  // per face: the split vertex of each corner
};

SplitMesh Split(const Mesh& mesh, bool with_tangents) {
  SplitMesh s;
  std::map<std::pair<int, int>, uint32_t> ids;
  std::vector<Vec3> tan_sum, bit_sum;
  std::vector<int> pos_of;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    Vec3i cv;
    for (int k = 0; k < 3; ++k) {
      const int p = mesh.faces[f][k], t = mesh.face_uvs[f][k];
      auto [it, inserted] = ids.emplace(std::make_pair(p, t), uint32_t(pos_of.size()));
      if (inserted) {
        pos_of.push_back(p);
        for (int c = 0; c < 3; ++c) s.positions.push_back(float(mesh.positions[p][c]));
        Vec3 n = mesh.normals[p].normalized();
        if (!n.allFinite()) n = Vec3::UnitZ();  // isolated or degenerate vertex: any unit normal keeps the file valid
        for (int c = 0; c < 3; ++c) s.normals.push_back(float(n[c]));
        s.uvs.push_back(float(mesh.texcoords[t].x()));
        s.uvs.push_back(float(1.0 - mesh.texcoords[t].y()));  // glTF: v down, origin at the image's top left
        tan_sum.push_back(Vec3::Zero());
        bit_sum.push_back(Vec3::Zero());
      }
      cv[k] = int(it->second);
      s.indices.push_back(it->second);
    }
    s.corner_vertex.push_back(cv);
    if (!with_tangents) continue;
    // dP/du and dP/dv (OBJ v, up in the image) of the face.
    const Vec3i& i = mesh.faces[f];
    const Vec3i& j = mesh.face_uvs[f];
    const Vec3 e1 = mesh.positions[i[1]] - mesh.positions[i[0]], e2 = mesh.positions[i[2]] - mesh.positions[i[0]];
    const Vec2 d1 = mesh.texcoords[j[1]] - mesh.texcoords[j[0]], d2 = mesh.texcoords[j[2]] - mesh.texcoords[j[0]];
    const double det = d1.x() * d2.y() - d1.y() * d2.x();
    if (std::abs(det) < 1e-300) continue;
    const Vec3 dpdu = (e1 * d2.y() - e2 * d1.y()) / det, dpdv = (e2 * d1.x() - e1 * d2.x()) / det;
    const double area = 0.5 * e1.cross(e2).norm();
    for (int k = 0; k < 3; ++k) {
      tan_sum[cv[k]] += area * dpdu.normalized();
      bit_sum[cv[k]] += area * dpdv.normalized();
    }
  }
  if (with_tangents) {
    for (size_t v = 0; v < pos_of.size(); ++v) {
      const Vec3 n(s.normals[3 * v], s.normals[3 * v + 1], s.normals[3 * v + 2]);
      Frame fr = Frame::FromNormalTangent(n, tan_sum[v]);
      // glTF: bitangent = cross(normal, tangent) * w; choose w so it points along +v (OBJ), up in the image.
      const double w = fr.n.cross(fr.t).dot(bit_sum[v]) < 0 ? -1.0 : 1.0;
      for (int c = 0; c < 3; ++c) s.tangents.push_back(float(fr.t[c]));
      s.tangents.push_back(float(w));
    }
  }
  return s;
}

// Normal map -> glTF tangent-space normal texture (0.5 n + 0.5), in the frame
// a viewer interpolates from the vertex normals and TANGENTs (whose vertex
// tangents are not our per-face dP/du: converted at the texel centres,
// through the world normal that the map gives there in either space).
Image TangentNormals(const Material& m, const SplitMesh& s) {
  const Atlas atlas = BuildAtlas(m.mesh, m.width, m.height);
  Image out(m.width, m.height, 3, 0.5f);
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) out.at(x, y, 2) = 1.0f;
  for (const Texel& t : atlas.texels) {
    const Vec3i& cv = s.corner_vertex[t.prim];
    const double b[3] = {1 - t.b1 - t.b2, t.b1, t.b2};
    Vec3 n = Vec3::Zero(), tan = Vec3::Zero();
    double w = 0;
    for (int k = 0; k < 3; ++k) {
      for (int c = 0; c < 3; ++c) {
        n[c] += b[k] * s.normals[3 * cv[k] + c];
        tan[c] += b[k] * s.tangents[4 * cv[k] + c];
      }
      w += b[k] * s.tangents[4 * cv[k] + 3];
    }
    n.normalize();
    tan = (tan - n * n.dot(tan)).normalized();
    const Vec3 bit = n.cross(tan) * (w < 0 ? -1.0 : 1.0);
    const Vec3 value(m.normal_map.at(t.x, t.y, 0), m.normal_map.at(t.x, t.y, 1), m.normal_map.at(t.x, t.y, 2));
    if (!(value.squaredNorm() > 1e-12) || !tan.allFinite()) continue;
    const Vec3 nw = NormalFromMapValue(value, m.normal_map_space, t.normal, t.tangent);
    const Vec3 local(nw.dot(tan), nw.dot(bit), nw.dot(n));
    for (int c = 0; c < 3; ++c) out.at(t.x, t.y, c) = float(0.5 * local[c] + 0.5);
  }
  return out;
}

class BufferBuilder {
 public:
  // Appends data as a new bufferView (4-byte aligned) with one accessor; returns the accessor index.
  int Add(json& gltf, const void* data, size_t bytes, size_t count, const char* type, int component, int target,
          const json& min = nullptr, const json& max = nullptr) {
    while (bin_.size() % 4) bin_.push_back('\0');
    const size_t offset = bin_.size();
    bin_.append(static_cast<const char*>(data), bytes);
    gltf["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}, {"target", target}});
    json acc = {{"bufferView", gltf["bufferViews"].size() - 1}, {"componentType", component}, {"count", count}, {"type", type}};
    if (!min.is_null()) acc["min"] = min, acc["max"] = max;
    gltf["accessors"].push_back(acc);
    return static_cast<int>(gltf["accessors"].size()) - 1;
  }
  const std::string& bytes() const { return bin_; }

 private:
  std::string bin_;
};

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t i = std::min(v.size() - 1, size_t(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + i, v.end());
  return v[i];
}

}  // namespace

json ExportGltf(const Material& m, const GltfExportOptions& o, const std::string& dir) {
  o.Check();
  if (!m.mesh.HasUVs()) throw Error(Msg(m.dir, ": mesh has no texture coordinates"));
  if (m.mesh.normals.size() != m.mesh.positions.size()) throw Error(Msg(m.dir, ": mesh has no normals"));
  const bool with_normal_map = m.normal_map.width > 0;
  const std::vector<GltfTexel> texels = FitGltfTexels(m, o);

  // Textures.
  Image base(m.width, m.height, 3), mr(m.width, m.height, 3), err(m.width, m.height, 1);
  std::vector<double> errors;
  // Per basis material: the fit error summed (then averaged, below) over the
  // texels where it has the largest weight, so that each warning states its
  // own material's error.
  const size_t K = m.basis.size();
  std::vector<double> basis_error(K, 0.0);
  std::vector<long> basis_texels(K, 0);
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      const GltfTexel& t = texels[size_t(y) * m.width + x];
      for (int c = 0; c < 3; ++c) base.at(x, y, c) = float(t.base_color[c]);
      mr.at(x, y, 0) = 0.0f;
      mr.at(x, y, 1) = float(t.roughness);
      mr.at(x, y, 2) = float(t.metallic);
      err.at(x, y, 0) = float(t.error);
      bool covered = false;
      size_t dominant = 0;
      double most = -1;
      for (size_t k = 0; k < K; ++k) {
        const Image& w = m.weights[k];
        covered |= w.at(x, y, 0) != 0 || w.at(x, y, 1) != 0 || w.at(x, y, 2) != 0;
        const double sum = double(w.at(x, y, 0)) + w.at(x, y, 1) + w.at(x, y, 2);
        if (sum > most) most = sum, dominant = k;
      }
      if (!covered) continue;
      errors.push_back(t.error);
      basis_error[dominant] += t.error;
      ++basis_texels[dominant];
    }
  WriteImage((fs::path(dir) / "baseColor.png").string(), base, PixelFormat::kUInt8, ColorSpace::kSRGB);
  WriteImage((fs::path(dir) / "metallicRoughness.png").string(), mr, PixelFormat::kUInt8, ColorSpace::kLinear);
  WriteImage((fs::path(dir) / "fit_error.exr").string(), err, PixelFormat::kFloat);

  const SplitMesh s = Split(m.mesh, with_normal_map);
  if (with_normal_map)
    WriteImage((fs::path(dir) / "normal.png").string(), TangentNormals(m, s), PixelFormat::kUInt8, ColorSpace::kLinear);

  json g;
  g["asset"] = {{"version", "2.0"}, {"generator", "svbrdf export"}};
  g["scene"] = 0;
  g["scenes"] = json::array({{{"nodes", {0}}}});
  g["nodes"] = json::array({{{"mesh", 0}, {"name", "svbrdf object"}}});
  g["bufferViews"] = json::array();
  g["accessors"] = json::array();
  BufferBuilder bb;
  const size_t nv = s.positions.size() / 3;
  json lo = {1e30, 1e30, 1e30}, hi = {-1e30, -1e30, -1e30};
  for (size_t v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c].get<double>(), double(s.positions[3 * v + c]));
      hi[c] = std::max(hi[c].get<double>(), double(s.positions[3 * v + c]));
    }
  const int ind = bb.Add(g, s.indices.data(), s.indices.size() * 4, s.indices.size(), "SCALAR", kUInt, kElementArrayBuffer);
  json attributes;
  attributes["POSITION"] = bb.Add(g, s.positions.data(), s.positions.size() * 4, nv, "VEC3", kFloat, kArrayBuffer, lo, hi);
  attributes["NORMAL"] = bb.Add(g, s.normals.data(), s.normals.size() * 4, nv, "VEC3", kFloat, kArrayBuffer);
  attributes["TEXCOORD_0"] = bb.Add(g, s.uvs.data(), s.uvs.size() * 4, nv, "VEC2", kFloat, kArrayBuffer);
  if (with_normal_map)
    attributes["TANGENT"] = bb.Add(g, s.tangents.data(), s.tangents.size() * 4, nv, "VEC4", kFloat, kArrayBuffer);
  g["meshes"] = json::array({{{"name", "svbrdf object"},
                              {"primitives", json::array({{{"attributes", attributes}, {"indices", ind},
                                                           {"material", 0}, {"mode", 4}}})}}});
  g["buffers"] = json::array({{{"uri", "model.bin"}, {"byteLength", bb.bytes().size()}}});
  // Linear filtering with mipmaps, clamped at the atlas border.
  g["samplers"] = json::array({{{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 33071}, {"wrapT", 33071}}});
  g["images"] = json::array({{{"uri", "baseColor.png"}}, {{"uri", "metallicRoughness.png"}}});
  g["textures"] = json::array({{{"sampler", 0}, {"source", 0}}, {{"sampler", 0}, {"source", 1}}});
  json material = {{"name", "svbrdf fitted metallic-roughness"},
                   {"pbrMetallicRoughness",
                    {{"baseColorTexture", {{"index", 0}}}, {"metallicRoughnessTexture", {{"index", 1}}},
                     {"metallicFactor", 1.0}, {"roughnessFactor", 1.0}}}};
  if (with_normal_map) {
    g["images"].push_back({{"uri", "normal.png"}});
    g["textures"].push_back({{"sampler", 0}, {"source", 2}});
    material["normalTexture"] = {{"index", 2}};
  }
  g["materials"] = json::array({material});
  WriteFileAtomic((fs::path(dir) / "model.bin").string(), bb.bytes());
  WriteFileAtomic((fs::path(dir) / "model.gltf").string(), g.dump(2));

  double mean = 0;
  for (double e : errors) mean += e;
  if (!errors.empty()) mean /= errors.size();
  json by_basis = json::object();
  for (size_t k = 0; k < K; ++k) {
    if (basis_texels[k]) basis_error[k] /= double(basis_texels[k]);  // sum -> mean
    by_basis[m.basis[k].name] = {{"texels", basis_texels[k]}, {"relative_error_mean", basis_error[k]}};
  }
  json report = {{"format", "gltf2"},
                 {"fit", {{"method", "grid over metallic x roughness, clamped least-squares base colour per channel"},
                          {"metallic_steps", o.metallic_steps}, {"roughness_steps", o.roughness_steps},
                          {"error_measure", "relative RMSE of reflected radiance under unit irradiance over direction pairs"},
                          {"texels", errors.size()},
                          {"relative_error_mean", mean},
                          {"relative_error_median", Percentile(errors, 0.5)},
                          {"relative_error_p95", Percentile(errors, 0.95)},
                          {"relative_error_max", errors.empty() ? 0.0 : *std::max_element(errors.begin(), errors.end())},
                          {"by_basis", by_basis}}},
                 {"vertices", nv},
                 {"triangles", s.indices.size() / 3},
                 {"normal_map", with_normal_map},
                 {"warnings", json::array()}};
  // glTF holds one metallic-roughness BRDF per texel: other models are fitted.
  for (size_t k = 0; k < K; ++k) {
    const BasisMaterial& b = m.basis[k];
    if (b.spec.family == Family::kGltf) continue;
    const std::string where =
        basis_texels[k] ? Msg("mean relative error ", basis_error[k], " over the ", basis_texels[k],
                              " texels where it weighs most")
                        : std::string("it weighs most in no texel");
    report["warnings"].push_back(Msg("basis '", b.name, "' (", b.spec.Label(), ") has no exact glTF form: fitted per "
                                     "texel (", where, "); `svbrdf reconstruct SCENE --for gltf` fits the glTF BRDF "
                                     "itself"));
  }
  WriteFileAtomic((fs::path(dir) / "export_report.json").string(), report.dump(2));
  return report;
}

}  // namespace svbrdf
