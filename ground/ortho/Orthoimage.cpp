#include "ground/ortho/Orthoimage.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include <opencv2/core/utility.hpp>

#include "firmware_core/camera/CahvInternal.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/dem/Viewshed.hpp"
#include "ground/ortho/ConeBlock.hpp"

namespace areomap::ortho {

namespace {

double bilinear(const cv::Mat& g, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x));
  const int y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0;
  const double fy = y - y0;
  const int x1 = std::min(x0 + 1, g.cols - 1);
  const int y1 = std::min(y0 + 1, g.rows - 1);
  const uint8_t* r0 = g.ptr<uint8_t>(std::max(0, y0));
  const uint8_t* r1 = g.ptr<uint8_t>(y1);
  const int xa = std::max(0, x0);
  return (1 - fy) * ((1 - fx) * r0[xa] + fx * r0[x1]) + fy * ((1 - fx) * r1[xa] + fx * r1[x1]);
}

bool inside(const cv::Mat& g, const Vec2& p, double border) {
  return p.x() >= border && p.y() >= border && p.x() <= g.cols - 1 - border && p.y() <= g.rows - 1 - border;
}

// Whether the pixel `px` that `point` projects to really images it: the pixel's own ray (unproject) passes
// within half a pixel of the point. The radial distortion of CAHVOR/CAHVORE is a polynomial in the
// off-axis angle that turns back beyond the field it was fitted for (with the navcam's R = 0 .006 -.004
// the image radius peaks at ~70 degrees off the axis and falls to the centre at ~76): `project` maps such
// points, which the camera cannot see, into the image, often near its centre, where the nearest-centre
// rule would take them (thin radial strips of foreign texture along the seams). Half a pixel: the point
// lies in the pixel's footprint; a true projection round-trips to the inverse's precision (1e-9 rad), a
// folded one misses by tens of degrees.
bool pixelSeesPoint(const CameraModel& m, const Vec3& point, const Vec2& px, double px_per_rad) {
  Vec3 origin, ray;
  if (unproject(m, px, origin, ray) != Status::kOk) return false;
  const Vec3 to = point - origin;
  const double dist = to.norm();
  if (!(to.dot(ray) > 0.0) || !(dist > 0.0)) return false;
  return to.cross(ray).norm() / dist * px_per_rad < 0.5;
}

// Zero-mean NCC of the patch of `a` around (ax, ay) and of `b` around (bx, by), bilinear.
double ncc(const cv::Mat& a, double ax, double ay, const cv::Mat& b, double bx, double by, int half) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  int n = 0;
  for (int dy = -half; dy <= half; ++dy) {
    for (int dx = -half; dx <= half; ++dx) {
      const double va = bilinear(a, ax + dx, ay + dy);
      const double vb = bilinear(b, bx + dx, by + dy);
      sa += va;
      sb += vb;
      saa += va * va;
      sbb += vb * vb;
      sab += va * vb;
      ++n;
    }
  }
  const double ca = saa - sa * sa / n;
  const double cb = sbb - sb * sb / n;
  if (ca <= 1e-6 || cb <= 1e-6) return -2.0;
  return (sab - sa * sb / n) / std::sqrt(ca * cb);
}

double parabolaOffset(double m, double c, double p) {
  const double den = m - 2 * c + p;
  if (std::fabs(den) < 1e-12) return 0.0;
  return std::clamp(0.5 * (m - p) / den, -0.5, 0.5);
}

// Per source: its image centre (the nearest-centre rule), its larger focal length in pixels (hs, vs) and
// its image's cone (ground/dem imageCone, of the image's size), outside which a point's projection is
// either outside the image or folded into it by the distortion (which pixelSeesPoint refuses): such
// points are passed over before the projection.
struct SourceGeometry {
  std::vector<Vec2> centre;
  std::vector<double> px_per_rad;
  std::vector<dem::ImageCone> cone;
};

