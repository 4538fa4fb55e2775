#include "ground/traverse/SiteProducts.hpp"

#include <cmath>
#include <filesystem>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "ground/cli/Cli.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/ImageFile.hpp"

namespace areomap::traverse {

namespace {

std::vector<cv::Mat> makePyramid(const cv::Mat& image8) {
  std::vector<cv::Mat> pyramid(1);
  image8.convertTo(pyramid[0], CV_32F);
  for (int l = 1; l < kPyramidLevels; ++l) {
    if (pyramid.back().cols < 16 || pyramid.back().rows < 16) break;
    cv::Mat down;
    cv::pyrDown(pyramid.back(), down);
    pyramid.push_back(down);
  }
  return pyramid;
}

// Every image of the site's dataset: its pixels `image_of(ref)` (8-bit) with the model
// `model_of(ref, width, height)`.
template <typename ImageOf, typename ModelOf>
SiteProducts loadSite(const std::string& id, const Dataset& ds, const ImageOf& image_of,
                      const ModelOf& model_of) {
  SiteProducts s;
  s.id = id;
  std::vector<const ImageRef*> refs;
  for (std::size_t p = 0; p < ds.pairs.size(); ++p) {
    for (int side = 0; side < 2; ++side) {
      const ImageRef* ref =
          side == 0 ? &ds.pairs[p].left : (ds.pairs[p].right ? &*ds.pairs[p].right : nullptr);
      if (ref == nullptr) continue;
      refs.push_back(ref);
      SiteImage im;
      im.stem = ref->stem;
      im.pair_index = static_cast<int>(p);
      im.right = side == 1;
      s.images.push_back(std::move(im));
    }
  }
  // Each image read and its pyramid made in parallel (the first failure by image order is thrown).
  cli::parallelFor(refs.size(), 0, [&](std::size_t k) {
    SiteImage& im = s.images[k];
    im.pyramid = makePyramid(image_of(*refs[k]));
    im.model = model_of(*refs[k], im.pyramid[0].cols, im.pyramid[0].rows);
  });
  return s;
}

// Every image of the site's dataset folder with the model file `model_path(stem)`.
template <typename ModelPath>
SiteProducts loadSite(const TraverseSite& site, const ModelPath& model_path) {
  return loadSite(
      site.id, readDataset(site.dir), [](const ImageRef& ref) { return io::loadImage8(ref.image_path); },
      [&](const ImageRef& ref, int width, int height) {
        const std::string path = model_path(ref.stem);
        if (!std::filesystem::exists(path))
          throw cli::InputError(path, "model",
                                "no camera model for image " + ref.stem + " of site " + site.id);
        return io::readCameraModelFile(path, width, height);
      });
}

// The DEM sigma when it is on the DEM's grid.
void setSigma(SiteProducts& s, std::optional<DemGrid> sigma) {
  if (sigma && sigma->cols == s.dem.cols && sigma->rows == s.dem.rows) s.dem_sigma = std::move(sigma);
}

// The orthoimage when it is on the DEM's grid.
void setOrtho(SiteProducts& s, std::optional<DemGrid> ortho) {
  if (ortho && ortho->cols == s.dem.cols && ortho->rows == s.dem.rows) s.ortho = std::move(ortho);
}

}  // namespace

int SiteProducts::indexOf(const std::string& stem) const {
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (images[i].stem == stem) return static_cast<int>(i);
  }
  return -1;
}

SiteProducts loadSiteProducts(const TraverseSite& site, const std::string& products_dir) {
  SiteProducts s =
      loadSite(site, [&](const std::string& stem) { return products_dir + "/models/" + stem + ".cahvor"; });
  const std::string dem = products_dir + "/dem.tif";
  if (!std::filesystem::exists(dem))
    throw cli::InputError(dem, "dem.tif", "no DEM among the products of site " + site.id);
  s.dem = readDemGeoTiff(dem);
  const std::string sigma = products_dir + "/dem_sigma.tif";
  if (std::filesystem::exists(sigma)) setSigma(s, readDemGeoTiff(sigma));
  const std::string ortho = products_dir + "/ortho.tif";
  if (std::filesystem::exists(ortho)) setOrtho(s, readDemGeoTiff(ortho));
  return s;
}

