// Mesh registration by silhouettes (after Lensch et al. 2001): the rigid
// pose of a scanned mesh in the photos' world frame that makes its projected
// outline agree with the object masks in every view. Each outer iteration
// finds the mesh's contour generators per view (edges between a face turned
// towards the camera and one turned away, visible from the camera), and Ceres
// moves the pose so that their projections land on the mask boundaries: the
// residual is the mask's signed distance field (calib/segment.h), sampled
// bicubically, so derivatives flow through the interpolation.
#pragma once
#include <vector>

#include "camera/camera.h"
#include "io/image.h"
#include "io/mesh.h"

namespace svbrdf {

struct SilhouetteView {
  Camera camera;
  Rigid3 cam_from_world;
  Image mask;  // 1 channel, > 0.5 = object
};

// Parameters (name, meaning, range):
//   outer_iterations  contour re-extractions, >= 1
//   huber_px          Huber loss scale on the distance residual, pixels, > 0
//   max_points_per_view  contour samples kept per view (evenly thinned), >= 10
struct SilhouetteOptions {
  int outer_iterations = 10;
  double huber_px = 1.5;
  int max_points_per_view = 600;
  int threads = 0;
  bool progress = true;
  void Check() const;
};

struct SilhouetteResult {
  Rigid3 world_from_object;
  std::vector<double> iou_before, iou_after;  // per view: rendered mesh vs mask
  double mean_distance_px = 0;                // mean |signed distance| of the final contour points
};

// Mask of a mesh (object frame, placed by world_from_object) seen by a view:
// pixel centre rays, 1 where the mesh is hit.
Image RenderSilhouette(const Mesh& object_mesh, const Rigid3& world_from_object, const Camera& camera,
                       const Rigid3& cam_from_world);

SilhouetteResult AlignSilhouettes(const Mesh& object_mesh, const Rigid3& initial_world_from_object,
                                  const std::vector<SilhouetteView>& views, const SilhouetteOptions& options);

}  // namespace svbrdf