SourceGeometry sourceGeometry(const std::vector<OrthoSource>& sources) {
  SourceGeometry geometry{std::vector<Vec2>(sources.size()), std::vector<double>(sources.size()),
                          std::vector<dem::ImageCone>(sources.size())};
  for (std::size_t i = 0; i < sources.size(); ++i) {
    const CahvInternal internal = cahvInternal(sources[i].model);
    geometry.centre[i] = Vec2(0.5 * (sources[i].grey.cols - 1), 0.5 * (sources[i].grey.rows - 1));
    geometry.px_per_rad[i] = std::max(internal.hs_px, internal.vs_px);
    if (sources[i].grey.empty()) continue;
    CameraModel sized = sources[i].model;
    sized.width = sources[i].grey.cols;
    sized.height = sources[i].grey.rows;
    geometry.cone[i] = dem::imageCone(sized);
  }
  return geometry;
}

// Whether `ground` lies within the cone of source i (SourceGeometry): outside it no pixel of the image
// sees it.
bool inCone(const SourceGeometry& geometry, std::size_t i, const CameraModel& m, const Vec3& ground) {
  const Vec3 d = ground - m.c;
  return !(d.dot(geometry.cone[i].axis) < geometry.cone[i].min_cos * d.norm());
}

// Per ortho cell, for the seam check: the second-best candidate (index, -1 none) and both candidates' pixels.
struct SeamCandidates {
  cv::Mat second;     // CV_16S
  cv::Mat best_px;    // CV_32FC2
  cv::Mat second_px;  // CV_32FC2
};

// The images that see a ground point, the best and the next: the nearest to their image centre.
struct SourceChoice {
  int best = -1, next = -1;
  Vec2 best_px = Vec2::Zero(), next_px = Vec2::Zero();
};

// Per DEM cell and source: whether the DEM's terrain leaves the cell's ground point in the source camera's
// view (OrthoOptions::occlusion; everything is seen when it is off).
struct TerrainVisibility {
  bool on = false;
  std::size_t words = 0;        // per cell
  std::vector<uint64_t> bits;   // cell * words + source / 64, bit source % 64
  bool sees(std::size_t cell, std::size_t source) const {
    return !on || ((bits[cell * words + source / 64] >> (source % 64)) & 1u) != 0;
  }
};

// The DEM, each filled cell lowered by twice its sigma (when given on the same grid), hides; a cell is
// seen from a source's centre when its elevation clears the horizon there (ground/dem Viewshed). Source
// k's bits are set over windows[k] only (the DEM cells it may paint; an empty window: none): a horizon
// costs the box about its window and its eye, not the whole grid.
TerrainVisibility terrainVisibility(const DemGrid& dem, const std::vector<OrthoSource>& sources,
                                    const OrthoOptions& options, const std::vector<dem::GridWindow>& windows) {
  TerrainVisibility vis;
  if (!options.occlusion) return vis;
  vis.on = true;
  vis.words = (sources.size() + 63) / 64;
  vis.bits.assign(dem.values.size() * std::max<std::size_t>(1, vis.words), 0);
  DemGrid hiding = dem;
  const DemGrid* sigma = options.dem_sigma;
  if (sigma != nullptr && sigma->values.size() == dem.values.size()) {
    for (std::size_t i = 0; i < hiding.values.size(); ++i) {
      const float s = sigma->values[i];
      if (hiding.values[i] != dem.nodata && s != sigma->nodata && std::isfinite(s)) hiding.values[i] -= 2.0f * s;
    }
  }
  std::vector<std::size_t> used;
  std::vector<Vec3> eyes;
  std::vector<dem::GridWindow> used_windows;
  for (std::size_t k = 0; k < sources.size(); ++k) {
    if (sources[k].grey.empty() || windows[k].cols <= 0 || windows[k].rows <= 0) continue;
    used.push_back(k);
    eyes.push_back(sources[k].model.c);
    used_windows.push_back(windows[k]);
  }
  // The sources' horizons made on threads, each source's bits set in the sources' order.
  dem::forEachHorizon(hiding, eyes, used_windows, true, [&](std::size_t e, const std::vector<float>& horizon) {
    const std::size_t k = used[e];
    const dem::GridWindow& w = used_windows[e];
    cli::parallelFor(static_cast<std::size_t>(w.rows), 0, [&](std::size_t wr) {
      const int r = w.row0 + static_cast<int>(wr);
      for (int c = w.col0; c < w.col0 + w.cols; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * dem.cols + c;
        const float v = dem.values[i];
        if (v != dem.nodata && v >= horizon[w.at(c, r)]) vis.bits[i * vis.words + k / 64] |= uint64_t{1} << (k % 64);
      }
    });
  });
  return vis;
}

