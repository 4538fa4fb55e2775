#include "ground/ties/TieRunner.hpp"

#include <algorithm>
#include <filesystem>
#include <memory>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ground/cli/Cli.hpp"
#include "ground/raster/RasterFiles.hpp"
#include "ground/ties/FullResolutionTies.hpp"

namespace areomap {
namespace {

ImageView viewOf(const cv::Mat& m) {
  return ImageView{m.ptr<uint8_t>(0), m.cols, m.rows, static_cast<int32_t>(m.step[0])};
}

// The binning factor of the panorama: that of its largest image (FullResolutionTies.hpp), so that every
// image and every stored patch of the matcher is in one pixel scale.
int32_t panoramaBinning(const io::Panorama& panorama) {
  int32_t k = 1;
  for (std::size_t i = 0; i < panorama.left.size(); ++i) {
    k = std::max(k, binningFactor(panorama.left[i].grey.cols, panorama.left[i].grey.rows));
    if (panorama.right[i])
      k = std::max(k, binningFactor(panorama.right[i]->grey.cols, panorama.right[i]->grey.rows));
  }
  return k;
}

int solIndex(const Dataset& dataset, std::size_t k, TieNetwork& network) {
  const Pair& pair = dataset.pairs[k];
  auto it = std::find(network.sol_of_index.begin(), network.sol_of_index.end(), pair.sol);
  if (it == network.sol_of_index.end()) {
    if (static_cast<int32_t>(network.sol_of_index.size()) >= kMaxSols) {
      throw cli::InputError(dataset.root + "/panorama.json", "pairs[" + std::to_string(k) + "].sol",
                            "more than " + std::to_string(kMaxSols) + " sols");
    }
    network.sol_of_index.push_back(pair.sol);
    it = network.sol_of_index.end() - 1;
  }
  return static_cast<int>(it - network.sol_of_index.begin());
}

std::string progressLine(std::size_t k, std::size_t n, const Pair& pair, Status s,
                         const PairTieReport& report) {
  return "pair " + std::to_string(k + 1) + "/" + std::to_string(n) + " (" + pair.left.stem +
         "): " + statusName(s) + ", intra " + std::to_string(report.intra.selected) + ", inter " +
         std::to_string(report.inter_candidates) + " predicted, " + std::to_string(report.inter_matched) +
         " matched, " + std::to_string(report.inter_rejected) + " rejected, " +
         std::to_string(report.inter_observations) + " observations to " + std::to_string(report.neighbours) +
         " earlier pairs; " + std::to_string(report.inter_candidates_stored) + " candidates kept" +
         (report.births_deferred > 0
              ? ", " + std::to_string(report.births_deferred) + " deferred (point share)"
              : "") +
         (report.overflow > 0 ? ", " + std::to_string(report.overflow) + " lost to full lists" : "");
}

}  // namespace

TieRun runTiePoints(const io::Panorama& panorama, bool progress, TieNetwork* network) {
  const Dataset& dataset = panorama.dataset;
  if (static_cast<int32_t>(dataset.pairs.size()) > kMaxPairs) {
    throw cli::InputError(
        dataset.root + "/panorama.json", "pairs",
        std::to_string(dataset.pairs.size()) + " pairs exceed the rover's " + std::to_string(kMaxPairs));
  }
  // ~20 MiB of fixed workspaces, as on the rover (heap here only because the ground owns its memory).
  auto matcher = std::make_unique<PanoramaMatcher>();
  auto dem = std::make_unique<CoarseDem>();
  matcher->reset();
  matcher->planForPairs(static_cast<int32_t>(dataset.pairs.size()));
  TieRun run;
  run.binning = panoramaBinning(panorama);
  if (progress && run.binning > 1) {
    cli::info("tie points matched on images binned " + std::to_string(run.binning) + "x" +
              std::to_string(run.binning) + " (the matcher's capacity is " + std::to_string(kMaxImageWidth) +
              "x" + std::to_string(kMaxImageHeight) + "), then refined at full resolution");
  }
  const double start = cli::nowSeconds();
  std::vector<cv::Mat> full(2 * dataset.pairs.size());  // per tie image index (2 * pair + side)
  std::vector<int32_t> obs_after, points_after;         // list lengths after each pair
  for (size_t k = 0; k < dataset.pairs.size(); ++k) {
    const Pair& pair = dataset.pairs[k];
    const io::PanoramaImage& left = panorama.left[k];
    const io::PanoramaImage* right = panorama.right[k] ? &*panorama.right[k] : nullptr;  // mono: none
    run.stems.push_back(pair.left.stem);
    run.stems.push_back(pair.right ? pair.right->stem : std::string());
    full[2 * k] = left.grey;
    if (right != nullptr) full[2 * k + 1] = right->grey;
    const cv::Mat lb = binImage(left.grey, run.binning);
    const cv::Mat rb = right != nullptr ? binImage(right->grey, run.binning) : cv::Mat();
    const CameraModel lm = binnedModel(left.model, run.binning);
    const CameraModel rm = right != nullptr ? binnedModel(right->model, run.binning) : CameraModel{};
    const ImageView lv = viewOf(lb);
    const ImageView rv = right != nullptr ? viewOf(rb) : ImageView{};
    PairTieReport report;
    const Status s = matcher->addPair(lv, right != nullptr ? &rv : nullptr, lm,
                                      right != nullptr ? &rm : nullptr, *dem, report);
    if (s == Status::kInvalidArgument || s == Status::kCapacityExceeded) {
      throw cli::InputError(pair.left.image_path, "image",
                            std::string("rejected by the matcher: ") + statusName(s));
    }
    run.reports.push_back(report);
    obs_after.push_back(matcher->observations().size());
    points_after.push_back(matcher->points().size());
    if (progress) cli::info(progressLine(k, dataset.pairs.size(), pair, s, report));
  }
  std::vector<TieObservation> obs(matcher->observations().begin(), matcher->observations().end());
  std::vector<TiePoint> points(matcher->points().begin(), matcher->points().end());
  std::vector<int32_t> kept_obs(obs.size() + 1), kept_points(points.size() + 1);
  for (std::size_t i = 0; i < kept_obs.size(); ++i) kept_obs[i] = static_cast<int32_t>(i);
  for (std::size_t i = 0; i < kept_points.size(); ++i) kept_points[i] = static_cast<int32_t>(i);
  if (run.binning > 1) {
    RefineParams params;
    params.min_ncc = matcher->stereo.min_ncc;
    params.lr_tolerance_px = matcher->stereo.lr_tolerance_px;
    run.refine = refineAtFullResolution(full, run.binning, params, obs, points, kept_obs, kept_points);
    if (progress) {
      cli::info("full-resolution refinement: " + std::to_string(run.refine.refined) +
                " observations refined, " + std::to_string(run.refine.dropped) + " left out (score below " +
                std::to_string(run.refine.score_floor).substr(0, 4) + " " +
                std::to_string(run.refine.low_score) + ", window border " +
                std::to_string(run.refine.border) + ", back-match " + std::to_string(run.refine.back_match) +
                ", least squares " + std::to_string(run.refine.least_squares) + "), " +
                std::to_string(run.refine.points_dropped) + " points left out");
    }
  }
  if (network != nullptr) {
    network->net->clear();
    network->builder->reset();
    for (size_t k = 0; k < dataset.pairs.size(); ++k) {
      const Pair& pair = dataset.pairs[k];
      const io::PanoramaImage& left = panorama.left[k];
      const io::PanoramaImage* right = panorama.right[k] ? &*panorama.right[k] : nullptr;
      TieList list;
      list.points = points.data();
      list.point_count = kept_points[points_after[k]];
      list.observations = obs.data();
      list.observation_count = kept_obs[obs_after[k]];
      list.pair_count = static_cast<int32_t>(k) + 1;
      const int tier = std::max(0, std::min(kMaxTiers - 1, pair.tier));
      int32_t failed = 0;
      const Status ns =
          network->builder->syncPair(list, solIndex(dataset, k, *network), tier, left.model,
                                     right != nullptr ? &right->model : nullptr, *network->net, failed);
      if (!ok(ns)) {
        throw cli::InputError(pair.left.image_path, "model",
                              std::string("cannot enter the network: ") + statusName(ns));
      }
      network->failed_observations += failed;
      network->stem_of_image.push_back(pair.left.stem);
      network->apriori_of_image.push_back(left.model);
      if (right != nullptr) {
        network->stem_of_image.push_back(right->stem);
        network->apriori_of_image.push_back(right->model);
      }
    }
  }
  run.seconds = cli::nowSeconds() - start;
  for (const TieObservation& t : obs) {
    ImageObservation o;
    o.point = t.point;
    o.image = run.stems[static_cast<size_t>(t.image)];
    o.sample_px = t.sample_px;
    o.line_px = t.line_px;
    o.kind = t.kind == TieKind::kIntra ? "intra" : "inter";
    (t.kind == TieKind::kIntra ? run.intra_observations : run.inter_observations) += 1;
    run.observations.push_back(o);
  }
  for (const TiePoint& p : points) run.points_m.push_back(p.ground_m);
  return run;
}

void writeTiePoints(const std::string& out_dir, const TieRun& run) {
  std::filesystem::create_directories(out_dir);
  writeObservationsCsv(out_dir + "/tiepoints.csv", run.observations, true);
}

void writeOverlays(const std::string& out_dir, const io::Panorama& panorama, const TieRun& run) {
  const std::string dir = out_dir + "/overlays";
  std::filesystem::create_directories(dir);
  for (std::size_t k = 0; k < panorama.left.size(); ++k) {
    for (const io::PanoramaImage* im :
         {&panorama.left[k], panorama.right[k] ? &*panorama.right[k] : nullptr}) {
      if (im == nullptr) continue;
      cv::Mat colour;
      cv::cvtColor(im->grey, colour, cv::COLOR_GRAY2BGR);
      for (const ImageObservation& o : run.observations) {
        if (o.image != im->stem) continue;
        const cv::Scalar c = o.kind == "intra" ? cv::Scalar(255, 0, 0) : cv::Scalar(0, 0, 255);  // BGR
        const cv::Point p(static_cast<int>(std::lround(o.sample_px)),
                          static_cast<int>(std::lround(o.line_px)));
        cv::drawMarker(colour, p, c, cv::MARKER_CROSS, 9, 1);
      }
      const std::string path = dir + "/" + im->stem + ".png";
      raster::writePng(path, colour);
    }
  }
}

}  // namespace areomap
