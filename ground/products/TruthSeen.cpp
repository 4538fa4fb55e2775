#include "ground/products/TruthSeen.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "firmware_core/adjust/Datum.hpp"
#include "firmware_core/camera/CameraConversion.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/dem/DemSeen.hpp"
#include "ground/dem/Viewshed.hpp"
#include "ground/ortho/ConeBlock.hpp"
#include "ground/ortho/Orthoimage.hpp"

namespace areomap::products {

namespace {

constexpr double kTruthToleranceM = 0.001;  // rounding of the true surface's float elevations
constexpr int kGreyTolerance = 2;            // rounding of two bilinear samples

// The site -> camera rotation of a model (identity if it does not convert).
Mat3 siteToCamera(const CameraModel& m) {
  PhotogrammetricCamera p;
  ConversionResidual residual;
  return cahvorToPhotogrammetric(m, p, residual) == Status::kOk ? p.m : Mat3::Identity();
}

// Where the products' cell centre (north, east) at the true elevation lies in the truth's frame: the
// point p of the products' frame with p = (north, east, -z) and z the true surface at g + R (p - g)
// (a few fixed-point steps: R is within a few mrad of the identity). False where the truth has no value.
bool alignedGround(const TruthFrame& f, const DemGrid& truth, double north, double east, Vec3& in_truth) {
  double z = 0.0;
  if (!ortho::demElevation(truth, north, east, z)) return false;
  for (int it = 0; it < 3; ++it) {
    in_truth = f.toTruth(Vec3(north, east, -z));
    double t = 0.0;
    if (!ortho::demElevation(truth, in_truth.x(), in_truth.y(), t)) return false;
    z += t + in_truth.z();  // the aligned point's height above the true surface, removed
  }
  in_truth = f.toTruth(Vec3(north, east, -z));
  return true;
}

// The true surface in the products' frame at the cell centres of `grid` (nodata where it has no value).
DemGrid truthInProducts(const DemGrid& truth, const DemGrid& grid, const TruthFrame& f) {
  DemGrid s = grid;
  s.nodata = truth.nodata;
  s.values.assign(static_cast<std::size_t>(grid.cols) * grid.rows, s.nodata);
  cli::parallelFor(static_cast<std::size_t>(grid.rows), 0, [&](std::size_t row) {
    const int r = static_cast<int>(row);
    for (int c = 0; c < grid.cols; ++c) {
      Vec3 q;
      if (!alignedGround(f, truth, grid.northOfRow(r), grid.eastOfCol(c), q)) continue;
      s.at(c, r) = static_cast<float>(-f.toProducts(q).z());
    }
  });
  return s;
}

// The truth ortho's samples per DEM cell along each axis: the grey of the true ground over the cell and
// its neighbours, not nine point samples of it (near the rover a cell covers tens of pixels, and a sample
// moved by a fraction of a cell lands on other pixels).
constexpr int kTruthOrthoSamples = 3;

// Whether `value` lies within the values of `truth` (kTruthOrthoSamples per DEM cell) over the DEM cell
// (r, c) and its eight neighbours (filled ones).
bool agrees(const cv::Mat& truth, int r, int c, int value) {
  int lo = 256, hi = -1;
  constexpr int s = kTruthOrthoSamples;
  for (int dr = -s; dr < 2 * s; ++dr) {
    for (int dc = -s; dc < 2 * s; ++dc) {
      const int rr = r * s + dr, cc = c * s + dc;
      if (rr < 0 || cc < 0 || rr >= truth.rows || cc >= truth.cols) continue;
      const int t = truth.at<uint8_t>(rr, cc);
      if (t == 0) continue;
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
  }
  return value >= lo - kGreyTolerance && value <= hi + kGreyTolerance;
}

// The truth nodes (cell centres of `truth`) within the square of side `cell` centred on (north, east):
// [c0, c1] x [r0, r1]; the nearest node when none is (a cell finer than the truth's).
void nodesAround(const DemGrid& truth, double north, double east, double cell, int& c0, int& c1, int& r0, int& r1) {
  const double w = east - 0.5 * cell, n = north + 0.5 * cell;
  c0 = static_cast<int>(std::ceil((w - truth.east0_m) / truth.cell_m - 0.5));
  c1 = static_cast<int>(std::ceil((w + cell - truth.east0_m) / truth.cell_m - 0.5)) - 1;
  r0 = static_cast<int>(std::ceil((truth.north0_m - n) / truth.cell_m - 0.5));
  r1 = static_cast<int>(std::ceil((truth.north0_m - n + cell) / truth.cell_m - 0.5)) - 1;
  if (c1 < c0) c0 = c1 = static_cast<int>(std::floor((east - truth.east0_m) / truth.cell_m));
  if (r1 < r0) r0 = r1 = static_cast<int>(std::floor((truth.north0_m - north) / truth.cell_m));
  c0 = std::max(c0, 0);
  r0 = std::max(r0, 0);
  c1 = std::min(c1, truth.cols - 1);
  r1 = std::min(r1, truth.rows - 1);
}

// The truth's four nodes about (north, east), for a bilinear value there: (bc, br) the first, (fc, fr) the
// point in node units. False when one of them lies beyond the truth.
bool prCentreNodes(const DemGrid& truth, double north, double east, double& fc, double& fr, int& bc,
                   int& br) {
  fc = (east - truth.east0_m) / truth.cell_m - 0.5;
  fr = (truth.north0_m - north) / truth.cell_m - 0.5;
  bc = static_cast<int>(std::floor(fc));
  br = static_cast<int>(std::floor(fr));
  return bc >= 0 && br >= 0 && bc + 1 < truth.cols && br + 1 < truth.rows;
}

// A box of the truth's nodes, grown by blocks of them (empty blocks add nothing).
struct PrNodeBox {
  int lo_c = std::numeric_limits<int>::max(), hi_c = -1, lo_r = std::numeric_limits<int>::max(), hi_r = -1;
  void add(int c0, int c1, int r0, int r1) {
    if (c1 < c0 || r1 < r0) return;
    lo_c = std::min(lo_c, c0);
    hi_c = std::max(hi_c, c1);
    lo_r = std::min(lo_r, r0);
    hi_r = std::max(hi_r, r1);
  }
  dem::GridWindow window() const {
    return hi_c < lo_c ? dem::GridWindow{} : dem::GridWindow{lo_c, lo_r, hi_c - lo_c + 1, hi_r - lo_r + 1};
  }
};

// The box of the truth's nodes that the cells (centres north, east in the truth's frame; NaN: none) read:
// the four about each centre and those within its square. A camera's horizon is needed there only.
dem::GridWindow prNodesRead(const DemGrid& grid, const DemGrid& truth, const std::vector<double>& north,
                            const std::vector<double>& east) {
  std::vector<PrNodeBox> rows(static_cast<std::size_t>(grid.rows));
  cli::parallelFor(rows.size(), 0, [&](std::size_t row) {
    for (int c = 0; c < grid.cols; ++c) {
      const std::size_t i = row * grid.cols + c;
      if (std::isnan(north[i])) continue;
      int c0, c1, r0, r1;
      nodesAround(truth, north[i], east[i], grid.cell_m, c0, c1, r0, r1);
      rows[row].add(c0, c1, r0, r1);
      double fc, fr;
      int bc, br;
      if (prCentreNodes(truth, north[i], east[i], fc, fr, bc, br)) rows[row].add(bc, bc + 1, br, br + 1);
    }
  });
  PrNodeBox all;
  for (const PrNodeBox& b : rows) all.add(b.lo_c, b.hi_c, b.lo_r, b.hi_r);
  return all.window();
}

// A block of points (truth nodes or cell centres) for prCameraNodes: their bounds and the box of nodes
// they add when every one of them lies in a camera's cone. A camera's cone is tested on the block's bounds
// first (ortho::blockAgainstCone): a block wholly outside it adds nothing, one wholly inside it adds `all`,
// and only a block across the cone's edge is tested point by point. The same box as testing every point,
// for a small part of the cost (the cones are narrow against the window).
struct PrBlock {
  int row0 = 0, rows = 0, col0 = 0, cols = 0;  // in the points' own grid
  ortho::PointBounds bounds;
  PrNodeBox all;
};

constexpr int kPrBlockSide = 16;  // points per block side: tens of thousands of blocks over a navcam window

// Blocks of kPrBlockSide^2 over rows x cols points; point(r, c, x, box) gives a point's place (site frame)
// and the nodes it adds (false: none, it is skipped). Blocks without points are left out.
template <typename Point>
std::vector<PrBlock> prBlocks(int rows, int cols, const Point& point) {
  const int block_rows = (rows + kPrBlockSide - 1) / kPrBlockSide, block_cols = (cols + kPrBlockSide - 1) / kPrBlockSide;
  std::vector<PrBlock> blocks(static_cast<std::size_t>(std::max(0, block_rows)) * std::max(0, block_cols));
  cli::parallelFor(blocks.size(), 0, [&](std::size_t k) {
    PrBlock& b = blocks[k];
    b.row0 = static_cast<int>(k / block_cols) * kPrBlockSide;
    b.col0 = static_cast<int>(k % block_cols) * kPrBlockSide;
    b.rows = std::min(kPrBlockSide, rows - b.row0);
    b.cols = std::min(kPrBlockSide, cols - b.col0);
    for (int r = b.row0; r < b.row0 + b.rows; ++r) {
      for (int c = b.col0; c < b.col0 + b.cols; ++c) {
        Vec3 x;
        PrNodeBox adds;
        if (!point(r, c, x, adds)) continue;
        b.bounds.add(x);
        b.all.add(adds.lo_c, adds.hi_c, adds.lo_r, adds.hi_r);
      }
    }
  });
  blocks.erase(std::remove_if(blocks.begin(), blocks.end(), [](const PrBlock& b) { return b.bounds.empty(); }),
               blocks.end());
  return blocks;
}

// The camera-independent part of prCameraNodes: the window's nodes and the cells' centres, each point's
// place (site frame) and the nodes it adds (false: none), and both sets of points in blocks.
struct PrPoints {
  const DemGrid& grid;
  const DemGrid& truth;
  const std::vector<double>& north;
  const std::vector<double>& east;
  const std::vector<double>& centre_up;
  dem::GridWindow within;
  std::vector<PrBlock> nodes, centres;

  // Node (r, c) of `within`.
  bool node(int r, int c, Vec3& x, PrNodeBox& adds) const {
    const int tr = within.row0 + r, tc = within.col0 + c;
    const float z = truth.values[static_cast<std::size_t>(tr) * truth.cols + tc];
    if (z == truth.nodata) return false;
    x = Vec3(truth.northOfRow(tr), truth.eastOfCol(tc), -z);
    adds.add(tc, tc, tr, tr);
    return true;
  }
  // The centre of the grid's cell (r, c): the four nodes about it.
  bool centre(int r, int c, Vec3& x, PrNodeBox& adds) const {
    const std::size_t i = static_cast<std::size_t>(r) * grid.cols + c;
    double fc, fr;
    int bc, br;
    if (std::isnan(north[i]) || !prCentreNodes(truth, north[i], east[i], fc, fr, bc, br)) return false;
    x = Vec3(north[i], east[i], -centre_up[i]);
    adds.add(bc, bc + 1, br, br + 1);
    return true;
  }
};

PrPoints prPoints(const DemGrid& grid, const DemGrid& truth, const std::vector<double>& north,
                  const std::vector<double>& east, const std::vector<double>& centre_up,
                  const dem::GridWindow& within) {
  PrPoints p{grid, truth, north, east, centre_up, within, {}, {}};
  p.nodes = prBlocks(within.rows, within.cols,
                     [&p](int r, int c, Vec3& x, PrNodeBox& adds) { return p.node(r, c, x, adds); });
  p.centres = prBlocks(grid.rows, grid.cols,
                       [&p](int r, int c, Vec3& x, PrNodeBox& adds) { return p.centre(r, c, x, adds); });
  return p;
}

// The box of the nodes of `within` that camera `m` may see (dem::imageSees: inside its cone) and of the
// four nodes about each cell centre it may see: no cell's verdict from `m` reads the horizon beyond it.
// A looser cone than imageSees's (squares, a relative margin far above their rounding), so that no point
// it accepts is left out; the whole of `within` when the cone is a half-space or wider. The points are
// taken a block at a time (PrBlock).
dem::GridWindow prCameraNodes(const CameraModel& m, const dem::ImageCone& cone, const PrPoints& points) {
  if (!(cone.min_cos > 0.0)) return points.within;
  const double cos2 = cone.min_cos * cone.min_cos * (1.0 - 1e-9);
  const auto inCone = [&](const Vec3& x) {
    const Vec3 d = x - m.c;
    const double along = d.dot(cone.axis);
    return along > 0.0 && along * along >= cos2 * d.squaredNorm();
  };
  // Items: the node blocks, then the centre blocks.
  const std::size_t node_blocks = points.nodes.size();
  std::vector<PrNodeBox> boxes(node_blocks + points.centres.size());
  cli::parallelFor(boxes.size(), 0, [&](std::size_t j) {
    const bool node = j < node_blocks;
    const PrBlock& b = node ? points.nodes[j] : points.centres[j - node_blocks];
    const int where = ortho::blockAgainstCone(b.bounds, m.c, cone.axis, cos2);
    if (where == ortho::kConeOutside) return;
    if (where == ortho::kConeInside) {
      boxes[j] = b.all;
      return;
    }
    for (int r = b.row0; r < b.row0 + b.rows; ++r) {
      for (int c = b.col0; c < b.col0 + b.cols; ++c) {
        Vec3 x;
        PrNodeBox adds;
        if ((node ? points.node(r, c, x, adds) : points.centre(r, c, x, adds)) && inCone(x))
          boxes[j].add(adds.lo_c, adds.hi_c, adds.lo_r, adds.hi_r);
      }
    }
  });
  PrNodeBox all;
  for (const PrNodeBox& b : boxes) all.add(b.lo_c, b.hi_c, b.lo_r, b.hi_r);
  return all.window();
}

}  // namespace

TruthFrame truthFrame(const std::vector<CameraModel>& products_models, const std::vector<CameraModel>& truth_models,
                      const Vec3& gimbal_site_m) {
  TruthFrame f;
  f.gimbal = gimbal_site_m;
  std::vector<Mat3> est, tru;
  for (std::size_t k = 0; k < products_models.size() && k < truth_models.size(); ++k) {
    est.push_back(siteToCamera(products_models[k]));
    tru.push_back(siteToCamera(truth_models[k]));
  }
  if (!est.empty()) f.r = commonRotation(est.data(), tru.data(), static_cast<int32_t>(est.size()));
  return f;
}

std::vector<uint8_t> truthCellsSeen(const DemGrid& grid, const DemGrid& truth, const std::vector<cv::Mat>& images,
                                    const std::vector<CameraModel>& models, const TruthFrame& frame) {
  const std::size_t n = static_cast<std::size_t>(grid.cols) * grid.rows;
  std::vector<uint8_t> seen(n, 0);
  // Each cell's centre in the truth's frame (the square about it, of the cell's side, is the cell there).
  std::vector<double> north(n, std::numeric_limits<double>::quiet_NaN()), east(n, north[0]), centre_up(n, 0.0);
  cli::parallelFor(static_cast<std::size_t>(grid.rows), 0, [&](std::size_t row) {
    for (int c = 0; c < grid.cols; ++c) {
      Vec3 q;
      if (!alignedGround(frame, truth, grid.northOfRow(static_cast<int>(row)), grid.eastOfCol(c), q)) continue;
      north[row * grid.cols + c] = q.x();
      east[row * grid.cols + c] = q.y();
      centre_up[row * grid.cols + c] = -q.z();
    }
  });
  const dem::GridWindow window = prNodesRead(grid, truth, north, east);
  if (window.cols <= 0 || window.rows <= 0) return seen;
  std::vector<std::size_t> cameras;
  std::vector<Vec3> eyes;
  std::vector<dem::ImageCone> cones;
  std::vector<dem::GridWindow> windows;
  const PrPoints points = prPoints(grid, truth, north, east, centre_up, window);
  for (std::size_t k = 0; k < models.size() && k < images.size(); ++k) {
    if (images[k].empty()) continue;
    cameras.push_back(k);
    eyes.push_back(models[k].c);
    cones.push_back(dem::imageCone(models[k]));
    windows.push_back(prCameraNodes(models[k], cones.back(), points));
  }
  // The truth's nodes each cell reads, the same from every camera: those within its square
  // (nodesAround) and the four about its centre (bc, br the first; bc = -1: none, prCentreNodes).
  struct CellNodes {
    int32_t c0 = 0, c1 = -1, r0 = 0, r1 = -1, bc = -1, br = -1;
  };
  std::vector<CellNodes> cell_nodes(n);
  // And per run of kPrBlockSide cells of a row, the box of every node its cells read: a camera whose
  // window misses it has no verdict on them.
  const std::size_t runs = static_cast<std::size_t>((grid.cols + kPrBlockSide - 1) / kPrBlockSide);
  std::vector<PrNodeBox> run_nodes(static_cast<std::size_t>(grid.rows) * runs);
  cli::parallelFor(static_cast<std::size_t>(grid.rows), 0, [&](std::size_t row) {
    for (int c = 0; c < grid.cols; ++c) {
      const std::size_t i = row * grid.cols + c;
      if (std::isnan(north[i])) continue;
      CellNodes& k = cell_nodes[i];
      int c0, c1, r0, r1;
      nodesAround(truth, north[i], east[i], grid.cell_m, c0, c1, r0, r1);
      k = CellNodes{c0, c1, r0, r1, -1, -1};
      PrNodeBox& run = run_nodes[row * runs + c / kPrBlockSide];
      run.add(c0, c1, r0, r1);
      double fc, fr;
      int bc, br;
      if (prCentreNodes(truth, north[i], east[i], fc, fr, bc, br)) k.bc = bc, k.br = br, run.add(bc, bc + 1, br, br + 1);
    }
  });
  // A cell's verdict is the best of the cameras' (seen, marginal, unseen), so the cameras' horizons are
  // made on threads and the cells checked against them in the cameras' order.
  const auto check = [&](std::size_t e, const std::vector<float>& horizon) {
    const CameraModel& m = models[cameras[e]];
    const dem::ImageCone& cone = cones[e];
    const dem::GridWindow& seen_by = windows[e];
    const double rad_per_px = 1.0 / cone.px_per_rad;
    cli::parallelFor(static_cast<std::size_t>(grid.rows), 0, [&](std::size_t row) {
      for (int c = 0; c < grid.cols; ++c) {
        const PrNodeBox& run = run_nodes[row * runs + c / kPrBlockSide];
        if (c % kPrBlockSide == 0 && !seen_by.meets(run.lo_c, run.hi_c, run.lo_r, run.hi_r)) {
          c += kPrBlockSide - 1;
          continue;
        }
        const std::size_t i = row * grid.cols + c;
        if (seen[i] == kTruthSeen || std::isnan(north[i])) continue;
        const CellNodes& k = cell_nodes[i];
        // Nodes beyond the camera's window belong to points it cannot see: skipped, as imageSees would
        // reject them, and so is a cell with none inside it.
        const bool centre = k.bc >= 0 && seen_by.holds(k.bc, k.br) && seen_by.holds(k.bc + 1, k.br + 1);
        if (!centre && (seen[i] == kTruthMarginal || !seen_by.meets(k.c0, k.c1, k.r0, k.r1))) continue;
        // The centre: the true surface there against the horizon between its four nodes (bilinear).
        if (centre) {
          double fc, fr;
          int bc, br;
          prCentreNodes(truth, north[i], east[i], fc, fr, bc, br);
          double h = 0.0, wsum = 0.0;
          for (int q = 0; q < 4; ++q) {
            const float hq = horizon[seen_by.at(bc + q % 2, br + q / 2)];
            const double w = (q % 2 ? fc - bc : 1.0 - (fc - bc)) * (q / 2 ? fr - br : 1.0 - (fr - br));
            if (hq == -std::numeric_limits<float>::infinity()) continue;
            h += w * hq;
            wsum += w;
          }
          const Vec3 x(north[i], east[i], -centre_up[i]);
          if ((wsum < 1e-9 || centre_up[i] + kTruthToleranceM >= h / wsum) && dem::imageSees(m, cone, x)) {
            seen[i] = kTruthSeen;
            continue;
          }
        }
        if (seen[i] == kTruthMarginal) continue;
        double tolerance = -1.0;  // made for the first node that needs it
        for (int tr = k.r0; tr <= k.r1 && seen[i] == kTruthUnseen; ++tr) {
          for (int tc = k.c0; tc <= k.c1 && seen[i] == kTruthUnseen; ++tc) {
            const float z = truth.values[static_cast<std::size_t>(tr) * truth.cols + tc];
            if (z == truth.nodata || !seen_by.holds(tc, tr)) continue;
            if (tolerance < 0.0)
              tolerance = kTruthToleranceM + rad_per_px * std::hypot(north[i] - m.c.x(), east[i] - m.c.y());
            if (z + tolerance < horizon[seen_by.at(tc, tr)]) continue;
            if (dem::imageSees(m, cone, Vec3(truth.northOfRow(tr), truth.eastOfCol(tc), -z))) seen[i] = kTruthMarginal;
          }
        }
      }
    });
  };
  dem::forEachHorizon(truth, eyes, windows, false, check);
  return seen;
}

SeenTruth seenAgainstTruth(const DemGrid& dem, const cv::Mat* ortho_image, const DemGrid& truth_dem,
                           const std::vector<cv::Mat>& images, const std::vector<CameraModel>& truth_models,
                           const TruthFrame& frame, double max_range_m, const std::vector<uint8_t>* classes) {
  SeenTruth out;
  const Vec3& g = frame.gimbal;
  const DemGrid truth = truthInProducts(truth_dem, dem, frame);
  out.seen = truthCellsSeen(dem, truth_dem, images, truth_models, frame);
  const std::vector<uint8_t>& seen = out.seen;
  // A cell the true cameras see, with a true elevation, within max_range_m.
  const auto comparable = [&](int r, int c) {
    const std::size_t i = static_cast<std::size_t>(r) * dem.cols + c;
    return truth.values[i] != truth.nodata && seen[i] != kTruthMarginal && seen[i] != kTruthUnseen &&
           std::hypot(dem.northOfRow(r) - g.x(), dem.eastOfCol(c) - g.y()) <= max_range_m;
  };
  cv::Mat truth_ortho;
  if (ortho_image != nullptr && ortho_image->rows == dem.rows && ortho_image->cols == dem.cols) {
    std::vector<ortho::OrthoSource> sources;
    const Mat3 back = frame.r.transpose();
    for (std::size_t k = 0; k < truth_models.size() && k < images.size(); ++k)
      sources.push_back(ortho::OrthoSource{images[k], movedModel(truth_models[k], back, frame.toProducts(truth_models[k].c))});
    // Only the cells the agreement below reads (a compared cell and its eight neighbours) are painted,
    // and the truth ortho's seams are not checked: the same values where they are read.
    std::vector<uint8_t> read(seen.size(), 0);
    for (int r = 0; r < dem.rows; ++r) {
      for (int c = 0; c < dem.cols; ++c) {
        if (!comparable(r, c) || ortho_image->at<uint8_t>(r, c) == 0) continue;
        for (int rr = std::max(0, r - 1); rr <= std::min(dem.rows - 1, r + 1); ++rr) {
          for (int cc = std::max(0, c - 1); cc <= std::min(dem.cols - 1, c + 1); ++cc)
            read[static_cast<std::size_t>(rr) * dem.cols + cc] = 1;
        }
      }
    }
    ortho::OrthoOptions options;
    options.supersample = kTruthOrthoSamples;
    options.cells = &read;
    options.check_seams = false;
    truth_ortho = ortho::makeOrthoimage(truth, sources, options).image;
  }
  long long empty = 0, filled = 0, agree = 0;
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const std::size_t i = static_cast<std::size_t>(r) * dem.cols + c;
      if (truth.values[i] == truth.nodata) continue;
      if (std::hypot(dem.northOfRow(r) - g.x(), dem.eastOfCol(c) - g.y()) > max_range_m) continue;
      const bool has = dem.values[i] != dem.nodata && std::isfinite(dem.values[i]);
      if (seen[i] == kTruthMarginal) {
        ++out.cells_marginal;
        continue;
      }
      if (seen[i] == kTruthUnseen) {
        ++out.cells_unseen;
        empty += !has;
        out.unseen_measured += classes != nullptr && i < classes->size() && (*classes)[i] == dem::kCellMeasured;
        continue;
      }
      ++out.cells_seen;
      filled += has;
      if (truth_ortho.empty()) continue;
      const int v = ortho_image->at<uint8_t>(r, c);
      const int t = truth_ortho.at<uint8_t>(r * kTruthOrthoSamples + kTruthOrthoSamples / 2,
                                            c * kTruthOrthoSamples + kTruthOrthoSamples / 2);
      if (v == 0 || t == 0) continue;
      ++out.cells_compared;
      agree += agrees(truth_ortho, r, c, v);
    }
  }
  const auto fraction = [](long long part, long long whole) {
    return whole > 0 ? std::optional<double>(static_cast<double>(part) / static_cast<double>(whole)) : std::nullopt;
  };
  out.unseen_empty = fraction(empty, out.cells_unseen);
  out.seen_filled = fraction(filled, out.cells_seen);
  out.ortho_agreement = fraction(agree, out.cells_compared);
  return out;
}

}  // namespace areomap::products