// The sources that may see a block of cells (ConeBlock.hpp): in index order, each with whether its cone
// surely holds every cell of the block (its per-cell cone test is then skipped).
struct BlockSources {
  std::vector<std::size_t> index;
  std::vector<uint8_t> all_in_cone;
};

void blockSources(const std::vector<OrthoSource>& sources, const SourceGeometry& geometry, const PointBounds& bounds,
                  BlockSources& out) {
  out.index.clear();
  out.all_in_cone.clear();
  if (bounds.empty()) return;
  for (std::size_t i = 0; i < sources.size(); ++i) {
    if (sources[i].grey.empty()) continue;
    const dem::ImageCone& cone = geometry.cone[i];
    const int where = cone.min_cos > 0.0
                          ? blockAgainstCone(bounds, sources[i].model.c, cone.axis, cone.min_cos * cone.min_cos)
                          : kConeAcross;
    if (where == kConeOutside) continue;
    out.index.push_back(i);
    out.all_in_cone.push_back(where == kConeInside ? 1 : 0);
  }
}

// The best and next source of a ground point among `candidates` (a block's, blockSources): the same as
// over every source, since the others' cones do not hold it. The two nearest their image centres of the
// sources whose pixel sees the point (pixelSeesPoint), ties to the lower index: the sources that hold it
// taken in that order until two see it, so that the costly check runs about twice per cell.
SourceChoice chooseSources(const Vec3& ground, const std::vector<OrthoSource>& sources,
                           const SourceGeometry& geometry, const OrthoOptions& options,
                           const TerrainVisibility& visibility, std::size_t dem_cell, const BlockSources& candidates) {
  struct Held {
    double d;
    std::size_t i;
    Vec2 px;
  };
  thread_local std::vector<Held> held;
  held.clear();
  for (std::size_t k = 0; k < candidates.index.size(); ++k) {
    const std::size_t i = candidates.index[k];
    if (!visibility.sees(dem_cell, i) || (!candidates.all_in_cone[k] && !inCone(geometry, i, sources[i].model, ground)))
      continue;
    Vec2 px;
    if (project(sources[i].model, ground, px) != Status::kOk || !inside(sources[i].grey, px, options.border_px)) continue;
    held.push_back({(px - geometry.centre[i]).squaredNorm(), i, px});
  }
  SourceChoice choice;
  for (std::size_t taken = 0; taken < held.size() && choice.next < 0; ++taken) {
    std::size_t first = taken;
    for (std::size_t k = taken + 1; k < held.size(); ++k) {
      if (held[k].d < held[first].d || (held[k].d == held[first].d && held[k].i < held[first].i)) first = k;
    }
    std::swap(held[taken], held[first]);
    const Held& h = held[taken];
    if (!pixelSeesPoint(sources[h.i].model, ground, h.px, geometry.px_per_rad[h.i])) continue;
    if (choice.best < 0) {
      choice.best = static_cast<int>(h.i);
      choice.best_px = h.px;
    } else {
      choice.next = static_cast<int>(h.i);
      choice.next_px = h.px;
    }
  }
  return choice;
}

// Ortho cells per side of the blocks whose sources are found together (blockSources).
constexpr int kOrthoBlockCells = 16;

