// The stages of makeProducts (Products.hpp), shared by its files: the run's context, the checks of an
// image and the dense cloud. Internal to ground/products.
#pragma once

#include <optional>
#include <set>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "ground/dem/DemProducts.hpp"
#include "ground/dem/PackedCloud.hpp"
#include "ground/dense/PairCloud.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/Products.hpp"

namespace areomap::products {

struct Context {
  const ProductInputs& in;
  const ProductOptions& options;
  std::string out_dir;
  ProductsResult result;
  std::set<std::string> warned;           // images already warned about (once each)
  dem::DemMetadata meta;                  // site and sols of the rasters
  std::optional<DemGrid> truth_dem_read;  // in.truth_dem_path's, once read (truthDem)
  void warn(const std::string& text);
  // The true DEM: in.truth_dem, else in.truth_dem_path read on the first call; nullptr when there is none.
  const DemGrid* truthDem();
  // A product that could not be written (full disk, folder not writable): the message names it.
  void writeFailed(const std::exception& e);
};

// Writes a PNG atomically; a failure is a write error of the run.
void writePng(Context& ctx, const std::string& path, const cv::Mat& image);
// An image is usable when it is present and its model describes an image of its size (warned once).
bool usable(Context& ctx, const ProductImage& im);
// Why an image is not usable ("" when it is), without warning: for work done off the run's thread.
std::string unusableReason(const ProductImage& im);
// The image's model with the image's size.
CameraModel sized(const ProductImage& im);

// The dense cloud as the products keep it (a navcam panorama has ~1.7e7 points): the DEM points packed
// (dem::PackedCloud, 18 B each: float offsets from the gimbal centre) in a cloud of their own, so that the
// DEM step takes them over by a move, and beside them what points.ply needs besides (9 B, packed), freed
// before the DEM is made: the sigmas north and east and the grey value; the sigma down is the DEM point's
// sigma_m, a float (both are sqrt of the same variance). points.ply's positions are the packed ones.
#pragma pack(push, 1)
struct PlyExtra {
  float sigma_north_m = 0.f;
  float sigma_east_m = 0.f;
  uint8_t grey = 0;
};
#pragma pack(pop)
static_assert(sizeof(PlyExtra) == 9, "PlyExtra is packed");

struct Cloud {
  Cloud() = default;
  explicit Cloud(const Vec3& origin_site_m) : dem(origin_site_m) {}
  dem::PackedCloud dem;
  std::vector<PlyExtra> extra;  // extra[i] belongs to dem point i
  std::size_t size() const { return dem.size(); }
  bool empty() const { return dem.empty(); }
  void reserve(std::size_t n) {
    dem.reserve(n);
    extra.reserve(n);
  }
  void append(const Cloud& other) {
    dem.append(other.dem);
    extra.insert(extra.end(), other.extra.begin(), other.extra.end());
  }
  void release() {
    dem.release();
    std::vector<PlyExtra>().swap(extra);
  }
  void push(const dense::CloudPoint& c) {
    dem::DemPoint p;
    p.north_m = c.site_m.x();
    p.east_m = c.site_m.y();
    p.elevation_m = -c.site_m.z();
    p.sigma_m = c.sigmaHeight_m();
    p.line = c.line;
    dem.push(p);
    PlyExtra e;
    e.sigma_north_m = static_cast<float>(std::sqrt(std::max(0.0, c.covariance_m2(0, 0))));
    e.sigma_east_m = static_cast<float>(std::sqrt(std::max(0.0, c.covariance_m2(1, 1))));
    e.grey = c.grey;
    extra.push_back(e);
  }
  dense::CloudPoint cloudPoint(std::size_t i) const {
    const dem::DemPoint p = dem.at(i);
    dense::CloudPoint c;
    c.site_m = Vec3(p.north_m, p.east_m, -p.elevation_m);
    const PlyExtra e = extra[i];
    const float sigma[3] = {e.sigma_north_m, e.sigma_east_m, static_cast<float>(p.sigma_m)};
    for (int k = 0; k < 3; ++k) c.covariance_m2(k, k) = static_cast<double>(sigma[k]) * sigma[k];
    c.grey = e.grey;
    c.line = p.line;
    return c;
  }
};

// Step 1: rectify, match and triangulate every pair; outliers dropped; points.ply written. Its stage
// timings ("rectify", "dense", "triangulate") and the run's sols (ctx.meta) are set.
Cloud denseCloud(Context& ctx);

// Step 4: dem.png, ortho.png (ortho: the orthoimage, when made), overlays, the tie residuals and
// report.html with `adjustment` (optional) and the products' part merged in.
void previewsAndReport(Context& ctx, const ortho::OrthoResult* ortho, const ground::AdjustReport* adjustment);

}  // namespace areomap::products
