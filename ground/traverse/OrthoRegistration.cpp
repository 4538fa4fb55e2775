#include "ground/traverse/OrthoRegistration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "firmware_core/base/Angles.hpp"

namespace areomap::traverse {

namespace {

constexpr int kOrthoMinCells = 200;  // common cells below which a correlation is not taken

struct OrthoSample {
  Eigen::Vector2d b_m;
  double grey = 0.0;
};

bool orthoHasGrey(const DemGrid& g, float v) {
  return v != g.nodata && std::isfinite(v) && v > 0.0f;
}

std::vector<OrthoSample> orthoSamples(const DemGrid& ortho, double spacing_m, double max_range_m) {
  const int stride = std::max(1, static_cast<int>(std::lround(spacing_m / ortho.cell_m)));
  std::vector<OrthoSample> out;
  for (int r = stride / 2; r < ortho.rows; r += stride) {
    for (int c = stride / 2; c < ortho.cols; c += stride) {
      const float v = ortho.at(c, r);
      if (!orthoHasGrey(ortho, v)) continue;
      const Eigen::Vector2d p(ortho.northOfRow(r), ortho.eastOfCol(c));
      if (p.norm() <= max_range_m) out.push_back({p, v});
    }
  }
  return out;
}

// NCC of B's samples moved by `pose` against A's ortho (bilinear; 0 where a corner has no grey value).
double orthoNcc(const DemGrid& ortho_a, const std::vector<OrthoSample>& samples, const RelativePose& pose,
                double max_range_m, int& n) {
  const double c = std::cos(pose.heading_rad), s = std::sin(pose.heading_rad);
  double sa = 0.0, sb = 0.0, saa = 0.0, sbb = 0.0, sab = 0.0;
  n = 0;
  for (const OrthoSample& q : samples) {
    const Eigen::Vector2d p(c * q.b_m.x() - s * q.b_m.y() + pose.translation_m.x(),
                            s * q.b_m.x() + c * q.b_m.y() + pose.translation_m.y());
    if (p.squaredNorm() > max_range_m * max_range_m) continue;
    const double g = demElevation(ortho_a, p.x(), p.y());
    if (!std::isfinite(g) || g <= 0.0) continue;
    sa += g;
    sb += q.grey;
    saa += g * g;
    sbb += q.grey * q.grey;
    sab += g * q.grey;
    ++n;
  }
  if (n < kOrthoMinCells) return -1.0;
  const double ma = sa / n, mb = sb / n;
  const double va = saa / n - ma * ma, vb = sbb / n - mb * mb;
  return va > 0.0 && vb > 0.0 ? (sab / n - ma * mb) / std::sqrt(va * vb) : -1.0;
}

// The vertex of the parabola through (-1, lo), (0, mid), (1, hi), in steps (0 when not a peak).
double orthoVertex(double lo, double mid, double hi) {
  const double d = lo - 2.0 * mid + hi;
  return d < 0.0 ? std::clamp(0.5 * (lo - hi) / d, -0.5, 0.5) : 0.0;
}

// The NCC over a grid of poses about `centre`: n steps each side of `step_m` in x and y, nh of `step_rad`.
struct OrthoNccGrid {
  int n = 0, nh = 0;
  double step_m = 0.0, step_rad = 0.0;
  std::vector<double> ncc;
  int side() const { return 2 * n + 1; }
  double& at(int i, int j, int k) { return ncc[(static_cast<std::size_t>(k) * side() + j) * side() + i]; }
  double at(int i, int j, int k) const {
    return ncc[(static_cast<std::size_t>(k) * side() + j) * side() + i];
  }
};

void orthoFillGrid(const DemGrid& ortho_a, const std::vector<OrthoSample>& samples,
                   const RelativePose& centre, double max_range_m, OrthoNccGrid& g) {
  g.ncc.assign(static_cast<std::size_t>(g.side()) * g.side() * (2 * g.nh + 1), -1.0);
  for (int k = 0; k <= 2 * g.nh; ++k) {
    for (int j = 0; j < g.side(); ++j) {
      for (int i = 0; i < g.side(); ++i) {
        int n = 0;
        g.at(i, j, k) =
            orthoNcc(ortho_a, samples,
                     shiftedPose(centre, (i - g.n) * g.step_m, (j - g.n) * g.step_m, (k - g.nh) * g.step_rad),
                     max_range_m, n);
      }
    }
  }
}

struct OrthoPeak {
  int i = 0, j = 0, k = 0;
  double ncc = -1.0;
};

OrthoPeak orthoBestOf(const OrthoNccGrid& g) {
  OrthoPeak best;
  for (int k = 0; k <= 2 * g.nh; ++k)
    for (int j = 0; j < g.side(); ++j)
      for (int i = 0; i < g.side(); ++i)
        if (g.at(i, j, k) > best.ncc) best = {i, j, k, g.at(i, j, k)};
  return best;
}

bool orthoLocalPeak(const OrthoNccGrid& g, int i, int j, int k) {
  const double v = g.at(i, j, k);
  for (int dk = -1; dk <= 1; ++dk) {
    for (int dj = -1; dj <= 1; ++dj) {
      for (int di = -1; di <= 1; ++di) {
        const int ii = i + di, jj = j + dj, kk = k + dk;
        if ((di | dj | dk) == 0 || ii < 0 || jj < 0 || kk < 0 || ii >= g.side() || jj >= g.side() ||
            kk > 2 * g.nh)
          continue;
        if (g.at(ii, jj, kk) > v) return false;
      }
    }
  }
  return true;
}

// The highest local peak away from `best` (as DemRegistration's second minimum), -1 when none.
double orthoSecondPeak(const OrthoNccGrid& g, const OrthoPeak& best, const RegistrationParams& params) {
  double second = -1.0;
  for (int k = 0; k <= 2 * g.nh; ++k) {
    for (int j = 0; j < g.side(); ++j) {
      for (int i = 0; i < g.side(); ++i) {
        const double v = g.at(i, j, k);
        if (v <= second) continue;
        const double d = std::hypot(i - best.i, j - best.j) * g.step_m;
        if (d < params.second_min_distance_m &&
            std::fabs(k - best.k) * g.step_rad < params.second_min_deg * kDegToRad)
          continue;
        if (orthoLocalPeak(g, i, j, k)) second = v;
      }
    }
  }
  return second;
}

std::string orthoFormat(const char* fmt, double a, double b, double c) {
  char buffer[200];
  std::snprintf(buffer, sizeof buffer, fmt, a, b, c);
  return buffer;
}

}  // namespace

OrthoRegistration registerOrthos(const SiteProducts& a, const SiteProducts& b, const RelativePose& apriori,
                                 const RegistrationParams& params) {
  OrthoRegistration out;
  out.a_from_b = apriori;
  if (!a.ortho || !b.ortho) {
    out.message = "no orthoimage to register";
    return out;
  }
  // Coarse: about ten steps each side, the orthos averaged to the step.
  OrthoNccGrid coarse;
  coarse.step_m = coarseStepM(params);
  coarse.step_rad = coarseStepRad(params);
  coarse.n = static_cast<int>(std::lround(params.search_m / coarse.step_m));
  coarse.nh = static_cast<int>(std::lround(params.search_deg * kDegToRad / coarse.step_rad));
  const int fa = std::max(1, static_cast<int>(std::lround(coarse.step_m / a.ortho->cell_m)));
  const int fb = std::max(1, static_cast<int>(std::lround(coarse.step_m / b.ortho->cell_m)));
  const DemGrid coarse_a = fa > 1 ? coarsenDem(*a.ortho, fa) : *a.ortho;
  const DemGrid coarse_b = fb > 1 ? coarsenDem(*b.ortho, fb) : *b.ortho;
  orthoFillGrid(coarse_a, orthoSamples(coarse_b, std::max(0.25, coarse.step_m), params.max_range_m), apriori,
                params.max_range_m, coarse);
  const OrthoPeak best = orthoBestOf(coarse);
  if (best.ncc <= 0.0) {
    out.message = "their orthoimages share too few cells within the search window";
    return out;
  }
  std::vector<double> all;
  for (double v : coarse.ncc)
    if (v > -1.0) all.push_back(v);
  std::nth_element(all.begin(), all.begin() + all.size() / 2, all.end());
  out.median_ncc = all[all.size() / 2];
  out.second_ncc = std::max(0.0, orthoSecondPeak(coarse, best, params));
  // Fine: quarter steps about the coarse peak on the full orthos, then a parabola per axis.
  OrthoNccGrid fine;
  fine.step_m = coarse.step_m / 4.0;
  fine.step_rad = coarse.step_rad / 4.0;
  fine.n = 4;
  fine.nh = 4;
  const RelativePose centre =
      shiftedPose(apriori, (best.i - coarse.n) * coarse.step_m, (best.j - coarse.n) * coarse.step_m,
                  (best.k - coarse.nh) * coarse.step_rad);
  orthoFillGrid(
      *a.ortho,
      orthoSamples(*b.ortho, std::max(params.sample_spacing_m, b.ortho->cell_m), params.max_range_m), centre,
      params.max_range_m, fine);
  const OrthoPeak top = orthoBestOf(fine);
  const auto clampIndex = [](int v, int hi) { return std::clamp(v, 1, hi - 1); };
  const int i = clampIndex(top.i, fine.side() - 1), j = clampIndex(top.j, fine.side() - 1),
            k = clampIndex(top.k, 2 * fine.nh);
  const double di = orthoVertex(fine.at(i - 1, j, k), fine.at(i, j, k), fine.at(i + 1, j, k));
  const double dj = orthoVertex(fine.at(i, j - 1, k), fine.at(i, j, k), fine.at(i, j + 1, k));
  const double dk = orthoVertex(fine.at(i, j, k - 1), fine.at(i, j, k), fine.at(i, j, k + 1));
  out.a_from_b = shiftedPose(centre, (i + di - fine.n) * fine.step_m, (j + dj - fine.n) * fine.step_m,
                             (k + dk - fine.nh) * fine.step_rad);
  out.ncc = orthoNcc(*a.ortho, orthoSamples(*b.ortho, a.ortho->cell_m, params.max_range_m), out.a_from_b,
                     params.max_range_m, out.cells);
  // The search's resolution as the pose's sigma: the ties' geometric check, not this, measures the pose.
  out.covariance.diagonal() << fine.step_m * fine.step_m, fine.step_m * fine.step_m, 0.0,
      fine.step_rad * fine.step_rad;
  if (out.second_ncc > out.median_ncc + 0.5 * (best.ncc - out.median_ncc)) {
    out.message = orthoFormat(
        "their orthoimages match ambiguously (NCC %.2f at the best pose, %.2f at a second peak, %.2f "
        "median)",
        best.ncc, out.second_ncc, out.median_ncc);
    return out;
  }
  out.ok = true;
  return out;
}

}  // namespace areomap::traverse