// A cell's ground elevation for the ortho (false: none, or the caller reads none of its DEM cell).
bool orthoCellElevation(const DemGrid& dem, const OrthoResult& out, const OrthoOptions& options, int r, int c,
                        double& elev) {
  const int s = options.supersample;
  const std::size_t dem_cell = static_cast<std::size_t>(r / s) * dem.cols + static_cast<std::size_t>(c / s);
  if (options.cells != nullptr && (*options.cells)[dem_cell] == 0) return false;
  if (s == 1) {
    const float v = dem.at(c, r);
    if (v == dem.nodata) return false;
    elev = v;
    return true;
  }
  return demElevation(dem, out.grid.northOfRow(r), out.grid.eastOfCol(c), elev);
}

// Every cell with a DEM elevation takes its grey value from its best source (bands of rows in parallel,
// each row set empty first: the result and the candidates come allocated, not filled). First the blocks'
// sources (blockSources) and from them each source's window of DEM cells for its horizon.
void fillCells(const DemGrid& dem, const std::vector<OrthoSource>& sources, const OrthoOptions& options,
               OrthoResult& out, SeamCandidates& candidates) {
  const SourceGeometry geometry = sourceGeometry(sources);
  const int s = options.supersample;
  const int cols = out.grid.cols, rows = out.grid.rows;
  const int bands = (rows + kOrthoBlockCells - 1) / kOrthoBlockCells;
  const int per_band = (cols + kOrthoBlockCells - 1) / kOrthoBlockCells;
  std::vector<BlockSources> blocks(static_cast<std::size_t>(bands) * per_band);
  // Block b's first and last rows and columns of cells.
  const auto span = [&](std::size_t b) {
    const int r0 = static_cast<int>(b / per_band) * kOrthoBlockCells, c0 = static_cast<int>(b % per_band) * kOrthoBlockCells;
    return std::array<int, 4>{r0, c0, std::min(rows, r0 + kOrthoBlockCells) - 1, std::min(cols, c0 + kOrthoBlockCells) - 1};
  };
  cli::parallelFor(blocks.size(), 0, [&](std::size_t b) {
    const auto [r0, c0, r1, c1] = span(b);
    PointBounds bounds;
    {
      // A cell's elevation (its DEM cell's, or bilinear) lies within the values of the DEM nodes about
      // it: the block's cells (those the caller reads) lie within the bounds of their places and of those
      // nodes.
      bool read = options.cells == nullptr;
      for (int dr = r0 / s; dr <= r1 / s && !read; ++dr) {
        for (int dc = c0 / s; dc <= c1 / s && !read; ++dc) read = (*options.cells)[static_cast<std::size_t>(dr) * dem.cols + dc] != 0;
      }
      const auto node = [&dem](double index) { return static_cast<int>(std::floor(index)); };
      const int n_c0 = std::max(0, node((out.grid.eastOfCol(c0) - dem.east0_m) / dem.cell_m - 0.5));
      const int n_c1 = std::min(dem.cols - 1, node((out.grid.eastOfCol(c1) - dem.east0_m) / dem.cell_m - 0.5) + 1);
      const int n_r0 = std::max(0, node((dem.north0_m - out.grid.northOfRow(r0)) / dem.cell_m - 0.5));
      const int n_r1 = std::min(dem.rows - 1, node((dem.north0_m - out.grid.northOfRow(r1)) / dem.cell_m - 0.5) + 1);
      double lo = 1e300, hi = -1e300;
      for (int nr = n_r0; read && nr <= n_r1; ++nr) {
        for (int nc = n_c0; nc <= n_c1; ++nc) {
          const float v = dem.at(nc, nr);
          if (v == dem.nodata) continue;
          lo = std::min<double>(lo, v);
          hi = std::max<double>(hi, v);
        }
      }
      if (lo <= hi) {
        bounds.add(Vec3(out.grid.northOfRow(r0), out.grid.eastOfCol(c0), -hi));
        bounds.add(Vec3(out.grid.northOfRow(r1), out.grid.eastOfCol(c1), -lo));
      }
    }
    blockSources(sources, geometry, bounds, blocks[b]);
  });
  std::vector<dem::GridWindow> windows(sources.size());
  {
    std::vector<int> lo_c(sources.size(), dem.cols), hi_c(sources.size(), -1), lo_r(sources.size(), dem.rows),
        hi_r(sources.size(), -1);
    for (std::size_t b = 0; b < blocks.size(); ++b) {
      const auto [r0, c0, r1, c1] = span(b);
      for (std::size_t i : blocks[b].index) {
        lo_c[i] = std::min(lo_c[i], c0 / s), hi_c[i] = std::max(hi_c[i], c1 / s);
        lo_r[i] = std::min(lo_r[i], r0 / s), hi_r[i] = std::max(hi_r[i], r1 / s);
      }
    }
    for (std::size_t i = 0; i < sources.size(); ++i) {
      if (hi_c[i] >= lo_c[i]) windows[i] = dem::GridWindow{lo_c[i], lo_r[i], hi_c[i] - lo_c[i] + 1, hi_r[i] - lo_r[i] + 1};
    }
  }
  const TerrainVisibility visibility = terrainVisibility(dem, sources, options, windows);
  cv::parallel_for_(cv::Range(0, bands), [&](const cv::Range& range) {
    for (int band = range.start; band < range.end; ++band) {
      const int r0 = band * kOrthoBlockCells, r1 = std::min(rows, r0 + kOrthoBlockCells);
      for (int r = r0; r < r1; ++r) {
        // The row empty first: no image, no source, no second candidate.
        out.image.row(r).setTo(0);
        out.valid.row(r).setTo(0);
        out.source.row(r).setTo(-1);
        candidates.second.row(r).setTo(-1);
        candidates.best_px.row(r).setTo(cv::Scalar(0, 0));
        candidates.second_px.row(r).setTo(cv::Scalar(0, 0));
      }
      for (int r = r0; r < r1; ++r) {
        for (int c = 0; c < cols; ++c) {
          const BlockSources& block = blocks[static_cast<std::size_t>(band) * per_band + c / kOrthoBlockCells];
          double elev = 0.0;
          if (block.index.empty() || !orthoCellElevation(dem, out, options, r, c, elev)) continue;
          const double north = out.grid.northOfRow(r);
          const double east = out.grid.eastOfCol(c);
          const std::size_t dem_cell = static_cast<std::size_t>(r / s) * dem.cols + static_cast<std::size_t>(c / s);
          const SourceChoice choice =
              chooseSources(Vec3(north, east, -elev), sources, geometry, options, visibility, dem_cell, block);
          if (choice.best < 0) continue;
          const Vec2& bp = choice.best_px;
          out.image.at<uint8_t>(r, c) = static_cast<uint8_t>(
              std::clamp(std::lround(bilinear(sources[choice.best].grey, bp.x(), bp.y())), 1L, 255L));
          out.valid.at<uint8_t>(r, c) = 255;
          out.source.at<int16_t>(r, c) = static_cast<int16_t>(choice.best);
          candidates.best_px.at<cv::Vec2f>(r, c) = cv::Vec2f(static_cast<float>(bp.x()), static_cast<float>(bp.y()));
          if (choice.next >= 0) {
            const Vec2& np = choice.next_px;
            candidates.second.at<int16_t>(r, c) = static_cast<int16_t>(choice.next);
            candidates.second_px.at<cv::Vec2f>(r, c) = cv::Vec2f(static_cast<float>(np.x()), static_cast<float>(np.y()));
          }
        }
      }
    }
  });
}

