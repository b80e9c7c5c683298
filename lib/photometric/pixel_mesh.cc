#include "photometric/pixel_mesh.h"

#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <deque>

#include "core/error.h"

namespace svbrdf {

std::vector<double> IntegrateNormals(const Image& normals_cam, const Image& region, double metres_per_pixel,
                                     double max_slope) {
  const int w = region.width, h = region.height;
  std::vector<int> index(size_t(w) * h, -1);
  int n = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (region.at(x, y, 0) > 0.5f) index[size_t(y) * w + x] = n++;
  std::vector<double> depth(size_t(w) * h, 0.0);
  if (n == 0) return depth;
  // dz/dx = -nx/nz, dz/dy = -ny/nz on the surface z(x, y) (camera frame).
  auto slope = [&](int x, int y, int axis) {
    const double nz = std::min(-1e-3, double(normals_cam.at(x, y, 2)));  // facing the camera: nz < 0
    return std::clamp(-double(normals_cam.at(x, y, axis)) / nz, -max_slope, max_slope);
  };
  std::vector<Eigen::Triplet<double>> t;
  std::vector<double> rhs;
  int row = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int i = index[size_t(y) * w + x];
      if (i < 0) continue;
      for (int axis = 0; axis < 2; ++axis) {
        const int x2 = x + (axis == 0), y2 = y + (axis == 1);
        if (x2 >= w || y2 >= h) continue;
        const int j = index[size_t(y2) * w + x2];
        if (j < 0) continue;
        t.emplace_back(row, j, 1.0);
        t.emplace_back(row, i, -1.0);
        rhs.push_back(0.5 * (slope(x, y, axis) + slope(x2, y2, axis)) * metres_per_pixel);
        ++row;
      }
    }
  // A weak pull to 0 fixes each part's free offset; removed again below.
  const double kAnchor = 1e-6;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(row++, i, kAnchor);
    rhs.push_back(0.0);
  }
  Eigen::SparseMatrix<double> A(row, n);
  A.setFromTriplets(t.begin(), t.end());
  const Eigen::Map<const Eigen::VectorXd> b(rhs.data(), row);
  const Eigen::SparseMatrix<double> AtA = A.transpose() * A;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(AtA);
  if (solver.info() != Eigen::Success) throw Error("normal integration: factorisation failed");
  const Eigen::VectorXd z = solver.solve(A.transpose() * b);
  // Mean 0 per connected part (4-neighbours).
  std::vector<int> part(n, -1);
  std::vector<double> sum;
  std::vector<int> count;
  for (int y0 = 0; y0 < h; ++y0)
    for (int x0 = 0; x0 < w; ++x0) {
      const int i0 = index[size_t(y0) * w + x0];
      if (i0 < 0 || part[i0] >= 0) continue;
      const int p = int(sum.size());
      sum.push_back(0), count.push_back(0);
      std::deque<std::pair<int, int>> queue{{x0, y0}};
      part[i0] = p;
      while (!queue.empty()) {
        const auto [x, y] = queue.front();
        queue.pop_front();
        const int i = index[size_t(y) * w + x];
        sum[p] += z[i], count[p] += 1;
        const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
        for (int k = 0; k < 4; ++k) {
          const int xn = x + dx[k], yn = y + dy[k];
          if (xn < 0 || yn < 0 || xn >= w || yn >= h) continue;
          const int j = index[size_t(yn) * w + xn];
          if (j < 0 || part[j] >= 0) continue;
          part[j] = p;
          queue.emplace_back(xn, yn);
        }
      }
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int i = index[size_t(y) * w + x];
      if (i >= 0) depth[size_t(y) * w + x] = z[i] - sum[part[i]] / count[part[i]];
    }
  return depth;
}

Mesh PixelGridMesh(const Camera& cam, const Rigid3& cam_from_world, const Image& region,
                   const std::vector<double>& depth, double base_depth, const Image& normals_cam) {
  const int w = region.width, h = region.height;
  if (w != cam.width || h != cam.height)
    throw Error(Msg("pixel mesh: region is ", w, "x", h, " but the camera is ", cam.width, "x", cam.height));
  const Rigid3 world_from_cam = cam_from_world.Inverse();
  auto inside = [&](int x, int y) { return x >= 0 && y >= 0 && x < w && y < h && region.at(x, y, 0) > 0.5f; };
  Mesh mesh;
  std::vector<int> corner(size_t(w + 1) * (h + 1), -1);
  for (int y = 0; y <= h; ++y)
    for (int x = 0; x <= w; ++x) {
      double z = 0;
      Vec3 n = Vec3::Zero();
      int k = 0;
      for (int dy = -1; dy <= 0; ++dy)
        for (int dx = -1; dx <= 0; ++dx)
          if (inside(x + dx, y + dy)) {
            z += depth[size_t(y + dy) * w + x + dx];
            n += Vec3(normals_cam.at(x + dx, y + dy, 0), normals_cam.at(x + dx, y + dy, 1),
                      normals_cam.at(x + dx, y + dy, 2));
            ++k;
          }
      if (k == 0) continue;
      corner[size_t(y) * (w + 1) + x] = int(mesh.positions.size());
      Vec3 origin, dir;
      cam.PixelRay(Vec2(x, y), &origin, &dir);
      // Orthographic rays are parallel: the point at depth z lies on the ray
      // from the pixel's point on z = 0; a pinhole's ray scales with z.
      const double zc = base_depth + z / k;
      const Vec3 x_cam = cam.IsOrthographic() ? Vec3(origin + zc * dir) : Vec3(zc * dir);
      mesh.positions.push_back(world_from_cam * x_cam);
      mesh.normals.push_back(n.norm() > 0 ? Vec3(world_from_cam.rotation * n.normalized())
                                          : Vec3(world_from_cam.rotation * Vec3(0, 0, -1)));
      mesh.texcoords.emplace_back(double(x) / w, 1.0 - double(y) / h);
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!inside(x, y)) continue;
      const int a = corner[size_t(y) * (w + 1) + x], b = corner[size_t(y) * (w + 1) + x + 1];
      const int c = corner[size_t(y + 1) * (w + 1) + x + 1], d = corner[size_t(y + 1) * (w + 1) + x];
      // Counter-clockwise seen from the camera (image y down): a d c, a c b.
      mesh.faces.emplace_back(a, d, c);
      mesh.faces.emplace_back(a, c, b);
    }
  mesh.face_uvs = mesh.faces;  // texcoords are indexed like positions
  if (mesh.faces.empty()) throw Error("pixel mesh: the object region is empty");
  return mesh;
}

