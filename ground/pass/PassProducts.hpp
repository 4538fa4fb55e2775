// The products of a ground pass (ground/products: dense matching, DEM, ortho, previews, report.html) from
// its solved network: the hook that areomap-ground and areomap-traverse set (GroundPassOptions::
// products_hook). The DEM sigma gets the adjusted cameras' error (ground/adjust/FullEoCovariance.hpp,
// CommonVergence.hpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "firmware_core/adjust/Network.hpp"
#include "ground/node/GroundPass.hpp"
#include "ground/products/Products.hpp"

namespace areomap::ground {

// The products' inputs from the pass: the network's images (grey shared with the panorama) with their
// adjusted models, the dataset's pairs and the pass's tie observations; without the EO covariance and the
// truth DEM, which makePassProducts adds. And the options makePassProducts makes the products with.
products::ProductInputs passProductInputs(const ProductContext& c);
products::ProductOptions passProductOptions();

// Makes the products of the pass in c.out_dir and merges their part into c.report.
void makePassProducts(const ProductContext& c);

// The adjusted cameras and their whole EO covariance for the DEM sigma (products::EoUncertainty), for
// product images in the network's image order; absent (with a warning into `warnings`) when the network
// has none.
std::optional<products::EoUncertainty> eoUncertainty(const Network& solved,
                                                     std::vector<std::string>& warnings,
                                                     const std::vector<products::ProductPair>& pairs);

}  // namespace areomap::ground