// Seam cells: the chosen image differs from a 4-neighbour's, and the cell has the neighbour's image as a
// candidate too.
std::vector<cv::Point> seamCells(const cv::Mat& source, const cv::Mat& second) {
  std::vector<cv::Point> seam;
  for (int r = 0; r + 1 < source.rows; ++r) {
    for (int c = 0; c + 1 < source.cols; ++c) {
      const int16_t a = source.at<int16_t>(r, c);
      if (a < 0) continue;
      const int16_t e = source.at<int16_t>(r, c + 1);
      const int16_t so = source.at<int16_t>(r + 1, c);
      if ((e >= 0 && e != a) || (so >= 0 && so != a)) {
        if (second.at<int16_t>(r, c) >= 0) seam.push_back(cv::Point(c, r));
      }
    }
  }
  return seam;
}

// The ground distance of one pixel of `model`'s image at a ground point, from the projection of points
// 1 cm north and east of it. False when a projection fails.
bool groundPixelM(const CameraModel& model, double north, double east, double elevation, double& step_m) {
  Vec2 i0, in, ie;
  if (project(model, Vec3(north, east, -elevation), i0) != Status::kOk ||
      project(model, Vec3(north + 0.01, east, -elevation), in) != Status::kOk ||
      project(model, Vec3(north, east + 0.01, -elevation), ie) != Status::kOk) {
    return false;
  }
  const double px_per_m = std::max((in - i0).norm(), (ie - i0).norm()) / 0.01;
  if (!(px_per_m > 0)) return false;
  step_m = 1.0 / px_per_m;
  return true;
}