bool FillFromNearest(const Image& known, Image* image) {
  const int w = image->width, h = image->height;
  std::vector<char> done(size_t(w) * h, 0);
  std::deque<std::pair<int, int>> queue;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (known.at(x, y, 0) > 0.5f) {
        done[size_t(y) * w + x] = 1;
        queue.emplace_back(x, y);
      }
  if (queue.empty()) return false;
  while (!queue.empty()) {
    const auto [x, y] = queue.front();
    queue.pop_front();
    const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
    for (int k = 0; k < 4; ++k) {
      const int xn = x + dx[k], yn = y + dy[k];
      if (xn < 0 || yn < 0 || xn >= w || yn >= h || done[size_t(yn) * w + xn]) continue;
      done[size_t(yn) * w + xn] = 1;
      for (int c = 0; c < image->channels; ++c) image->at(xn, yn, c) = image->at(x, y, c);
      queue.emplace_back(xn, yn);
    }
  }
  return true;
}

bool FillNormalsSmoothly(const Image& known, const Image& region, Image* normals) {
  const int w = normals->width, h = normals->height;
  Image known_in_region(w, h, 1);
  std::vector<int> holes;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (region.at(x, y, 0) <= 0.5f) continue;
      if (known.at(x, y, 0) > 0.5f) known_in_region.at(x, y, 0) = 1.0f;
      else holes.push_back(y * w + x);
    }
  if (holes.size() == size_t(std::count_if(region.pixels.begin(), region.pixels.end(), [](float v) { return v > 0.5f; })))
    return false;
  if (holes.empty()) return true;
  FillFromNearest(known_in_region, normals);
  // Jacobi sweeps until no hole pixel turns by more than ~0.01 degrees (the
  // membrane converges in about (hole diameter)^2 sweeps; the cap bounds the
  // cost of a large hole, whose interior then keeps some of the start).
  constexpr int kMaxSweeps = 2000;
  constexpr double kTolerance = 2e-4;
  std::vector<Vec3> next(holes.size());
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    double change = 0;
    for (size_t i = 0; i < holes.size(); ++i) {
      const int x = holes[i] % w, y = holes[i] / w;
      Vec3 sum = Vec3::Zero();
      const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
      for (int k = 0; k < 4; ++k) {
        const int xn = x + dx[k], yn = y + dy[k];
        if (xn < 0 || yn < 0 || xn >= w || yn >= h || region.at(xn, yn, 0) <= 0.5f) continue;
        sum += Vec3(normals->at(xn, yn, 0), normals->at(xn, yn, 1), normals->at(xn, yn, 2));
      }
      const Vec3 old(normals->at(x, y, 0), normals->at(x, y, 1), normals->at(x, y, 2));
      next[i] = sum.norm() > 0 ? Vec3(sum.normalized()) : old;
      change = std::max(change, (next[i] - old).norm());
    }
    for (size_t i = 0; i < holes.size(); ++i)
      for (int c = 0; c < 3; ++c) normals->at(holes[i] % w, holes[i] / w, c) = float(next[i][c]);
    if (change < kTolerance) break;
  }
  return true;
}

Image RegionMedian(const Image& values, const Image& region, int radius) {
  Image out(values.width, values.height, 1);
  std::vector<float> window;
  for (int y = 0; y < values.height; ++y)
    for (int x = 0; x < values.width; ++x) {
      if (region.at(x, y, 0) < 0.5f) continue;
      window.clear();
      for (int v = std::max(0, y - radius); v <= std::min(values.height - 1, y + radius); ++v)
        for (int u = std::max(0, x - radius); u <= std::min(values.width - 1, x + radius); ++u)
          if (region.at(u, v, 0) >= 0.5f) window.push_back(values.at(u, v, 0));
      std::nth_element(window.begin(), window.begin() + window.size() / 2, window.end());
      out.at(x, y, 0) = window[window.size() / 2];
    }
  return out;
}

}  // namespace svbrdf
