// Mesh utilities and the OBJ reader/writer; the PLY reader is in ply.cc.
#include "io/mesh.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "core/error.h"
#include "io/files.h"
#include "io/scene.h"  // WriteFileAtomic

namespace svbrdf {

Mesh LoadPly(const std::string& path);  // ply.cc

namespace {

// Resolves a 1-based OBJ index (negative: relative to the end) to 0-based.
int ObjIndex(const std::string& token, size_t count, const std::string& where) {
  int i = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), i);
  if (ec != std::errc() || end != token.data() + token.size() || i == 0)
    throw Error(Msg(where, ": bad index '", token, "'"));
  const long resolved = i > 0 ? long(i) - 1 : long(count) + i;
  if (resolved < 0 || resolved >= long(count))
    throw Error(Msg(where, ": index ", i, " out of range (", count, " defined so far)"));
  return static_cast<int>(resolved);
}

Mesh LoadObj(const std::string& path) {
  std::istringstream in(ReadFileBytes(path));
  Mesh mesh;
  std::string line, tag;
  int line_no = 0, faces_with_uv = 0, faces_without_uv = 0;
  // The file's own normals (vn) are the mesh's when every corner names one
  // and each position always gets the same one; otherwise LoadMesh computes them.
  std::vector<Vec3> file_normals;
  std::vector<int> normal_of;
  bool normals_per_position = true;
  while (std::getline(in, line)) {
    ++line_no;
    if (normal_of.size() < mesh.positions.size()) normal_of.resize(mesh.positions.size(), -1);
    std::istringstream ls(line);
    if (!(ls >> tag)) continue;
    const std::string where = Msg(path, ":", line_no);
    if (tag == "v" || tag == "vt" || tag == "vn") {
      double a = 0, b = 0, c = 0;
      if (!(ls >> a >> b)) throw Error(Msg(where, ": expected numbers after '", tag, "'"));
      if (tag == "vt") {
        mesh.texcoords.emplace_back(a, b);
      } else {
        if (!(ls >> c)) throw Error(Msg(where, ": expected 3 numbers after '", tag, "'"));
        (tag == "v" ? mesh.positions : file_normals).emplace_back(a, b, c);
      }
    } else if (tag == "f") {
      // Corners are v, v/vt, v//vn or v/vt/vn.
      std::vector<int> pos, uv, vn;
      std::string corner;
      while (ls >> corner) {
        const size_t s1 = corner.find('/');
        pos.push_back(ObjIndex(corner.substr(0, s1), mesh.positions.size(), where));
        if (s1 == std::string::npos) continue;
        const size_t s2 = corner.find('/', s1 + 1);
        const std::string vt = corner.substr(s1 + 1, s2 == std::string::npos ? std::string::npos : s2 - s1 - 1);
        if (!vt.empty()) uv.push_back(ObjIndex(vt, mesh.texcoords.size(), where));
        if (s2 != std::string::npos && s2 + 1 < corner.size())
          vn.push_back(ObjIndex(corner.substr(s2 + 1), file_normals.size(), where));
      }
      if (vn.size() == pos.size()) {
        for (size_t k = 0; k < pos.size(); ++k) {
          int& n = normal_of[pos[k]];
          // A position with two different normals (split normals at a hard edge) has no per-position normal.
          if (n >= 0 && n != vn[k] && file_normals[n] != file_normals[vn[k]]) normals_per_position = false;
          n = vn[k];
        }
      } else {
        normals_per_position = false;  // a corner without vn
      }
      if (pos.size() < 3) throw Error(Msg(where, ": face with fewer than 3 vertices"));
      if (!uv.empty() && uv.size() != pos.size())
        throw Error(Msg(where, ": some corners of the face have texture coordinates and some do not"));
      (uv.empty() ? faces_without_uv : faces_with_uv)++;
      for (size_t k = 1; k + 1 < pos.size(); ++k) {  // fan triangulation of polygons
        mesh.faces.emplace_back(pos[0], pos[k], pos[k + 1]);
        if (!uv.empty()) mesh.face_uvs.emplace_back(uv[0], uv[k], uv[k + 1]);
      }
    }
    // Other statements (o, g, s, usemtl, mtllib, comments) carry nothing we use.
  }
  if (faces_with_uv > 0 && faces_without_uv > 0)
    throw Error(Msg(path, ": ", faces_without_uv, " faces lack texture coordinates while ", faces_with_uv,
                    " have them"));
  normal_of.resize(mesh.positions.size(), -1);
  if (normals_per_position && !file_normals.empty()) {
    mesh.normals.assign(mesh.positions.size(), Vec3::Zero());  // unused positions: zero, set by LoadMesh
    for (size_t v = 0; v < mesh.positions.size(); ++v)
      if (normal_of[v] >= 0) mesh.normals[v] = file_normals[normal_of[v]];
  }
  return mesh;
}