// Sources a and b resampled through the DEM into pa and pb: a ground grid of (2 span + 1)^2 samples step_m
// apart centred on (north0, east0). False when a sample has no DEM elevation or falls outside an image.
bool resampleSeamPatches(const DemGrid& dem, const OrthoSource& a, const OrthoSource& b, double north0,
                         double east0, double step_m, int span, cv::Mat& pa, cv::Mat& pb) {
  for (int dy = -span; dy <= span; ++dy) {
    for (int dx = -span; dx <= span; ++dx) {
      const double north = north0 - dy * step_m, east = east0 + dx * step_m;
      double z = 0;
      if (!demElevation(dem, north, east, z)) return false;
      const Vec3 g(north, east, -z);
      Vec2 ia, ib;
      if (project(a.model, g, ia) != Status::kOk || project(b.model, g, ib) != Status::kOk ||
          !inside(a.grey, ia, 0.0) || !inside(b.grey, ib, 0.0)) {
        return false;
      }
      pa.at<uint8_t>(dy + span, dx + span) =
          static_cast<uint8_t>(std::lround(bilinear(a.grey, ia.x(), ia.y())));
      pb.at<uint8_t>(dy + span, dx + span) =
          static_cast<uint8_t>(std::lround(bilinear(b.grey, ib.x(), ib.y())));
    }
  }
  return true;
}

// The length of the best shift of pa against pb (NCC within +-search, parabola refinement), in samples.
// False when the best NCC is below 0.7 or lies on the search edge.
bool patchShift(const cv::Mat& pa, const cv::Mat& pb, int span, int half, int search, double& shift) {
  double best_score = -3;
  int bx = 0, by = 0;
  const int n = 2 * search + 1;
  std::vector<double> score(static_cast<std::size_t>(n * n), -3);
  for (int dy = -search; dy <= search; ++dy) {
    for (int dx = -search; dx <= search; ++dx) {
      const double v = ncc(pa, span + dx, span + dy, pb, span, span, half);
      score[static_cast<std::size_t>((dy + search) * n + dx + search)] = v;
      if (v > best_score) {
        best_score = v;
        bx = dx;
        by = dy;
      }
    }
  }
  if (best_score < 0.7 || std::abs(bx) == search || std::abs(by) == search) return false;
  auto at = [&](int dx, int dy) { return score[static_cast<std::size_t>((dy + search) * n + dx + search)]; };
  const double ox = bx + parabolaOffset(at(bx - 1, by), at(bx, by), at(bx + 1, by));
  const double oy = by + parabolaOffset(at(bx, by - 1), at(bx, by), at(bx, by + 1));
  shift = std::hypot(ox, oy);
  return true;
}

