#include "photometric/pixel_mesh.h"

#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <deque>

#include "core/error.h"

namespace svbrdf {

void NormalIntegrationOptions::Check() const {
  if (!(max_slope > 0)) throw Error(Msg("normal integration: max_slope must be > 0, got ", max_slope));
  if (bilateral_iterations < 0)
    throw Error(Msg("normal integration: bilateral_iterations must be >= 0, got ", bilateral_iterations));
  if (!(bilateral_k > 0)) throw Error(Msg("normal integration: bilateral_k must be > 0, got ", bilateral_k));
  if (!(tolerance >= 0)) throw Error(Msg("normal integration: tolerance must be >= 0, got ", tolerance));
}

namespace {

// One one-sided difference equation of the bilateral refinement:
// confidence * (z[plus] - z[minus] - slope) = 0, all in pixel units.
struct DifferenceRow {
  int plus, minus;  // unknowns
  double slope, confidence;
  int partner;  // the row of the pixel's other side along the same axis, or -1
};

}  // namespace

std::vector<double> IntegrateNormals(const Image& normals_cam, const Image& region, double metres_per_pixel,
                                     const NormalIntegrationOptions& options) {
  options.Check();
  const int w = region.width, h = region.height;
  std::vector<int> index(size_t(w) * h, -1);
  int n = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (region.at(x, y, 0) > 0.5f) index[size_t(y) * w + x] = n++;
  std::vector<double> depth(size_t(w) * h, 0.0);
  if (n == 0) return depth;
  // dz/dx = -nx/nz, dz/dy = -ny/nz on the surface z(x, y) (camera frame), in
  // pixels per pixel.
  auto slope = [&](int x, int y, int axis) {
    const double nz = std::min(-1e-3, double(normals_cam.at(x, y, 2)));  // facing the camera: nz < 0
    return std::clamp(-double(normals_cam.at(x, y, axis)) / nz, -options.max_slope, options.max_slope);
  };
  auto neighbour = [&](int x, int y, int axis, int step) {
    const int x2 = x + (axis == 0) * step, y2 = y + (axis == 1) * step;
    return x2 < 0 || y2 < 0 || x2 >= w || y2 >= h ? -1 : index[size_t(y2) * w + x2];
  };
  // A weak pull to 0 fixes each part's free offset; removed again below.
  const double kAnchor = 1e-6;
  std::vector<Eigen::Triplet<double>> t;
  std::vector<double> rhs;
  int row = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int i = index[size_t(y) * w + x];
      if (i < 0) continue;
      for (int axis = 0; axis < 2; ++axis) {
        const int j = neighbour(x, y, axis, 1);
        if (j < 0) continue;
        t.emplace_back(row, j, 1.0);
        t.emplace_back(row, i, -1.0);
        const int x2 = x + (axis == 0), y2 = y + (axis == 1);
        rhs.push_back(0.5 * (slope(x, y, axis) + slope(x2, y2, axis)));
        ++row;
      }
    }
  for (int i = 0; i < n; ++i) {
    t.emplace_back(row++, i, kAnchor);
    rhs.push_back(0.0);
  }
  Eigen::SparseMatrix<double> A(row, n);
  A.setFromTriplets(t.begin(), t.end());
  const Eigen::Map<const Eigen::VectorXd> b(rhs.data(), row);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(A.transpose() * A);
  if (solver.info() != Eigen::Success) throw Error("normal integration: factorisation failed");
  Eigen::VectorXd z = solver.solve(A.transpose() * b);

  if (options.bilateral_iterations > 0) {
    // Both one-sided differences of every pixel along each axis; a pixel's
    // equations are scaled by |n.z| (the normal's own form n.z dz + n.x = 0),
    // so grazing normals, whose slope is least certain, count least.
    std::vector<DifferenceRow> rows;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int i = index[size_t(y) * w + x];
        if (i < 0) continue;
        const double confidence = std::max(0.05, -double(normals_cam.at(x, y, 2)));
        for (int axis = 0; axis < 2; ++axis) {
          const int forward = neighbour(x, y, axis, 1), backward = neighbour(x, y, axis, -1);
          const int first = int(rows.size());
          const double s = slope(x, y, axis);
          if (forward >= 0) rows.push_back({forward, i, s, confidence, -1});
          if (backward >= 0) rows.push_back({i, backward, s, confidence, -1});
          if (forward >= 0 && backward >= 0) rows[first].partner = first + 1, rows[first + 1].partner = first;
        }
      }
    const int m = int(rows.size());
    std::vector<double> weight(m, 1.0);
    auto reweight = [&] {
      for (int r = 0; r < m; ++r) {
        const DifferenceRow& d = rows[r];
        if (d.partner < 0) continue;
        // Trust this side more the smaller its jump is than the other's;
        // jumps scaled by |n.z| as the equations are (Cao et al.'s code
        // weighs A z, not z's differences), so that a steep but smooth
        // stretch, whose differences are large on both sides, keeps both.
        const DifferenceRow& o = rows[d.partner];
        const double own = d.confidence * (z[d.plus] - z[d.minus]);
        const double other = d.confidence * (z[o.plus] - z[o.minus]);
        weight[r] = 1.0 / (1.0 + std::exp(-options.bilateral_k * (other * other - own * own)));
      }
    };
    auto energy = [&] {
      double e = 0;
      for (int r = 0; r < m; ++r) {
        const double res = rows[r].confidence * (z[rows[r].plus] - z[rows[r].minus] - rows[r].slope);
        e += weight[r] * res * res;
      }
      return e;
    };
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> bilateral;
    double last = -1;
    for (int it = 0; it < options.bilateral_iterations; ++it) {
      reweight();
      std::vector<Eigen::Triplet<double>> nt;
      nt.reserve(size_t(m) * 4 + n);
      Eigen::VectorXd atb = Eigen::VectorXd::Zero(n);
      for (int r = 0; r < m; ++r) {
        const DifferenceRow& d = rows[r];
        const double c = weight[r] * d.confidence * d.confidence;
        nt.emplace_back(d.plus, d.plus, c);
        nt.emplace_back(d.minus, d.minus, c);
        nt.emplace_back(d.plus, d.minus, -c);
        nt.emplace_back(d.minus, d.plus, -c);
        atb[d.plus] += c * d.slope;
        atb[d.minus] -= c * d.slope;
      }
      for (int i = 0; i < n; ++i) nt.emplace_back(i, i, kAnchor * kAnchor);
      Eigen::SparseMatrix<double> normal(n, n);
      normal.setFromTriplets(nt.begin(), nt.end());
      if (it == 0) bilateral.analyzePattern(normal);
      bilateral.factorize(normal);
      if (bilateral.info() != Eigen::Success) throw Error("normal integration: bilateral factorisation failed");
      z = bilateral.solve(atb);
      const double e = energy();
      if (last >= 0 && std::abs(last - e) <= options.tolerance * std::max(last, 1e-12)) break;
      last = e;
    }
  }
  z *= metres_per_pixel;
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
