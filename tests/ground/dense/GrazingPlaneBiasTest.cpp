// The far-range disparity bias (a suspect: semi-global aggregation on a surface
// slanted in rows, textured below and textureless sky above). A flat ground seen at a grazing angle by a
// rectified pair has d(y) = d0 + k (y - y_h) below the horizon row y_h (k = b / h, baseline over camera
// height: 0.2 / 1.5 m on the navcam head); the far rows (d 4-7 px, just below the horizon) are where the
// FarRange scene's matches came out +0.33 px too large. This pair renders that disparity field from one
// continuous texture (bicubic, as MatchErrorCorrelationTest) and measures the mean error of the fine
// matcher's disparities per band of rows. Result: no bias from the slant and the sky, with clean or noisy
// texture and any aggregation strength; a bias appears only where the texture also fades towards the far
// edge at low signal-to-noise (printed, not asserted).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "ground/dense/DenseMatcher.hpp"
#include "tests/ground/dense/TexturePair.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dense;

namespace {

constexpr int kGrazingWidth = 480, kGrazingHeight = 240, kHorizon = 40;
constexpr double kSlope = 0.2 / 1.5;  // px of disparity per row below the horizon
constexpr int kSky = 140;             // grey of the textureless sky

struct Look {
  double contrast = 255.0;  // grey range of the texture
  double blur_px = 1.0;     // Gaussian blur of the random field
  double noise = 0.0;       // independent image noise (grey sd)
  double squash = 1.0;      // vertical compression of the texture (grazing foreshortening)
  double d0 = 0.0;          // disparity at the horizon row (the terrain's far edge)
  double fade_rows = 0.0;   // > 0: texture contrast grows as (y - horizon) / fade_rows (capped at 1):
                            // farther rows, more averaged by the pixel footprint, carry less texture
  bool sky = true;          // textureless above the horizon (else the texture goes on at disparity d0)
  double slope = kSlope;    // px of disparity per row below the horizon
};
Look g_look;

double grazingDisparity(int y) {
  return g_look.d0 + g_look.slope * std::max(0, y - kHorizon);
}

void grazingPair(cv::Mat& left, cv::Mat& right, const Look& look) {
  const int pad = 48;
  cv::RNG rng(7);
  cv::Mat tex(kGrazingHeight + 2 * pad, kGrazingWidth + 2 * pad, CV_32FC1);
  rng.fill(tex, cv::RNG::UNIFORM, 128.0 - 0.5 * look.contrast, 128.0 + 0.5 * look.contrast);
  cv::GaussianBlur(tex, tex, cv::Size(0, 0), look.blur_px, look.blur_px / look.squash);
  cv::Mat l, r;  // right(xr) = T(xr + d)
  areomap::test::remapPair(
      tex, pad, kGrazingWidth, kGrazingHeight, [](int x, int y) { return x + grazingDisparity(y); }, l, r);
  if (look.fade_rows > 0.0) {
    for (int y = 0; y < kGrazingHeight; ++y) {
      const double g = std::clamp((y - kHorizon) / look.fade_rows, 0.05, 1.0);
      l.row(y) = (l.row(y) - 128.0) * g + 128.0;
      r.row(y) = (r.row(y) - 128.0) * g + 128.0;
    }
  }
  if (look.noise > 0.0) {
    cv::Mat n(l.size(), CV_32FC1);
    rng.fill(n, cv::RNG::NORMAL, 0.0, look.noise);
    l += n;
    rng.fill(n, cv::RNG::NORMAL, 0.0, look.noise);
    r += n;
  }
  l.convertTo(left, CV_8UC1);
  r.convertTo(right, CV_8UC1);
  if (look.sky) {
    left.rowRange(0, kHorizon).setTo(kSky);
    right.rowRange(0, kHorizon).setTo(kSky);
  }
}

struct Band {
  int y0, y1;  // rows [y0, y1)
  double mean = 0.0, sd = 0.0;
  long long n = 0, gross = 0;
};

// Mean / sd of d - d_true per band of rows (valid pixels away from the borders; errors > 2 px counted
// apart as gross).
void scoreBands(const DenseResult& res, std::vector<Band>& bands) {
  for (Band& b : bands) {
    double s = 0.0, s2 = 0.0;
    for (int y = b.y0; y < b.y1; ++y) {
      for (int x = 40; x < kGrazingWidth - 8; ++x) {
        const float d = res.disparity.at<float>(y, x);
        if (std::isnan(d)) continue;
        const double e = d - grazingDisparity(y);
        if (std::fabs(e) > 2.0) {
          ++b.gross;
          continue;
        }
        s += e;
        s2 += e * e;
        ++b.n;
      }
    }
    b.mean = b.n > 0 ? s / static_cast<double>(b.n) : NAN;
    b.sd = b.n > 0 ? std::sqrt(std::max(0.0, s2 / static_cast<double>(b.n) - b.mean * b.mean)) : NAN;
  }
}

std::vector<Band> matchAndScore(const char* label, const DenseOptions& o, const Look& look = Look{}) {
  cv::Mat left, right;
  g_look = look;
  grazingPair(left, right, look);
  const DenseResult res = matchRectified(left, right, o);
  // Far: d 1-3 px, 3-6 px (the FarRange scene's 45-60 m and 30-45 m), near: 6-20 px.
  std::vector<Band> bands{
      {kHorizon + 8, kHorizon + 23}, {kHorizon + 23, kHorizon + 45}, {kHorizon + 45, kGrazingHeight - 8}};
  scoreBands(res, bands);
  std::printf("\n  %-34s", label);
  for (const Band& b : bands) {
    std::printf(" | d %4.1f-%4.1f: bias %+.3f sd %.3f n %lld gross %lld", grazingDisparity(b.y0),
                grazingDisparity(b.y1), b.mean, b.sd, b.n, b.gross);
  }
  return bands;
}

}  // namespace

