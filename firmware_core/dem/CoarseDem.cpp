#include "firmware_core/dem/CoarseDem.hpp"

#include <cmath>

namespace areomap {

void CoarseDem::reset(const Vec3& centre_m) {
  const double half = 0.5 * kCoarseDemCells * kCoarseDemCellM;
  origin_m_ = Vec3(centre_m.x() - half, centre_m.y() - half, 0.0);
  for (int32_t r = 0; r < kCoarseDemCells; ++r) {
    for (int32_t c = 0; c < kCoarseDemCells; ++c) {
      sum_z_[r][c] = 0.0f;
      count_[r][c] = 0;
      z_[r][c] = 0.0f;
      valid_[r][c] = false;
      filled_[r][c] = false;
    }
  }
  point_count_ = 0;
  outside_count_ = 0;
  measured_cells_ = 0;
}

bool CoarseDem::addPoint(const Vec3& point_m) {
  const double fr = (point_m.x() - origin_m_.x()) / kCoarseDemCellM;
  const double fc = (point_m.y() - origin_m_.y()) / kCoarseDemCellM;
  if (!(fr >= 0.0 && fc >= 0.0 && fr < kCoarseDemCells && fc < kCoarseDemCells) || !std::isfinite(point_m.z())) {
    ++outside_count_;
    return false;
  }
  const int32_t r = static_cast<int32_t>(fr);
  const int32_t c = static_cast<int32_t>(fc);
  if (count_[r][c] == UINT16_MAX) return true;
  sum_z_[r][c] += static_cast<float>(point_m.z());
  ++count_[r][c];
  ++point_count_;
  return true;
}

int32_t CoarseDem::finish() {
  measured_cells_ = 0;
  for (int32_t r = 0; r < kCoarseDemCells; ++r) {
    for (int32_t c = 0; c < kCoarseDemCells; ++c) {
      valid_[r][c] = count_[r][c] > 0;
      filled_[r][c] = false;
      if (valid_[r][c]) {
        z_[r][c] = sum_z_[r][c] / count_[r][c];
        ++measured_cells_;
      }
    }
  }
  // Hole filling: a cell with at least 2 valid 8-neighbours takes their mean; one pass per ring.
  for (int32_t pass = 0; pass < kMaxCoarseDemFillPasses; ++pass) {
    for (int32_t r = 0; r < kCoarseDemCells; ++r) {
      for (int32_t c = 0; c < kCoarseDemCells; ++c) {
        if (valid_[r][c]) continue;
        double sum = 0.0;
        int32_t n = 0;
        for (int32_t dr = -1; dr <= 1; ++dr) {
          for (int32_t dc = -1; dc <= 1; ++dc) {
            const int32_t rr = r + dr, cc = c + dc;
            if (rr < 0 || cc < 0 || rr >= kCoarseDemCells || cc >= kCoarseDemCells) continue;
            if (valid_[rr][cc] && !filled_[rr][cc]) {
              sum += z_[rr][cc];
              ++n;
            }
          }
        }
        if (n >= 2) {
          z_[r][c] = static_cast<float>(sum / n);
          filled_[r][c] = true;  // usable after this pass, not as a source within it
        }
      }
    }
    for (int32_t r = 0; r < kCoarseDemCells; ++r) {
      for (int32_t c = 0; c < kCoarseDemCells; ++c) {
        if (filled_[r][c]) {
          valid_[r][c] = true;
          filled_[r][c] = false;
        }
      }
    }
  }
  int32_t valid = 0;
  for (int32_t r = 0; r < kCoarseDemCells; ++r)
    for (int32_t c = 0; c < kCoarseDemCells; ++c) valid += valid_[r][c] ? 1 : 0;
  return valid;
}

bool CoarseDem::cellValue(int32_t row, int32_t col, double& z_m) const {
  if (row < 0 || col < 0 || row >= kCoarseDemCells || col >= kCoarseDemCells || !valid_[row][col]) return false;
  z_m = z_[row][col];
  return true;
}

bool CoarseDem::elevationAt(double x_m, double y_m, double& z_m) const {
  // Cell centres at origin + (i + 0.5) * cell.
  const double fr = (x_m - origin_m_.x()) / kCoarseDemCellM - 0.5;
  const double fc = (y_m - origin_m_.y()) / kCoarseDemCellM - 0.5;
  if (!(fr >= -0.5 && fc >= -0.5 && fr <= kCoarseDemCells - 0.5 && fc <= kCoarseDemCells - 0.5)) return false;
  const int32_t r0 = static_cast<int32_t>(std::floor(fr));
  const int32_t c0 = static_cast<int32_t>(std::floor(fc));
  const double a = fr - r0, b = fc - c0;
  double sum = 0.0, weight = 0.0;
  for (int32_t dr = 0; dr <= 1; ++dr) {
    for (int32_t dc = 0; dc <= 1; ++dc) {
      double z = 0.0;
      if (!cellValue(r0 + dr, c0 + dc, z)) continue;
      const double wgt = (dr ? a : 1.0 - a) * (dc ? b : 1.0 - b);
      sum += wgt * z;
      weight += wgt;
    }
  }
  if (weight < 0.25) return false;
  z_m = sum / weight;
  return true;
}

Status CoarseDem::intersectRay(const Vec3& origin, const Vec3& direction, Vec3& point) const {
  const double step = 0.5 * kCoarseDemCellM;
  bool have_previous = false;
  double previous_t = 0.0, previous_f = 0.0;
  for (int32_t k = 1; k <= kMaxDemRaySteps; ++k) {
    const double t = k * step;
    const Vec3 p = origin + t * direction;
    double z = 0.0;
    if (!elevationAt(p.x(), p.y(), z)) {
      have_previous = false;
      continue;
    }
    const double f = p.z() - z;  // > 0: below the surface (Z down)
    if (f >= 0.0) {
      double t_hit = t;
      if (have_previous && previous_f < 0.0) t_hit = previous_t + (t - previous_t) * (-previous_f) / (f - previous_f);
      point = origin + t_hit * direction;
      return Status::kOk;
    }
    have_previous = true;
    previous_t = t;
    previous_f = f;
  }
  return Status::kDegenerate;
}

}  // namespace areomap