// The seam statistics over an even subsample of the seam cells. The two candidates are compared in ortho
// space: each image resampled through the DEM onto a local ground grid around the seam cell, spaced one
// pixel of the chosen image (so that the comparison keeps the image's resolution however coarse the ortho
// cell); with a right DEM and right models both patches coincide. The best shift of one against the other
// (NCC + parabola) is in pixels of the chosen image.
void checkSeams(const DemGrid& dem, const std::vector<OrthoSource>& sources, const OrthoOptions& options,
                const std::vector<cv::Point>& seam, OrthoResult& out, const SeamCandidates& candidates) {
  const std::size_t stride =
      std::max<std::size_t>(1, seam.size() / static_cast<std::size_t>(std::max(1, options.max_seam_samples)));
  const int half = options.seam_patch_half_px;
  const int search = options.seam_search_px;
  const int span = half + search + 1;
  const int w = 2 * span + 1;
  // The samples (every stride-th seam cell) checked on threads, each into its own slot, then taken in order.
  const std::size_t samples = (seam.size() + stride - 1) / stride;
  std::vector<double> grey_diff(samples), shifts(samples);
  std::vector<uint8_t> shifted(samples, 0);
  cli::parallelFor(samples, 0, [&](std::size_t j) {
    const cv::Point p = seam[j * stride];
    const OrthoSource& a = sources[static_cast<std::size_t>(out.source.at<int16_t>(p))];
    const OrthoSource& b = sources[static_cast<std::size_t>(candidates.second.at<int16_t>(p))];
    const cv::Vec2f qa = candidates.best_px.at<cv::Vec2f>(p);
    const cv::Vec2f qb = candidates.second_px.at<cv::Vec2f>(p);
    grey_diff[j] = bilinear(a.grey, qa[0], qa[1]) - bilinear(b.grey, qb[0], qb[1]);
    const double n0 = out.grid.northOfRow(p.y), e0 = out.grid.eastOfCol(p.x);
    double z0 = 0, step_m = 0;
    if (!demElevation(dem, n0, e0, z0) || !groundPixelM(a.model, n0, e0, z0, step_m)) return;
    cv::Mat pa(w, w, CV_8U), pb(w, w, CV_8U);
    if (!resampleSeamPatches(dem, a, b, n0, e0, step_m, span, pa, pb)) return;
    shifted[j] = patchShift(pa, pb, span, half, search, shifts[j]) ? 1 : 0;
  });
  std::vector<double> geo;  // one sample is one pixel of the chosen image
  for (std::size_t j = 0; j < samples; ++j) {
    if (shifted[j]) geo.push_back(shifts[j]);
  }
  double g2 = 0;
  for (double d : grey_diff) g2 += d * d;
  out.seams.grey_rms = grey_diff.empty() ? 0.0 : std::sqrt(g2 / grey_diff.size());
  out.seams.checked = static_cast<long long>(geo.size());
  if (!geo.empty()) {
    double s2 = 0;
    for (double d : geo) s2 += d * d;
    out.seams.geometric_rms_px = std::sqrt(s2 / geo.size());
    std::sort(geo.begin(), geo.end());
    out.seams.geometric_p95_px = geo[std::min(geo.size() - 1, static_cast<std::size_t>(0.95 * geo.size()))];
    out.seams.geometric_median_px = geo[geo.size() / 2];
  }
}

}  // namespace

bool demElevation(const DemGrid& dem, double north_m, double east_m, double& elevation_m) {
  const double cx = (east_m - dem.east0_m) / dem.cell_m - 0.5;
  const double cy = (dem.north0_m - north_m) / dem.cell_m - 0.5;
  const int x0 = static_cast<int>(std::floor(cx));
  const int y0 = static_cast<int>(std::floor(cy));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= dem.cols || y0 + 1 >= dem.rows) return false;
  const double fx = cx - x0, fy = cy - y0;
  const float v00 = dem.at(x0, y0), v10 = dem.at(x0 + 1, y0), v01 = dem.at(x0, y0 + 1),
              v11 = dem.at(x0 + 1, y0 + 1);
  if (v00 == dem.nodata || v10 == dem.nodata || v01 == dem.nodata || v11 == dem.nodata) return false;
  elevation_m = (1 - fy) * ((1 - fx) * v00 + fx * v10) + fy * ((1 - fx) * v01 + fx * v11);
  return true;
}

