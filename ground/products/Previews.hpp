// The PNG previews of the products (DESIGN.md "Products"): the DEM as colour relief with hillshade, a
// colour key and a scale bar; the orthoimage with a scale bar; tie points drawn on an image. Images are
// returned as 8-bit BGR cv::Mat (written by the caller, also embedded in report.html).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/base/EigenTypes.hpp"
#include "ground/dataset/DemRaster.hpp"

namespace areomap::products {

// Colour relief (elevation min..max over a perceptual colour map) times a hillshade (sun from the
// north-west, 45 degrees), nodata white; a scale bar and the elevation range in the lower margin.
cv::Mat demPreview(const DemGrid& dem);
// The orthoimage (CV_8U, 0 = no data shown white) with a scale bar; `cell_m` its cell size.
cv::Mat orthoPreview(const cv::Mat& ortho, const cv::Mat& valid, double cell_m);
// The image with crosses: blue for intra-stereo, red for inter-stereo observations.
cv::Mat tieOverlay(const cv::Mat& grey, const std::vector<Vec2>& pixels, const std::vector<bool>& inter);
// Draws a scale bar (a round length near a fifth of the width) at the bottom left of `image`.
void drawScaleBar(cv::Mat& image, double metres_per_px);

}  // namespace areomap::products
