// Triangle meshes: OBJ and PLY (ASCII and binary little-endian), with or
// without texture coordinates. Positions and texture coordinates are indexed
// separately, as in OBJ, so UV seams need no vertex splitting.
#pragma once
#include <string>
#include <vector>

#include "core/types.h"

namespace svbrdf {

// How ComputeNormals weights the faces around a vertex.
enum class NormalWeighting {
  kAngle,  // by the face's corner angle at the vertex: Mitsuba 3's and Blender's choice (the default)
  kArea,   // by the face's area: this project's synthetic shapes (their regression data were made with it)
};

struct Mesh {
  std::vector<Vec3> positions;
  std::vector<Vec3i> faces;       // indices into positions
  std::vector<Vec2> texcoords;    // (u, v), v up as in OBJ
  std::vector<Vec3i> face_uvs;    // indices into texcoords; empty when the mesh has no UVs
  // Per position, unit: the file's own normals when it gives one per position
  // (OBJ vn, PLY nx ny nz), else angle-weighted smooth normals (ComputeNormals,
  // as Mitsuba 3 and Blender compute them for a file without normals).
  std::vector<Vec3> normals;

  bool HasUVs() const { return !face_uvs.empty(); }
  void ComputeNormals(NormalWeighting weighting = NormalWeighting::kAngle);
  // dP/du of face f from its UV parametrisation (the tangent that orients
  // anisotropic materials); zero without UVs or for a degenerate UV triangle.
  Vec3 FaceDpDu(int f) const;
  // Throws Error naming `context` for out-of-range indices, NaNs, no faces,
  // or only degenerate (zero-area) faces.
  void Validate(const std::string& context) const;
};

// By extension .obj / .ply; normals as the file gives them, else computed (see `normals`).
Mesh LoadMesh(const std::string& path);
// Writes OBJ (with vt when present, and with the per-position normals as vn
// when `write_normals`, so other renderers shade exactly as relight does);
// atomic (temporary name, then rename).
void SaveObj(const Mesh& mesh, const std::string& path, bool write_normals = false);

}  // namespace svbrdf
