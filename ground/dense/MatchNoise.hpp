// A stereo pair's sub-pixel matching noise (px) from its own data, for the point sigmas and the DEM sigma
// (PairCloud::match_sigma_px), instead of one constant for every camera, scene and exposure.
//
// Estimator: the left-right disagreement of the sub-pixel disparities (DenseResult::lr_diff_px: the left
// image's parabola disparity less the right image's at the matched pixel, from the same aggregated costs)
// over the matches that pass the left-right check. Chosen over the alternatives because it sees every
// cause of matching noise in the pair itself (sensor noise, blur, compression, texture) over the whole
// overlap and costs no second matching pass; the least-squares matching's fit residuals need the optional
// refinement and measure only the grey-level misfit of one window, and the ties' residuals after the
// adjustment are a few hundred points of another matcher, mixed with the cameras' errors. Both directions
// carry noise, so sigma = 1.4826 MAD(diff) / sqrt(2); the MAD (not the sd) because mismatches that pass
// the check by a pixel would dominate a variance.
// What it cannot see: errors both directions share (the parabola's pull towards whole pixels, the
// aggregation's smoothing of relief), which grow with blur; on strongly blurred and noisy images the
// estimate is too small (docs/products.md "Matching noise").
//
// With fewer than kMinMatchNoiseSamples differences the estimate is not trusted and the caller's fallback
// (the navcam-calibrated constant, DenseMatcher.hpp kMatchSigmaPx) is used and named as the source.
#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace areomap::dense {

// The MAD's sigma has a relative standard error of 1.17 / sqrt(n) for n independent Gaussian samples
// (asymptotic efficiency 0.37). Neighbouring matches share evidence (kMatchErrorCorrelationPx = 2 px: one
// independent sample per ~(2 L)^2 = 16 pixels), so n pixels carry ~n / 16 independent samples; 10^4 pixels
// bound the estimate's relative standard error at 1.17 / sqrt(625) < 5 %.
inline constexpr long long kMinMatchNoiseSamples = 10000;

struct MatchNoise {
  double sigma_px = 0.0;     // the pair's matching noise used for its points
  std::string source;        // "left_right" (estimated) or "fallback_constant" (too few samples)
  long long samples = 0;     // left-right differences used
  double lr_sigma_px = 0.0;  // the left-right estimate itself (0 without samples), also when not used
};

// From a DenseResult::lr_diff_px raster (NaN = no sample). `fallback_sigma_px` when fewer than
// kMinMatchNoiseSamples differences are finite.
MatchNoise estimateMatchNoise(const cv::Mat& lr_diff_px, double fallback_sigma_px);

}  // namespace areomap::dense
