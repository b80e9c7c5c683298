// Chart atlas for meshes without texture coordinates (scans): the surface is
// cut into charts, each chart is flattened, and the charts are packed into
// one square texture at a chosen texel size.
//
//  1. Segmentation: region growing over edge-adjacent faces; a face joins a
//     chart while its normal lies within `max_cone_deg` of the chart's mean
//     normal (nearly flat charts flatten with little distortion).
//     Charts smaller than `min_chart_texels` texels then join the
//     neighbour they share most edges with (same side): growing leaves
//     crumbs between charts and islands inside them (which make a chart an
//     annulus, not a disk).
//  2. Each chart must be a topological disk (one border loop, Euler
//     characteristic 1, manifold); a chart that is not, or whose flattening
//     flips or stretches a triangle by more than `max_stretch`, is cut in two
//     along its longest extent and both halves are tried again (one triangle
//     is always a disk, so this ends).
//  3. Flattening: least-squares conformal maps (Lévy et al. 2002, via CGAL's
//     Surface_mesh_parameterization::LSCM_parameterizer_3), scaled so that the
//     chart's UV area equals its surface area / texel_size^2, rotated to
//     its principal axes.
//     Charts still smaller than `min_chart_texels` (pieces of the cuts) join
//     a neighbour when the union still flattens within these limits.
//  4. Packing: shelves of charts sorted by height with a `gutter` of empty
//     texels between charts, so the atlas' one-texel dilation of one chart
//     never reaches another. When the layout exceeds `max_resolution`, the
//     texel size grows until it fits.
// CGAL is used only inside lib/atlas.
#pragma once
#include "io/mesh.h"

namespace svbrdf {

struct ChartAtlasOptions {
  double texel_size = 0.01;   // surface length per texel (mesh units), > 0
  int max_resolution = 2048;  // texture side cap; the texel size grows to fit
  double max_cone_deg = 60;   // normal deviation allowed within a chart (degrees, (0, 90])
  double max_stretch = 4.0;   // per-triangle UV/surface area ratio vs the chart's, either way (> 1)
  // Charts below this surface area (in texels of `texel_size`) are merged
  // into a neighbour (steps 1 and 3). Every chart carries a ring of border
  // texels that measure no surface of their own (about its perimeter in
  // texels); on a scan (the bunny) unmerged small charts, many of one
  // triangle, make border texels a large share of all texels. 0 = no merging.
  double min_chart_texels = 64;
  int gutter = 4;             // empty texels between charts (>= 4 keeps BuildAtlas(cover_small, dilate 1) claims apart)
  void Check() const;         // throws Error for out-of-range values
};

struct ChartAtlasInfo {
  int resolution = 0;         // the square texture side the layout needs
  double texel_size = 0;      // final texel size (>= the requested one)
  int charts = 0;
  double fill = 0;            // share of the texture covered by chart triangles
};

// Returns the mesh with texcoords/face_uvs filled (one UV vertex per chart
// corner; positions and faces unchanged). `info` receives the layout.
Mesh MakeChartAtlasUVs(const Mesh& mesh, const ChartAtlasOptions& options, ChartAtlasInfo* info);

}  // namespace svbrdf