TEST_GROUP(GrazingPlaneBias){};

// The slant alone: a grazing plane (0.133 px per row) from d = 4 px at its far edge (~60 m on the navcam
// head) down to 29 px, textureless sky above, clean and noisy texture; the default matcher and stronger /
// fewer-path aggregation. The bias per band must stay within 3 standard errors of its mean, with the
// errors' correlation counted: n_eff = n / (2 L)^2, L = 3.8 px (floor 0.03 px) -- at most 0.05 px on the
// clean texture and 0.17 px on the noisy one, against the +0.33 px at 45-60 m of the FarRange scene before
// session 5. L is the plane's error correlation (MatchErrorCorrelationTest without relief, whose long tail a
// plane has), not the default matcher's 2.0 px on rough ground (kMatchErrorCorrelationPx): here the disparity
// is a plane too, and the strong-aggregation cases correlate their errors farther than the default.
TEST(GrazingPlaneBias, SlantInRowsBelowTheSkyIsUnbiased) {
  DenseOptions o;
  o.max_disparity_px = 40;
  Look clean;
  clean.d0 = 4.0;
  Look noisy = clean;
  noisy.contrast = 60.0;
  noisy.noise = 2.0;
  noisy.blur_px = 1.5;
  DenseOptions strong = o;
  strong.fine_sgm = SemiGlobalParams{32, 192, 8};
  DenseOptions four = o;
  four.fine_sgm.paths = 4;
  struct Case {
    const char* label;
    const DenseOptions* options;
    const Look* look;
  } cases[] = {{"clean, default", &o, &clean},       {"clean, fine P1 32 P2 192", &strong, &clean},
               {"clean, fine 4 paths", &four, &clean}, {"noisy, default", &o, &noisy},
               {"noisy, fine P1 32 P2 192", &strong, &noisy}};
  constexpr double kPlaneErrorCorrelationPx = 3.8;
  const double cells = (2.0 * kPlaneErrorCorrelationPx) * (2.0 * kPlaneErrorCorrelationPx);
  for (const Case& c : cases) {
    for (const Band& b : matchAndScore(c.label, *c.options, *c.look)) {
      CHECK(b.n > 1000);
      CHECK(b.gross * 20 < b.n);
      const double bound = std::max(0.03, 3.0 * b.sd / std::sqrt(static_cast<double>(b.n) / cells));
      CHECK_TEXT(std::fabs(b.mean) <= bound, c.label);
    }
  }
  // Not asserted, printed: where the texture fades towards the far edge (contrast growing with the rows
  // below it) AND the surface is slanted, low signal-to-noise rows are pulled towards the nearer, better
  // textured rows (+0.35 px at d 5-7 px here, 2026-12-02); without the slant there is no bias. The
  // FarRange scene's bias is NOT this one (it is there with good texture, in every matcher tried, and
  // shrinks with the renderer's supersampling: docs/benchmarks-history.md).
  Look fade = noisy;
  fade.contrast = 255.0;
  fade.fade_rows = 200.0;
  matchAndScore("texture fading upwards, slanted", o, fade);
  fade.slope = 0.0;
  matchAndScore("texture fading upwards, level", o, fade);
  std::printf("\n");
}
