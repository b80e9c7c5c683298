#include "registration/white_paper.h"

#include <algorithm>
#include <cmath>

#include "raytrace/raytracer.h"

namespace svbrdf {

PaperCounts& PaperCounts::operator+=(const PaperCounts& o) {
  white += o.white, hidden += o.hidden, shadowed += o.shadowed;
  near_ball += o.near_ball, saturated += o.saturated, kept += o.kept;
  return *this;
}

namespace {

// Summed-area table of the drawing's non-white texels: a texture rectangle
// is all paper when its count is zero.
class InkTable {
 public:
  explicit InkTable(const Image& drawing) : w_(drawing.width), h_(drawing.height), sum_(size_t(w_ + 1) * (h_ + 1), 0) {
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x)
        sum_[Index(x + 1, y + 1)] = (drawing.at(x, y, 0) < kWhite ? 1 : 0) + sum_[Index(x, y + 1)] +
                                    sum_[Index(x + 1, y)] - sum_[Index(x, y)];
  }
  // Ink texels in the inclusive texel rectangle [x0, x1] x [y0, y1].
  long Count(int x0, int y0, int x1, int y1) const {
    return sum_[Index(x1 + 1, y1 + 1)] - sum_[Index(x0, y1 + 1)] - sum_[Index(x1 + 1, y0)] + sum_[Index(x0, y0)];
  }

 private:
  // Anti-aliased edges of the drawing count as ink.
  static constexpr float kWhite = 0.98f;
  size_t Index(int x, int y) const { return size_t(y) * (w_ + 1) + x; }
  int w_, h_;
  std::vector<long> sum_;
};

bool SegmentHitsSphere(const Vec3& from, const Vec3& to, const MirrorSphere& s) {
  const Vec3 d = to - from;
  const double t = std::clamp((s.centre - from).dot(d) / d.squaredNorm(), 0.0, 1.0);
  return (from + t * d - s.centre).norm() < s.radius;
}

}  // namespace

PaperCounts SampleWhitePaper(const BoardTexture& board, const PaperView& view, const std::vector<MirrorSphere>& spheres,
                             const RayTracer* occluder, const Vec3& light, double paper_albedo, int stride,
                             std::vector<DiffuseSample>* samples) {
  const Camera& cam = *view.camera;
  const Image& img = *view.radiance;
  const Rigid3 world_from_cam = view.cam_from_world.Inverse();
  const Vec3 eye = world_from_cam.translation;
  // Texture position of every pixel corner's ray on the board plane z = 0.
  const int W = img.width, H = img.height;
  std::vector<Vec2> corner_tex(size_t(W + 1) * (H + 1), Vec2::Constant(-1e9));
  for (int y = 0; y <= H; ++y)
    for (int x = 0; x <= W; ++x) {
      const Vec3 d = world_from_cam.rotation * cam.Unproject(Vec2(x, y));
      if (std::abs(d.z()) < 1e-12) continue;
      const double t = -eye.z() / d.z();
      if (t <= 0) continue;
      const Vec3 X = eye + t * d;
      corner_tex[size_t(y) * (W + 1) + x] = board.texture_from_board * Vec3(X.x(), X.y(), 1.0);
    }
  const InkTable ink(board.image);
  const int q = board.quiet_zone_px;
  const int tw = board.image.width, th = board.image.height;
  const Vec3 normal = eye.z() > 0 ? Vec3(0, 0, 1) : Vec3(0, 0, -1);
  const Eigen::Matrix2d board_from_tex = board.texture_from_board.leftCols(2).inverse();
  PaperCounts n;
  for (int y = 1; y + 1 < H; y += stride)
    for (int x = 1; x + 1 < W; x += stride) {
      // The pixel and half of each neighbour: corners x-1 .. x+2 span the
      // neighbours wholly; their bounding box in the texture is conservative.
      Vec2 lo = Vec2::Constant(1e30), hi = Vec2::Constant(-1e30);
      for (int cy = y - 1; cy <= y + 2; ++cy)
        for (int cx = x - 1; cx <= x + 2; ++cx) {
          const Vec2 u = corner_tex[size_t(cy) * (W + 1) + cx];
          lo = lo.cwiseMin(u), hi = hi.cwiseMax(u);
        }
      const int x0 = int(std::floor(lo.x())), y0 = int(std::floor(lo.y()));
      const int x1 = int(std::floor(hi.x())), y1 = int(std::floor(hi.y()));
      if (x0 < q || y0 < q || x1 >= tw - q || y1 >= th - q) continue;  // beyond the pattern, or a corner off the plane
      if (ink.Count(x0, y0, x1, y1) > 0) continue;
      ++n.white;
      if (view.object_mask && view.object_mask->at(x, y, 0) > 0.5f) {
        ++n.hidden;
        continue;
      }
      const Vec2 centre_tex = 0.5 * (corner_tex[size_t(y) * (W + 1) + x] + corner_tex[size_t(y + 1) * (W + 1) + x + 1]);
      const Vec2 b = board_from_tex * (centre_tex - board.texture_from_board.col(2));
      const Vec3 X(b.x(), b.y(), 0.0);
      bool near_ball = false, shadow = false;
      for (const MirrorSphere& s : spheres) {
        near_ball |= (X - s.centre).norm() < 1.5 * s.radius;
        shadow |= SegmentHitsSphere(X, light, s);
      }
      if (near_ball) {
        ++n.near_ball;
        continue;
      }
      const Vec3 to_light = light - X;
      if (!shadow && occluder) shadow = occluder->Occluded(X, to_light, 1e-4, to_light.norm() - 1e-4);
      if (shadow) {
        ++n.shadowed;
        continue;
      }
      if (view.saturated && view.saturated->at(x, y, 0) > 0) {
        ++n.saturated;
        continue;
      }
      ++n.kept;
      DiffuseSample s;
      for (int c = 0; c < 3; ++c) s.value[c] = img.at(x, y, std::min(c, img.channels - 1));
      s.albedo = paper_albedo;
      s.point = X;
      s.normal = normal;
      samples->push_back(s);
    }
  return n;
}

}  // namespace svbrdf
