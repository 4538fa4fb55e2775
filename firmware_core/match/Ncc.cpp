#include "firmware_core/match/Ncc.hpp"

#include <cmath>

namespace areomap {

namespace {
// Bilinear interpolation between two neighbouring rows at (r0[0] + fx, rows r0 and r1, fy).
inline double bilinear(const uint8_t* r0, const uint8_t* r1, double fx, double fy) {
  return (1.0 - fy) * ((1.0 - fx) * r0[0] + fx * r0[1]) + fy * ((1.0 - fx) * r1[0] + fx * r1[1]);
}

void finishTemplate(NccTemplate& t) {
  int64_t s = 0, s2 = 0;
  for (int32_t i = 0; i < kNccPixels; ++i) {
    s += t.pixels[i];
    s2 += static_cast<int64_t>(t.pixels[i]) * t.pixels[i];
  }
  t.sum = s;
  t.sum_sq = s2;
  const double n = kNccPixels;
  const double var = (static_cast<double>(s2) - static_cast<double>(s) * static_cast<double>(s) / n) / n;
  t.textured = var >= kMinNccVariance;
}
}  // namespace

bool extractTemplate(const ImageView& image, int32_t cx, int32_t cy, NccTemplate& t) {
  if (cx - kNccRadius < 0 || cy - kNccRadius < 0 || cx + kNccRadius >= image.width ||
      cy + kNccRadius >= image.height) {
    t.textured = false;
    return false;
  }
  for (int32_t dy = 0; dy < kNccSide; ++dy) {
    const uint8_t* row = image.row(cy - kNccRadius + dy) + (cx - kNccRadius);
    for (int32_t dx = 0; dx < kNccSide; ++dx) t.pixels[dy * kNccSide + dx] = row[dx];
  }
  finishTemplate(t);
  return true;
}

bool extractTemplateAt(const ImageView& image, double cx, double cy, NccTemplate& t) {
  t.textured = false;
  if (!(cx - kNccRadius >= 0.0 && cy - kNccRadius >= 0.0 && cx + kNccRadius < image.width - 1.0 &&
        cy + kNccRadius < image.height - 1.0)) {
    return false;
  }
  const int32_t x0 = static_cast<int32_t>(std::floor(cx));
  const int32_t y0 = static_cast<int32_t>(std::floor(cy));
  const double fx = cx - x0, fy = cy - y0;
  for (int32_t dy = 0; dy < kNccSide; ++dy) {
    const uint8_t* r0 = image.row(y0 - kNccRadius + dy) + (x0 - kNccRadius);
    const uint8_t* r1 = r0 + image.stride;
    for (int32_t dx = 0; dx < kNccSide; ++dx) {
      t.pixels[dy * kNccSide + dx] = static_cast<uint8_t>(std::lround(bilinear(r0 + dx, r1 + dx, fx, fy)));
    }
  }
  finishTemplate(t);
  return true;
}

void templateFromPixels(const uint8_t* pixels, NccTemplate& t) {
  for (int32_t i = 0; i < kNccPixels; ++i) t.pixels[i] = pixels[i];
  finishTemplate(t);
}

double nccAt(const NccTemplate& t, const ImageView& image, int32_t cx, int32_t cy) {
  if (!t.textured || cx - kNccRadius < 0 || cy - kNccRadius < 0 || cx + kNccRadius >= image.width ||
      cy + kNccRadius >= image.height) {
    return kNccInvalid;
  }
  int64_t s = 0, s2 = 0, st = 0;
  for (int32_t dy = 0; dy < kNccSide; ++dy) {
    const uint8_t* row = image.row(cy - kNccRadius + dy) + (cx - kNccRadius);
    const uint8_t* trow = t.pixels + dy * kNccSide;
    int32_t rs = 0, rs2 = 0, rst = 0;
    for (int32_t dx = 0; dx < kNccSide; ++dx) {
      const int32_t v = row[dx];
      rs += v;
      rs2 += v * v;
      rst += v * trow[dx];
    }
    s += rs;
    s2 += rs2;
    st += rst;
  }
  return nccFromSums(t, nccTemplateVariance(t), static_cast<double>(s), static_cast<double>(s2),
                     static_cast<double>(st));
}

void warpSamples(const Mat2& a, WarpedSamples& s) {
  s.reach_x = kNccRadius * (std::fabs(a(0, 0)) + std::fabs(a(0, 1)));
  s.reach_y = kNccRadius * (std::fabs(a(1, 0)) + std::fabs(a(1, 1)));
  s.min_dx = s.min_dy = 0;
  s.max_dx = s.max_dy = 0;
  for (int32_t v = -kNccRadius; v <= kNccRadius; ++v) {
    for (int32_t u = -kNccRadius; u <= kNccRadius; ++u) {
      const int32_t k = (v + kNccRadius) * kNccSide + (u + kNccRadius);
      const double ox = a(0, 0) * u + a(0, 1) * v;
      const double oy = a(1, 0) * u + a(1, 1) * v;
      const double floor_x = std::floor(ox);
      const double floor_y = std::floor(oy);
      s.dx[k] = static_cast<int32_t>(floor_x);
      s.dy[k] = static_cast<int32_t>(floor_y);
      s.fx[k] = ox - floor_x;
      s.fy[k] = oy - floor_y;
      s.gx[k] = 1.0 - s.fx[k];
      s.gy[k] = 1.0 - s.fy[k];
      s.min_dx = s.dx[k] < s.min_dx ? s.dx[k] : s.min_dx;
      s.max_dx = s.dx[k] > s.max_dx ? s.dx[k] : s.max_dx;
      s.min_dy = s.dy[k] < s.min_dy ? s.dy[k] : s.min_dy;
      s.max_dy = s.dy[k] > s.max_dy ? s.dy[k] : s.max_dy;
    }
  }
}

bool warpedWindowInside(const WarpedSamples& s, const ImageView& image, int32_t cx, int32_t cy) {
  // The reach test keeps every sample strictly inside [0, size - 1); the integer test holds the bilinear
  // reads inside the image where rounding puts a sample a hair beyond the reach.
  if (cx - s.reach_x < 0.0 || cy - s.reach_y < 0.0 || cx + s.reach_x >= image.width - 1.0 ||
      cy + s.reach_y >= image.height - 1.0) {
    return false;
  }
  return cx + s.min_dx >= 0 && cy + s.min_dy >= 0 && cx + s.max_dx + 1 <= image.width - 1 &&
         cy + s.max_dy + 1 <= image.height - 1;
}

double nccWarpedAt(const NccTemplate& t, const ImageView& image, int32_t cx, int32_t cy, const WarpedSamples& s) {
  if (!t.textured || !warpedWindowInside(s, image, cx, cy)) return kNccInvalid;
  double sum = 0.0, sum_sq = 0.0, cross = 0.0;
  for (int32_t k = 0; k < kNccPixels; ++k) {
    const uint8_t* r0 = image.row(cy + s.dy[k]) + (cx + s.dx[k]);
    const uint8_t* r1 = r0 + image.stride;
    // The bilinear value in the operation order of WarpedSearch.cpp's four-position blocks (bit for bit).
    const double value = s.gy[k] * (s.gx[k] * r0[0] + s.fx[k] * r0[1]) + s.fy[k] * (s.gx[k] * r1[0] + s.fx[k] * r1[1]);
    sum += value;
    sum_sq += value * value;
    cross += value * static_cast<double>(t.pixels[k]);
  }
  return nccFromSums(t, nccTemplateVariance(t), sum, sum_sq, cross);
}

double nccWarpedAt(const NccTemplate& t, const ImageView& image, int32_t cx, int32_t cy, const Mat2& a) {
  WarpedSamples s;
  warpSamples(a, s);
  return nccWarpedAt(t, image, cx, cy, s);
}

double nccOfSamples(const double* t, const double* s, int32_t n, double min_variance) {
  double st = 0.0, ss = 0.0, stt = 0.0, sss = 0.0, sts = 0.0;
  for (int32_t k = 0; k < n; ++k) {
    st += t[k];
    ss += s[k];
    stt += t[k] * t[k];
    sss += s[k] * s[k];
    sts += t[k] * s[k];
  }
  const double count = n;
  const double var_t = count * stt - st * st;
  if (var_t <= min_variance) return kNccInvalid;
  // "At or below min_variance" in nccFromSums' terms: below the next double above it.
  return nccFromSums(count, st, var_t, ss, sss, sts, std::nextafter(min_variance, INFINITY));
}

double parabolaOffset(double minus, double centre, double plus) {
  if (minus <= kNccInvalid || plus <= kNccInvalid) return 0.0;
  const double curvature = minus - 2.0 * centre + plus;
  if (curvature >= 0.0) return 0.0;
  const double offset = 0.5 * (minus - plus) / curvature;
  return std::fmax(-0.5, std::fmin(0.5, offset));
}

void refinePeak(const NccTemplate& t, const ImageView& image, int32_t bx, int32_t by, double best,
                double& x_px, double& y_px) {
  const double l = nccAt(t, image, bx - 1, by);
  const double r = nccAt(t, image, bx + 1, by);
  const double u = nccAt(t, image, bx, by - 1);
  const double d = nccAt(t, image, bx, by + 1);
  x_px = bx + parabolaOffset(l, best, r);
  y_px = by + parabolaOffset(u, best, d);
}

}  // namespace areomap