std::string LowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// Shortest text that reads back as the same double, so SaveObj/LoadMesh round trips exactly.
void AppendNumber(std::string& out, double v) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, end);
}

}  // namespace

Vec3 Mesh::FaceDpDu(int f) const {
  if (!HasUVs()) return Vec3::Zero();
  const Vec3i& i = faces[f];
  const Vec3i& j = face_uvs[f];
  const Vec3 e1 = positions[i[1]] - positions[i[0]], e2 = positions[i[2]] - positions[i[0]];
  const Vec2 d1 = texcoords[j[1]] - texcoords[j[0]], d2 = texcoords[j[2]] - texcoords[j[0]];
  // [e1 e2] = [dP/du dP/dv] [d1 d2]
  const double det = d1.x() * d2.y() - d1.y() * d2.x();
  return std::abs(det) > 1e-300 ? Vec3((e1 * d2.y() - e2 * d1.y()) / det) : Vec3::Zero();
}

void Mesh::ComputeNormals(NormalWeighting weighting) {
  // Angle-weighted (Thürmer & Wüthrich 1998, "Computing vertex normals from
  // polygonal facets"): each face adds its unit normal times its corner
  // angle at the vertex. This is what Mitsuba 3 (Mesh::recompute_vertex_normals,
  // run by its OBJ and PLY loaders for files without normals) and Blender
  // compute, so a capture rendered by them from a mesh without normals is
  // relit with the normals it was shaded with. Area weighting differs on a
  // scan (the bunny), enough to cost even a perfect prediction on Mitsuba's
  // photos (bench_results/independent.md).
  // Unlike area weighting it does not depend on how a region is
  // triangulated (a fan of thin triangles does not outweigh one large one).
  // kArea: the sum of unnormalised face normals (length = 2 x area).
  normals.assign(positions.size(), Vec3::Zero());
  for (const Vec3i& f : faces) {
    const Vec3 n = (positions[f[1]] - positions[f[0]]).cross(positions[f[2]] - positions[f[0]]);
    const double len = n.norm();
    if (!(len > 0)) continue;  // degenerate face: no direction, no angle
    for (int k = 0; k < 3; ++k) {
      const Vec3 a = positions[f[(k + 1) % 3]] - positions[f[k]];
      const Vec3 b = positions[f[(k + 2) % 3]] - positions[f[k]];
      // atan2(|a x b|, a . b): accurate at small and large angles alike.
      const double angle = std::atan2(a.cross(b).norm(), a.dot(b));
      normals[f[k]] += weighting == NormalWeighting::kArea ? n : Vec3((angle / len) * n);
    }
  }
  for (Vec3& n : normals) {
    const double len = n.norm();
    n = len > 0 ? Vec3(n / len) : Vec3::UnitZ();  // isolated vertex: any unit vector
  }
}

