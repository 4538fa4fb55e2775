#include "ground/pass/PassProducts.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>

#include "ground/adjust/CommonVergence.hpp"
#include "ground/adjust/FullEoCovariance.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/io/CameraFile.hpp"

namespace areomap::ground {

// The adjusted cameras and their whole EO covariance for the DEM sigma (products::EoUncertainty); the
// product images are the network's images in its order. Absent (with a warning) when the network has none.
std::optional<products::EoUncertainty> eoUncertainty(const Network& solved,
                                                     std::vector<std::string>& warnings,
                                                     const std::vector<products::ProductPair>& pairs) {
  const auto net = std::make_unique<Network>(solved);  // fullEoCovariance writes its per-pair blocks
  FullEoCovariance full = fullEoCovariance(*net);
  if (!ok(full.status)) {
    warnings.push_back(std::string("dem_sigma.tif leaves the cameras' error out: no EO covariance (") +
                       statusName(full.status) + ").");
    cli::warn(warnings.back());
    return std::nullopt;
  }
  const CommonVergenceCheck check = addCommonVergenceSystematic(*net, full);
  if (check.done) {
    char b[320];
    std::snprintf(
        b, sizeof b,
        "common vergence of the pairs: sigma %.1f urad; near half of the points (to %.2f m) differs by "
        "%+.1f urad, noise explains %.1f: systematic part %.1f urad (in the DEM sigma)",
        check.sigma_rad * 1e6, check.split_range_m, check.difference_rad * 1e6, check.expected_sd_rad * 1e6,
        check.systematic_rad * 1e6);
    cli::info(b);
    // Said when it is significant (|t| beyond twice its noise: p < 5 %); the sigma takes any excess.
    if (std::fabs(check.difference_rad) > 2.0 * check.expected_sd_rad) {
      std::snprintf(
          b, sizeof b,
          "The tie points beyond %.2f m move the pairs' common vergence by %.1f urad more than their "
          "noise explains (a systematic parallax error of far matches); dem_sigma.tif includes it.",
          check.split_range_m, check.systematic_rad * 1e6);
      warnings.push_back(b);
    }
  }
  products::EoUncertainty eo;
  for (int32_t i = 0; i < net->imageCount(); ++i) eo.cameras.push_back(net->image(i));
  for (const products::ProductPair& pp : pairs) {
    int block = -1;
    for (int32_t q = 0; q < net->pairCount() && block < 0; ++q) {
      if (net->pair(q).left == pp.left && net->pair(q).right == pp.right && pp.right >= 0) block = q;
    }
    eo.block_of_pair.push_back(block);
  }
  eo.covariance = full.covariance;
  return eo;
}

products::ProductInputs passProductInputs(const ProductContext& c) {
  products::ProductInputs in;
  const Dataset& dataset = c.panorama->dataset;
  in.site = dataset.name;
  std::map<std::string, int> index_of_stem;
  for (std::size_t i = 0; i < c.stems->size(); ++i) {
    const std::string& stem = (*c.stems)[i];
    products::ProductImage image;
    image.stem = stem;
    if (const io::PanoramaImage* loaded = c.panorama->find(stem))
      image.grey = loaded->grey;  // shared, not copied
    image.model = adjustedModelOf(*c.net, static_cast<int>(i), (*c.apriori)[i]);
    index_of_stem[stem] = static_cast<int>(in.images.size());
    in.images.push_back(image);
  }
  for (const Pair& pair : dataset.pairs) {
    products::ProductPair p;
    p.id = pair.id;
    p.sol = pair.sol;
    const auto left = index_of_stem.find(pair.left.stem);
    if (left == index_of_stem.end()) continue;
    p.left = left->second;
    if (pair.right) {
      const auto right = index_of_stem.find(pair.right->stem);
      p.right = right == index_of_stem.end() ? -1 : right->second;
    }
    in.pairs.push_back(p);
  }
  for (const ImageObservation& o : *c.ties) {
    const auto it = index_of_stem.find(o.image);
    if (it == index_of_stem.end()) continue;
    products::ProductTie t;
    t.point = static_cast<int>(o.point);
    t.image = it->second;
    t.pixel_px = Vec2(o.sample_px, o.line_px);
    t.inter = o.kind == "inter";
    in.ties.push_back(t);
  }
  in.gimbal_site_m = c.net->rig.gimbal_m[0];
  return in;
}

products::ProductInputs passProductInputs(const SitePass& pass) {
  if (!pass.network) throw std::logic_error("passProductInputs: a pass rebuilt from files has no network");
  const io::Panorama empty{pass.dataset, {}, {}};
  AdjustReport report = pass.report;
  const ProductContext c{pass.panorama ? pass.panorama.get() : &empty, pass.out_dir, pass.network.get(),
                         &pass.stems, &pass.apriori, &pass.ties, &report, "", nullptr};
  return passProductInputs(c);
}

products::ProductOptions passProductOptions() {
  return products::ProductOptions{};
}

// The true models of `images` from truth_root/truth/models/<stem>.cahvor; none unless every one is there.
namespace {

std::vector<CameraModel> passTrueModels(const std::string& truth_root,
                                        const std::vector<products::ProductImage>& images) {
  std::vector<CameraModel> models;
  for (const products::ProductImage& im : images) {
    const std::string path = truth_root + "/truth/models/" + im.stem + ".cahvor";
    if (!std::filesystem::exists(path)) return {};
    models.push_back(io::readCameraModelFile(path, im.grey.cols, im.grey.rows));
  }
  return models;
}

}  // namespace

// The products of ground/products (dense matching, DEM, ortho, previews, report.html) from the pass.
products::ProductsResult makePassProducts(const ProductContext& c) {
  products::ProductInputs in = passProductInputs(c);
  in.eo_uncertainty = eoUncertainty(*c.net, c.report->warnings, in.pairs);
  if (!c.truth_root.empty() && std::filesystem::exists(c.truth_root + "/truth/dem.tif")) {
    in.truth_dem_path = c.truth_root + "/truth/dem.tif";
    in.truth_models = passTrueModels(c.truth_root, in.images);
  }
  products::ProductsResult made = products::makeProducts(in, passProductOptions(), c.out_dir, c.report);
  products::mergeIntoReport(made, *c.report);
  if (c.write_errors != nullptr)
    c.write_errors->insert(c.write_errors->end(), made.write_errors.begin(), made.write_errors.end());
  return made;
}

}  // namespace areomap::ground
