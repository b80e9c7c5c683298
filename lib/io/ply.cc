// PLY reader: ascii and binary_little_endian; vertex x y z with optional
// per-vertex texture coordinates, face vertex_indices lists. Other elements
// and properties are read and skipped.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>

#include "core/error.h"
#include "io/files.h"
#include "io/mesh.h"

namespace svbrdf {
namespace {

enum class PlyType { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };

bool ParsePlyType(const std::string& name, PlyType* t) {
  static const std::pair<const char*, PlyType> kNames[] = {
      {"char", PlyType::kInt8},     {"int8", PlyType::kInt8},       {"uchar", PlyType::kUInt8},
      {"uint8", PlyType::kUInt8},   {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUInt16}, {"uint16", PlyType::kUInt16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},   {"uint", PlyType::kUInt32},     {"uint32", PlyType::kUInt32},
      {"float", PlyType::kFloat32}, {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [n, type] : kNames)
    if (name == n) {
      *t = type;
      return true;
    }
  return false;
}

struct PlyProperty {
  std::string name;
  PlyType type;
  bool is_list = false;
  PlyType count_type = PlyType::kUInt8;
};

struct PlyElement {
  std::string name;
  long count = 0;
  std::vector<PlyProperty> properties;
};

// Reads scalar values from the body, ascii tokens or little-endian binary.
class PlyBody {
 public:
  PlyBody(const std::string& data, size_t offset, bool binary, const std::string& path)
      : data_(data), pos_(offset), binary_(binary), path_(path) {
    if (!binary_) text_.str(data_.substr(offset));
  }
  double Read(PlyType t, const std::string& what) {
    if (!binary_) {
      double v;
      if (!(text_ >> v)) throw Error(Msg(path_, ": truncated or non-numeric data reading ", what));
      return v;
    }
    switch (t) {
      case PlyType::kInt8: return Raw<int8_t>(what);
      case PlyType::kUInt8: return Raw<uint8_t>(what);
      case PlyType::kInt16: return Raw<int16_t>(what);
      case PlyType::kUInt16: return Raw<uint16_t>(what);
      case PlyType::kInt32: return Raw<int32_t>(what);
      case PlyType::kUInt32: return Raw<uint32_t>(what);
      case PlyType::kFloat32: return Raw<float>(what);
      case PlyType::kFloat64: return Raw<double>(what);
    }
    return 0;
  }

 private:
  template <class T>
  double Raw(const std::string& what) {
    // Hosts are little-endian (x86-64, arm64), as is the only binary PLY flavour accepted.
    if (pos_ + sizeof(T) > data_.size()) throw Error(Msg(path_, ": truncated binary data reading ", what));
    T v;
    std::memcpy(&v, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return static_cast<double>(v);
  }
  const std::string& data_;
  size_t pos_;
  bool binary_;
  std::string path_;
  std::istringstream text_;
};

// Parses the header up to end_header; returns the body offset.
size_t ParseHeader(const std::string& data, const std::string& path, bool* binary, std::vector<PlyElement>* elements) {
  std::istringstream in(data);
  std::string line;
  if (!std::getline(in, line) || line.substr(0, 3) != "ply") throw Error(Msg(path, ": not a PLY file"));
  bool have_format = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "end_header") {
      if (!have_format) throw Error(Msg(path, ": PLY header has no format line"));
      return static_cast<size_t>(in.tellg());
    }
    if (word == "format") {
      std::string fmt;
      ls >> fmt;
      if (fmt != "ascii" && fmt != "binary_little_endian")
        throw Error(Msg(path, ": PLY format '", fmt, "' not supported (ascii or binary_little_endian)"));
      *binary = fmt != "ascii";
      have_format = true;
    } else if (word == "element") {
      PlyElement e;
      if (!(ls >> e.name >> e.count) || e.count < 0) throw Error(Msg(path, ": bad PLY line '", line, "'"));
      elements->push_back(e);
    } else if (word == "property") {
      if (elements->empty()) throw Error(Msg(path, ": PLY property before any element"));
      PlyProperty p;
      std::string type;
      ls >> type;
      if (type == "list") {
        std::string count_type, item_type;
        ls >> count_type >> item_type >> p.name;
        p.is_list = true;
        if (!ParsePlyType(count_type, &p.count_type) || !ParsePlyType(item_type, &p.type))
          throw Error(Msg(path, ": bad PLY list property '", line, "'"));
      } else {
        ls >> p.name;
        if (!ParsePlyType(type, &p.type)) throw Error(Msg(path, ": unknown PLY type in '", line, "'"));
      }
      elements->back().properties.push_back(p);
    }
    // comment / obj_info lines carry nothing we use.
  }
  throw Error(Msg(path, ": PLY header has no end_header"));
}

int FindProperty(const PlyElement& e, std::initializer_list<const char*> names) {
  for (const char* n : names)
    for (size_t i = 0; i < e.properties.size(); ++i)
      if (e.properties[i].name == n && !e.properties[i].is_list) return static_cast<int>(i);
  return -1;
}

}  // namespace

Mesh LoadPly(const std::string& path) {
  const std::string data = ReadFileBytes(path);
  bool binary = false;
  std::vector<PlyElement> elements;
  const size_t body_offset = ParseHeader(data, path, &binary, &elements);  // sets `binary`
  PlyBody body(data, body_offset, binary, path);
  Mesh mesh;
  bool uvs = false;
  for (const PlyElement& e : elements) {
    const int ix = FindProperty(e, {"x"}), iy = FindProperty(e, {"y"}), iz = FindProperty(e, {"z"});
    const int iu = FindProperty(e, {"u", "s", "texture_u", "texture_s"});
    const int iv = FindProperty(e, {"v", "t", "texture_v", "texture_t"});
    const int inx = FindProperty(e, {"nx"}), iny = FindProperty(e, {"ny"}), inz = FindProperty(e, {"nz"});
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    if (is_vertex && (ix < 0 || iy < 0 || iz < 0)) throw Error(Msg(path, ": PLY vertex lacks x, y or z"));
    const bool normals = is_vertex && inx >= 0 && iny >= 0 && inz >= 0;  // used by LoadMesh when valid
    if (is_vertex) uvs = iu >= 0 && iv >= 0;
    // Every item takes at least one byte: a larger count is a corrupt header
    // (and must not drive a loop of billions of empty items).
    if (e.properties.empty()) continue;
    if (e.count > static_cast<long>(data.size()))
      throw Error(Msg(path, ": element ", e.name, " claims ", e.count, " items, more than the file's ", data.size(),
                      " bytes can hold"));
    std::vector<double> values;
    for (long item = 0; item < e.count; ++item) {
      std::vector<int> polygon;
      values.assign(e.properties.size(), 0.0);
      for (size_t p = 0; p < e.properties.size(); ++p) {
        const PlyProperty& prop = e.properties[p];
        const std::string what = Msg(e.name, " ", item, " ", prop.name);
        if (!prop.is_list) {
          values[p] = body.Read(prop.type, what);
          continue;
        }
        const double n = body.Read(prop.count_type, what);
        if (n < 0 || n > 1e6) throw Error(Msg(path, ": bad list length ", n, " in ", what));
        const bool indices = is_face && (prop.name == "vertex_indices" || prop.name == "vertex_index");
        for (int k = 0; k < int(n); ++k) {
          const double v = body.Read(prop.type, what);
          // Range first: converting an out-of-range double to int is undefined.
          if (indices && !(v >= 0 && v < 2147483647.0 && v == std::floor(v)))
            throw Error(Msg(path, ": bad vertex index ", v, " in ", what));
          if (indices) polygon.push_back(static_cast<int>(v));
        }
      }
      if (is_vertex) {
        mesh.positions.emplace_back(values[ix], values[iy], values[iz]);
        if (uvs) mesh.texcoords.emplace_back(values[iu], values[iv]);
        if (normals) mesh.normals.emplace_back(values[inx], values[iny], values[inz]);
      }
      if (is_face) {
        if (polygon.size() < 3) throw Error(Msg(path, ": face ", item, " has fewer than 3 vertex indices"));
        for (size_t k = 1; k + 1 < polygon.size(); ++k)  // fan triangulation
          mesh.faces.emplace_back(polygon[0], polygon[k], polygon[k + 1]);
      }
    }
  }
  // Per-vertex UVs: texture coordinates are indexed like the positions.
  if (uvs) mesh.face_uvs = mesh.faces;
  return mesh;
}

}  // namespace svbrdf
