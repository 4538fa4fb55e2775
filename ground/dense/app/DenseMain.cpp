// areomap-dense LEFT RIGHT --max-disp N --out DISP.tif: dense coarse-to-fine matching of a rectified pair.
// Writes the left image's disparity (positive: left x matches right x - d) as a float32 TIFF, NaN = no match.
#include <cmath>
#include <cstdio>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "ground/cli/Cli.hpp"
#include "ground/dense/DenseMatcher.hpp"

namespace {

const char* const kUsage =
    "usage: areomap-dense LEFT RIGHT --max-disp N --out DISP.tif [options]\n"
    "\n"
    "Dense coarse-to-fine matching of a rectified (epipolar) stereo pair, paper section 4.1: a coarse pass\n"
    "on a 5-px grid over the whole range, then a 1-px pass in a small range around the coarse result\n"
    "(census cost, semi-global aggregation), sub-pixel refinement, uniqueness and left-right checks.\n"
    "\n"
    "  LEFT, RIGHT        8-bit images (PNG, TIFF, JPEG, PGM; colour is converted to grey), same size\n"
    "  --max-disp N       largest disparity searched, pixels (required)\n"
    "  --min-disp N       smallest disparity searched, pixels (default 0)\n"
    "  --out DISP.tif     output: float32 TIFF, disparity of the left image, NaN = no match\n"
    "  --fill             fill left-right failures from their neighbours (occlusions from the background)\n"
    "  --mask MASK.png    also write the validity mask (255 = matched, 128 = filled, 0 = none)\n"
    "  --coarse-step N    coarse grid step, pixels (default 5)\n"
    "  --subpixel M       parabola (default: through the aggregated costs of the winner and its two\n"
    "                     neighbours) or lsm (least-squares matching of a 9x7 window with disparity,\n"
    "                     its gradient, gain and offset: no preference for whole pixels; ~5x the time)\n"
    "\n"
    "Exit codes: 0 ok, 2 usage error, 1 other error.\n";

cv::Mat readGrey(const std::string& path, const char* field) {
  const cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (image.empty()) throw areomap::cli::InputError(path, field, "cannot read the image");
  return image;
}

}  // namespace

int main(int argc, char** argv) {
  return areomap::cli::runTool("areomap-dense", argc, argv, kUsage, [](areomap::cli::Args& args) {
    areomap::dense::DenseOptions o;
    const std::string out = args.required("--out");
    const std::string max_text = args.required("--max-disp");
    o.min_disparity_px = static_cast<int>(args.integer("--min-disp", 0));
    o.coarse_step_px = static_cast<int>(args.integer("--coarse-step", 5));
    o.fill_holes = args.flag("--fill");
    const std::string mask_path = args.option("--mask", "");
    const std::string subpixel = args.option("--subpixel", "parabola");
    if (subpixel != "parabola" && subpixel != "lsm") {
      throw areomap::cli::UsageError("--subpixel: expected parabola or lsm, got '" + subpixel + "'");
    }
    o.refine_subpixel = subpixel == "lsm";
    char* end = nullptr;
    const long max_disp = std::strtol(max_text.c_str(), &end, 10);
    if (end == max_text.c_str() || *end != '\0' || max_disp < 1 || max_disp > 4096) {
      throw areomap::cli::UsageError("--max-disp: expected an integer 1..4096, got '" + max_text + "'");
    }
    o.max_disparity_px = static_cast<int>(max_disp);
    if (o.min_disparity_px > o.max_disparity_px) throw areomap::cli::UsageError("--min-disp above --max-disp");
    if (o.coarse_step_px < 1 || o.coarse_step_px > 64) throw areomap::cli::UsageError("--coarse-step: 1..64");
    const std::string left_path = args.positional(0, "LEFT");
    const std::string right_path = args.positional(1, "RIGHT");
    if (args.positionalCount() != 2) throw areomap::cli::UsageError("expected exactly two images, LEFT and RIGHT");
    const cv::Mat left = readGrey(left_path, "LEFT");
    const cv::Mat right = readGrey(right_path, "RIGHT");
    if (left.size() != right.size()) {
      throw areomap::cli::InputError(right_path, "size",
                                     "image is " + std::to_string(right.cols) + "x" + std::to_string(right.rows) +
                                         ", LEFT is " + std::to_string(left.cols) + "x" +
                                         std::to_string(left.rows));
    }
    if (left.cols < 2 * o.coarse_step_px || left.rows < 2 * o.coarse_step_px) {
      throw areomap::cli::InputError(left_path, "size", "image too small for the coarse grid");
    }
    areomap::cli::info("matching " + std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                       ", disparities " + std::to_string(o.min_disparity_px) + ".." +
                       std::to_string(o.max_disparity_px));
    const areomap::dense::DenseResult r = areomap::dense::matchRectified(left, right, o);
    char line[200];
    std::snprintf(line, sizeof line, "coarse %.2f s, fine %.2f s, post %.2f s; %.1f %% of pixels matched",
                  r.coarse_seconds, r.fine_seconds, r.post_seconds, 100.0 * r.matched_fraction);
    if (o.refine_subpixel) {
      std::snprintf(line, sizeof line, "least-squares matching: %lld refined, %lld kept the parabola's",
                    r.subpixel.refined, r.subpixel.kept);
      areomap::cli::info(line);
    }
    if (!cv::imwrite(out, r.disparity)) throw areomap::cli::InputError(out, "--out", "cannot write the TIFF");
    if (!mask_path.empty()) {
      cv::Mat mask = r.valid.clone();
      mask.setTo(128, r.filled);
      if (!cv::imwrite(mask_path, mask)) throw areomap::cli::InputError(mask_path, "--mask", "cannot write");
    }
    return 0;
  });
}
