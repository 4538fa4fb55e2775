// The products of a ground pass (ground/products: dense matching, DEM, ortho, previews, report.html) from
// its solved network: the pass's last stage when GroundPassOptions::products is set. The DEM sigma gets the
// adjusted cameras' error (ground/adjust/FullEoCovariance.hpp, CommonVergence.hpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "firmware_core/adjust/Network.hpp"
#include "ground/pass/GroundPass.hpp"
#include "ground/products/Products.hpp"

namespace areomap::ground {

// What the products are made from: the pass's solution and data (pointers into its SitePass).
struct ProductContext {
  const io::Panorama* panorama = nullptr;  // the dataset with its images and a-priori models, loaded once
  std::string out_dir;
  const Network* net = nullptr;                         // the integrated solution
  const std::vector<std::string>* stems = nullptr;      // per network image
  const std::vector<CameraModel>* apriori = nullptr;    // per network image
  const std::vector<ImageObservation>* ties = nullptr;  // tie observations (image = stem)
  AdjustReport* report = nullptr;  // add stage timings, warnings, truth.dem_rmse_m (written after the products)
  std::string truth_root;          // the folder holding truth/ ("" when none)
  // One message per product that could not be written (naming the file; ProductsResult::write_errors).
  std::vector<std::string>* write_errors = nullptr;
};

// The products' inputs from the pass: the network's images (grey shared with the panorama) with their
// adjusted models, the dataset's pairs and the pass's tie observations; without the EO covariance and the
// truth DEM, which makePassProducts adds. And the options makePassProducts makes the products with.
products::ProductInputs passProductInputs(const ProductContext& c);
// The same from a pass that ran (its network; its images when it loaded them).
products::ProductInputs passProductInputs(const SitePass& pass);
products::ProductOptions passProductOptions();

// Makes the products of the pass in c.out_dir, merges their part into c.report and returns them.
products::ProductsResult makePassProducts(const ProductContext& c);

// The adjusted cameras and their whole EO covariance for the DEM sigma (products::EoUncertainty), for
// product images in the network's image order; absent (with a warning into `warnings`) when the network
// has none.
std::optional<products::EoUncertainty> eoUncertainty(const Network& solved,
                                                     std::vector<std::string>& warnings,
                                                     const std::vector<products::ProductPair>& pairs);

}  // namespace areomap::ground
