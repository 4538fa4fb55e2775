// Image patches of the simulator tests: bilinear sampling of a rendered image, NCC of patches, and the NCC
// of a patch with the same surface seen in another image (each pixel cast onto the terrain).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/sim/Renderer.hpp"
#include "ground/sim/Terrain.hpp"

namespace areomap::sim::patches {

inline double bilinear(const RenderedImage& im, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int c, int r) {
    c = std::clamp(c, 0, im.width - 1);
    r = std::clamp(r, 0, im.height - 1);
    return static_cast<double>(im.pixels[static_cast<std::size_t>(r) * im.width + c]);
  };
  return at(x0, y0) * (1 - fx) * (1 - fy) + at(x0 + 1, y0) * fx * (1 - fy) + at(x0, y0 + 1) * (1 - fx) * fy +
         at(x0 + 1, y0 + 1) * fx * fy;
}

inline double nccOf(const std::vector<double>& va, const std::vector<double>& vb) {
  const double n = static_cast<double>(va.size());
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < va.size(); ++i) {
    ma += va[i] / n;
    mb += vb[i] / n;
  }
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < va.size(); ++i) {
    sab += (va[i] - ma) * (vb[i] - mb);
    saa += (va[i] - ma) * (va[i] - ma);
    sbb += (vb[i] - mb) * (vb[i] - mb);
  }
  return sab / std::sqrt(std::max(1e-12, saa * sbb));
}

// NCC of (2 half + 1)^2 patches centred on sub-pixel positions.
inline double ncc(const RenderedImage& a, const Vec2& pa, const RenderedImage& b, const Vec2& pb, int half) {
  std::vector<double> va, vb;
  for (int dy = -half; dy <= half; ++dy) {
    for (int dx = -half; dx <= half; ++dx) {
      va.push_back(bilinear(a, pa.x() + dx, pa.y() + dy));
      vb.push_back(bilinear(b, pb.x() + dx, pb.y() + dy));
    }
  }
  return nccOf(va, vb);
}

// NCC of the patch around `pa` in image A with the same surface seen in image B: every pixel of A's patch
// is cast onto the terrain and the hit projected into B (so perspective differences do not count).
inline bool warpedNcc(const Terrain& terrain, const CameraModel& ma, const RenderedImage& a, const Vec2& pa,
                      const CameraModel& mb, const RenderedImage& b, int half, double& value) {
  std::vector<double> va, vb;
  for (int dy = -half; dy <= half; ++dy) {
    for (int dx = -half; dx <= half; ++dx) {
      Vec3 origin, dir;
      double t = 0.0;
      Vec2 pb;
      if (unproject(ma, Vec2(pa.x() + dx, pa.y() + dy), origin, dir) != Status::kOk ||
          !terrain.castRay(origin, dir, t) || project(mb, origin + t * dir, pb) != Status::kOk) {
        return false;
      }
      va.push_back(bilinear(a, pa.x() + dx, pa.y() + dy));
      vb.push_back(bilinear(b, pb.x(), pb.y()));
    }
  }
  value = nccOf(va, vb);
  return true;
}

}  // namespace areomap::sim::patches