SiteProducts siteProducts(const TraverseSite& site, const ground::SitePass& pass) {
  if (!pass.dem)
    throw cli::InputError(pass.out_dir + "/dem.tif", "dem.tif",
                          "no DEM among the products of site " + site.id);
  if (!pass.panorama)
    throw cli::InputError(pass.out_dir, "images", "the pass of site " + site.id + " holds no images");
  SiteProducts s = loadSite(
      site.id, pass.dataset,
      [&](const ImageRef& ref) {
        const io::PanoramaImage* image = pass.panorama->find(ref.stem);
        if (image == nullptr) throw cli::InputError(ref.image_path, "image", "not among the pass's images");
        return image->grey;
      },
      [&](const ImageRef& ref, int, int) {
        const CameraModel* model = pass.adjustedOf(ref.stem);
        if (model == nullptr)
          throw cli::InputError(pass.out_dir + "/models/" + ref.stem + ".cahvor", "model",
                                "no camera model for image " + ref.stem + " of site " + site.id);
        return *model;
      });
  s.dem = *pass.dem;
  setSigma(s, pass.dem_sigma);
  setOrtho(s, pass.ortho);
  return s;
}

SiteProducts loadSiteTruth(const TraverseSite& site, double cell_m) {
  SiteProducts s = loadSite(site, [&](const std::string& stem) {
    return site.dir + "/" + kTruthModelsFolder + "/" + stem + ".cahvor";
  });
  s.dem = readDemGeoTiff(site.dir + "/" + kTruthDemFile);
  if (cell_m > 0.0) {
    const int factor = static_cast<int>(std::lround(cell_m / s.dem.cell_m));
    if (factor > 1) s.dem = coarsenDem(s.dem, factor);
  }
  return s;
}

DemGrid coarsenDem(const DemGrid& dem, int factor) {
  DemGrid out;
  out.east0_m = dem.east0_m;
  out.north0_m = dem.north0_m;
  out.cell_m = dem.cell_m * factor;
  out.cols = dem.cols / factor;
  out.rows = dem.rows / factor;
  out.nodata = dem.nodata;
  out.values.assign(static_cast<std::size_t>(out.cols) * out.rows, dem.nodata);
  for (int r = 0; r < out.rows; ++r) {
    for (int c = 0; c < out.cols; ++c) {
      double sum = 0.0;
      int n = 0;
      for (int i = 0; i < factor; ++i) {
        for (int j = 0; j < factor; ++j) {
          const float v = dem.at(c * factor + j, r * factor + i);
          if (v != dem.nodata && std::isfinite(v)) {
            sum += v;
            ++n;
          }
        }
      }
      if (2 * n >= factor * factor) out.at(c, r) = static_cast<float>(sum / n);
    }
  }
  return out;
}

namespace {

// The last step index from k on (at most `steps`) up to which the ray is above the ceiling of the block
// under step k: every step of that stretch is above the surface or off it, so none is a crossing. k - 1
// when there is none (step k is off the grid or may be at or below the surface).
int lastStepAbove(const DemGrid& dem, const DemCeiling& ceiling, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& direction, double step, int k, int steps) {
  const double t0 = k * step;
  const Eigen::Vector3d p = origin + t0 * direction;
  // The cell coordinates demElevation computes, linear along the ray.
  const double u0 = (p.y() - dem.east0_m) / dem.cell_m - 0.5, v0 = (dem.north0_m - p.x()) / dem.cell_m - 0.5;
  if (!(u0 >= 0.0 && v0 >= 0.0)) return k - 1;
  const int bc = static_cast<int>(u0) / ceiling.block, br = static_cast<int>(v0) / ceiling.block;
  if (bc >= ceiling.cols || br >= ceiling.rows) return k - 1;
  const double top = ceiling.top[static_cast<std::size_t>(br) * ceiling.cols + bc];
  // Where the ray leaves the block widened by half a cell (its ceiling covers a cell more), so that the
  // rounding of the steps' coordinates cannot take one beyond what the ceiling covers.
  auto leave = [&](double w0, double dw, int b) {
    const double lo = b * ceiling.block - 0.5, hi = (b + 1) * ceiling.block + 0.5;
    if (dw > 0.0) return t0 + (hi - w0) / dw;
    if (dw < 0.0) return t0 + (lo - w0) / dw;
    return static_cast<double>(INFINITY);
  };
  const double t1 = std::min(
      {leave(u0, direction.y() / dem.cell_m, bc), leave(v0, -direction.x() / dem.cell_m, br), steps * step});
  // The ray's height is linear in t: its least over [t0, t1] is at an end; a margin far above rounding.
  constexpr double kMargin = 1e-6;
  const double lowest = std::min(-p.z(), -(origin.z() + t1 * direction.z()));
  if (!(lowest > top + kMargin)) return k - 1;
  return std::clamp(static_cast<int>(std::floor(t1 / step)), k - 1, steps);
}

bool castRay(const DemGrid& dem, const DemCeiling* ceiling, const Eigen::Vector3d& origin,
             const Eigen::Vector3d& direction, double max_range_m, double& t_m) {
  const double step = std::max(0.5 * dem.cell_m, 0.01);
  const int steps = static_cast<int>(max_range_m / step);
  auto above = [&](double t, bool& valid) {
    const Eigen::Vector3d p = origin + t * direction;
    const double e = demElevation(dem, p.x(), p.y());
    valid = std::isfinite(e);
    return -p.z() - e;  // height above the surface
  };
  bool prev_valid = false;
  double prev_h = 0.0;
  for (int k = 1; k <= steps; ++k) {
    const int last =
        ceiling != nullptr ? lastStepAbove(dem, *ceiling, origin, direction, step, k, steps) : k - 1;
    if (last >= k) {
      // Steps k..last are no crossing; the next step compares with the last one's height.
      prev_h = above(last * step, prev_valid);
      k = last;
      continue;
    }
    const double t = k * step;
    bool valid = false;
    const double h = above(t, valid);
    if (valid && prev_valid && prev_h > 0.0 && h <= 0.0) {
      double lo = t - step, hi = t;
      for (int it = 0; it < 30; ++it) {
        const double mid = 0.5 * (lo + hi);
        bool v = false;
        const double hm = above(mid, v);
        if (!v) break;
        (hm > 0.0 ? lo : hi) = mid;
      }
      t_m = 0.5 * (lo + hi);
      return true;
    }
    prev_valid = valid;
    prev_h = h;
  }
  return false;
}

}  // namespace