OrthoResult makeOrthoimage(const DemGrid& dem, const std::vector<OrthoSource>& sources,
                           const OrthoOptions& options) {
  if (dem.cols <= 0 || dem.rows <= 0 || dem.cell_m <= 0 || options.supersample < 1) {
    throw std::invalid_argument("makeOrthoimage: empty DEM grid or bad supersample");
  }
  if (options.cells != nullptr && options.cells->size() != static_cast<std::size_t>(dem.cols) * dem.rows)
    throw std::invalid_argument("makeOrthoimage: the cell mask is not the DEM's size");
  OrthoResult out;
  const int s = options.supersample;
  out.grid = dem;
  out.grid.values.clear();
  out.grid.cell_m = dem.cell_m / s;
  out.grid.cols = dem.cols * s;
  out.grid.rows = dem.rows * s;
  const int cols = out.grid.cols, rows = out.grid.rows;
  // Allocated here, each row set to its empty value by fillCells on the thread that fills it.
  out.image = cv::Mat(rows, cols, CV_8U);
  out.valid = cv::Mat(rows, cols, CV_8U);
  out.source = cv::Mat(rows, cols, CV_16S);
  SeamCandidates candidates{cv::Mat(rows, cols, CV_16S), cv::Mat(rows, cols, CV_32FC2),
                            cv::Mat(rows, cols, CV_32FC2)};
  fillCells(dem, sources, options, out, candidates);
  out.cells_filled = cv::countNonZero(out.valid);
  const std::vector<cv::Point> seam = seamCells(out.source, candidates.second);
  out.seams.seam_cells = static_cast<long long>(seam.size());
  if (seam.empty() || !options.check_seams) return out;
  checkSeams(dem, sources, options, seam, out, candidates);
  return out;
}

int orthoShift(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask, int tile_px, int search_px,
               double& shift_east_cells, double& shift_south_cells, double* rms_shift_cells) {
  std::vector<double> sx, sy;
  const int half = tile_px / 2;
  const int margin = half + search_px + 2;
  for (int r = margin; r + margin < a.rows; r += tile_px) {
    for (int c = margin; c + margin < a.cols; c += tile_px) {
      // Every pixel of the tile (with its search margin) must be filled in both images.
      const cv::Rect rect(c - half - search_px - 1, r - half - search_px - 1, tile_px + 2 * search_px + 2,
                          tile_px + 2 * search_px + 2);
      if (cv::countNonZero(a(rect)) != rect.area() || cv::countNonZero(b(rect)) != rect.area()) continue;
      if (!mask.empty() && cv::countNonZero(mask(rect)) != rect.area()) continue;
      const int n = 2 * search_px + 1;
      std::vector<double> score(static_cast<std::size_t>(n * n), -3);
      double best = -3;
      int bx = 0, by = 0;
      for (int dy = -search_px; dy <= search_px; ++dy) {
        for (int dx = -search_px; dx <= search_px; ++dx) {
          const double v = ncc(a, c, r, b, c + dx, r + dy, half);
          score[static_cast<std::size_t>((dy + search_px) * n + dx + search_px)] = v;
          if (v > best) {
            best = v;
            bx = dx;
            by = dy;
          }
        }
      }
      if (best < 0.5 || std::abs(bx) == search_px || std::abs(by) == search_px) continue;
      auto at = [&](int dx, int dy) {
        return score[static_cast<std::size_t>((dy + search_px) * n + dx + search_px)];
      };
      sx.push_back(bx + parabolaOffset(at(bx - 1, by), at(bx, by), at(bx + 1, by)));
      sy.push_back(by + parabolaOffset(at(bx, by - 1), at(bx, by), at(bx, by + 1)));
    }
  }
  if (sx.empty()) {
    shift_east_cells = shift_south_cells = 0;
    if (rms_shift_cells) *rms_shift_cells = 0;
    return 0;
  }
  double s2 = 0;
  for (std::size_t i = 0; i < sx.size(); ++i) s2 += sx[i] * sx[i] + sy[i] * sy[i];
  if (rms_shift_cells) *rms_shift_cells = std::sqrt(s2 / sx.size());
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  shift_east_cells = median(sx);
  shift_south_cells = median(sy);
  return static_cast<int>(sx.size());
}

}  // namespace areomap::ortho