void Mesh::Validate(const std::string& context) const {
  if (faces.empty()) throw Error(Msg(context, ": mesh has no faces"));
  // Finite is not enough: products of coordinates beyond these overflow in
  // normals and ray tests (metres; texture coordinates tile a few times at most).
  for (size_t i = 0; i < positions.size(); ++i)
    if (!positions[i].allFinite() || positions[i].cwiseAbs().maxCoeff() > 1e9)
      throw Error(Msg(context, ": vertex ", i, " is not finite or beyond 1e9 (", positions[i].transpose(), ")"));
  for (size_t i = 0; i < texcoords.size(); ++i)
    if (!texcoords[i].allFinite() || texcoords[i].cwiseAbs().maxCoeff() > 1e4)
      throw Error(Msg(context, ": texture coordinate ", i, " is not finite or beyond 1e4 (", texcoords[i].transpose(), ")"));
  if (!face_uvs.empty() && face_uvs.size() != faces.size())
    throw Error(Msg(context, ": ", face_uvs.size(), " UV faces for ", faces.size(), " faces"));
  bool any_area = false;
  for (size_t i = 0; i < faces.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (faces[i][k] < 0 || faces[i][k] >= int(positions.size()))
        throw Error(Msg(context, ": face ", i, " refers to vertex ", faces[i][k], " of ", positions.size()));
      if (HasUVs() && (face_uvs[i][k] < 0 || face_uvs[i][k] >= int(texcoords.size())))
        throw Error(Msg(context, ": face ", i, " refers to texture coordinate ", face_uvs[i][k], " of ",
                        texcoords.size()));
    }
    const Vec3i& f = faces[i];
    any_area = any_area || (positions[f[1]] - positions[f[0]]).cross(positions[f[2]] - positions[f[0]]).norm() > 0;
  }
  if (!any_area) throw Error(Msg(context, ": every face is degenerate (zero area)"));
}

Mesh LoadMesh(const std::string& path) {
  const std::string ext = LowerExtension(path);
  Mesh mesh;
  if (ext == ".obj") mesh = LoadObj(path);
  else if (ext == ".ply") mesh = LoadPly(path);
  else throw Error(Msg(path, ": unknown mesh format '", ext, "' (expected .obj or .ply)"));
  mesh.Validate(path);
  // The file's normals when it gives one per position (OBJ vn, PLY nx ny nz):
  // other renderers shade with them (Mitsuba, Blender), and a capture
  // rendered with them must be relit with them. Otherwise (none, split
  // normals, a zero or non-finite one) the angle-weighted normals.
  bool usable = mesh.normals.size() == mesh.positions.size();
  std::vector<bool> used(mesh.positions.size(), false);
  for (const Vec3i& f : mesh.faces)
    for (int k = 0; k < 3; ++k) used[f[k]] = true;
  for (size_t v = 0; usable && v < mesh.normals.size(); ++v)
    usable = !used[v] || (mesh.normals[v].allFinite() && mesh.normals[v].norm() > 1e-12);
  if (usable) {
    for (Vec3& n : mesh.normals) n = n.norm() > 1e-12 ? Vec3(n.normalized()) : Vec3::UnitZ();
  } else {
    mesh.ComputeNormals();
  }
  return mesh;
}

void SaveObj(const Mesh& mesh, const std::string& path, bool write_normals) {
  write_normals = write_normals && mesh.normals.size() == mesh.positions.size();
  std::string out = "# svbrdf mesh\n";
  for (const Vec3& p : mesh.positions) {
    out += "v";
    for (int k = 0; k < 3; ++k) AppendNumber(out += ' ', p[k]);
    out += '\n';
  }
  for (const Vec2& t : mesh.texcoords) {
    out += "vt";
    for (int k = 0; k < 2; ++k) AppendNumber(out += ' ', t[k]);
    out += '\n';
  }
  if (write_normals)
    for (const Vec3& n : mesh.normals) {
      out += "vn";
      for (int k = 0; k < 3; ++k) AppendNumber(out += ' ', n[k]);
      out += '\n';
    }
  for (size_t i = 0; i < mesh.faces.size(); ++i) {
    out += "f";
    for (int k = 0; k < 3; ++k) {
      out += ' ' + std::to_string(mesh.faces[i][k] + 1);
      if (mesh.HasUVs() || write_normals) out += '/';
      if (mesh.HasUVs()) out += std::to_string(mesh.face_uvs[i][k] + 1);
      if (write_normals) out += '/' + std::to_string(mesh.faces[i][k] + 1);  // normals are per position
    }
    out += '\n';
  }
  WriteFileAtomic(path, out);
}

}  // namespace svbrdf