bool castRayOnDem(const DemGrid& dem, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                  double max_range_m, double& t_m) {
  return castRay(dem, nullptr, origin, direction, max_range_m, t_m);
}

bool castRayOnDem(const DemGrid& dem, const DemCeiling& ceiling, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& direction, double max_range_m, double& t_m) {
  return castRay(dem, &ceiling, origin, direction, max_range_m, t_m);
}

DemCeiling demCeiling(const DemGrid& dem, int block) {
  DemCeiling out;
  out.block = block;
  out.cols = (dem.cols + block - 1) / block;
  out.rows = (dem.rows + block - 1) / block;
  out.top.assign(static_cast<std::size_t>(out.cols) * out.rows, -INFINITY);
  for (int br = 0; br < out.rows; ++br) {
    for (int bc = 0; bc < out.cols; ++bc) {
      float top = -INFINITY;
      for (int r = std::max(0, br * block - 1); r <= std::min(dem.rows - 1, (br + 1) * block + 1); ++r) {
        for (int c = std::max(0, bc * block - 1); c <= std::min(dem.cols - 1, (bc + 1) * block + 1); ++c) {
          const float v = dem.at(c, r);
          if (v != dem.nodata && std::isfinite(v)) top = std::max(top, v);
        }
      }
      out.top[static_cast<std::size_t>(br) * out.cols + bc] = top;
    }
  }
  return out;
}

bool demPlane(const DemGrid& dem, const Eigen::Vector3d& point_m, double radius_m, Eigen::Vector3d& normal,
              Eigen::Vector3d& on_plane) {
  // elevation = a + b * (x - x0) + c * (y - y0) over the cells within the radius.
  const int reach = std::max(1, static_cast<int>(std::ceil(radius_m / dem.cell_m)));
  const int c0 = static_cast<int>(std::floor((point_m.y() - dem.east0_m) / dem.cell_m));
  const int r0 = static_cast<int>(std::floor((dem.north0_m - point_m.x()) / dem.cell_m));
  Eigen::Matrix3d n = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  int count = 0;
  for (int r = r0 - reach; r <= r0 + reach; ++r) {
    for (int c = c0 - reach; c <= c0 + reach; ++c) {
      if (r < 0 || c < 0 || r >= dem.rows || c >= dem.cols) continue;
      const float v = dem.at(c, r);
      if (v == dem.nodata || !std::isfinite(v)) continue;
      const double dx = dem.northOfRow(r) - point_m.x(), dy = dem.eastOfCol(c) - point_m.y();
      if (dx * dx + dy * dy > radius_m * radius_m) continue;
      const Eigen::Vector3d row(1.0, dx, dy);
      n.noalias() += row * row.transpose();
      rhs += row * v;
      ++count;
    }
  }
  if (count < 6) return false;
  const Eigen::Vector3d abc = n.ldlt().solve(rhs);
  if (!abc.allFinite()) return false;
  // Up-positive elevation e(x, y); the surface z = -e; normal of z + e(x,y) = 0 is (b, c, 1), pointing down.
  normal = -Eigen::Vector3d(abc[1], abc[2], 1.0).normalized();
  on_plane = Eigen::Vector3d(point_m.x(), point_m.y(), -abc[0]);
  return true;
}

}  // namespace areomap::traverse
