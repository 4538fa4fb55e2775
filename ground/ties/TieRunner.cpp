#include "ground/ties/TieRunner.hpp"

#include <algorithm>
#include <filesystem>
#include <memory>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ground/cli/Cli.hpp"
#include "ground/raster/RasterFiles.hpp"

namespace areomap {
namespace {

// The matcher takes images up to the rover's capacity.
void checkCapacity(const io::PanoramaImage& im) {
  if (im.grey.cols > kMaxImageWidth || im.grey.rows > kMaxImageHeight) {
    throw cli::InputError(im.image_path, "image",
                          "larger than the rover's " + std::to_string(kMaxImageWidth) + "x" +
                              std::to_string(kMaxImageHeight) + " capacity");
  }
}

ImageView viewOf(const cv::Mat& m) {
  return ImageView{m.ptr<uint8_t>(0), m.cols, m.rows, static_cast<int32_t>(m.step[0])};
}

}  // namespace

TieRun runTiePoints(const io::Panorama& panorama, bool progress, TieNetwork* network) {
  const Dataset& dataset = panorama.dataset;
  if (static_cast<int32_t>(dataset.pairs.size()) > kMaxPairs) {
    throw cli::InputError(dataset.root + "/panorama.json", "pairs",
                          std::to_string(dataset.pairs.size()) + " pairs exceed the rover's " +
                              std::to_string(kMaxPairs));
  }
  // ~20 MiB of fixed workspaces, as on the rover (heap here only because the ground owns its memory).
  auto matcher = std::make_unique<PanoramaMatcher>();
  auto dem = std::make_unique<CoarseDem>();
  matcher->reset();
  matcher->planForPairs(static_cast<int32_t>(dataset.pairs.size()));
  if (network != nullptr) {
    network->net->clear();
    network->builder->reset();
  }
  TieRun run;
  const double start = cli::nowSeconds();
  for (size_t k = 0; k < dataset.pairs.size(); ++k) {
    const Pair& pair = dataset.pairs[k];
    const io::PanoramaImage& left = panorama.left[k];
    const io::PanoramaImage* right = panorama.right[k] ? &*panorama.right[k] : nullptr;  // mono: none
    checkCapacity(left);
    if (right != nullptr) checkCapacity(*right);
    run.stems.push_back(pair.left.stem);
    run.stems.push_back(pair.right ? pair.right->stem : std::string());
    const ImageView lv = viewOf(left.grey);
    const ImageView rv = right != nullptr ? viewOf(right->grey) : ImageView{};
    const CameraModel* right_model = right != nullptr ? &right->model : nullptr;
    PairTieReport report;
    const Status s =
        matcher->addPair(lv, right != nullptr ? &rv : nullptr, left.model, right_model, *dem, report);
    if (s == Status::kInvalidArgument || s == Status::kCapacityExceeded) {
      throw cli::InputError(pair.left.image_path, "image", std::string("rejected by the matcher: ") + statusName(s));
    }
    run.reports.push_back(report);
    if (network != nullptr) {
      auto it = std::find(network->sol_of_index.begin(), network->sol_of_index.end(), pair.sol);
      if (it == network->sol_of_index.end()) {
        if (static_cast<int32_t>(network->sol_of_index.size()) >= kMaxSols) {
          throw cli::InputError(dataset.root + "/panorama.json", "pairs[" + std::to_string(k) + "].sol",
                                "more than " + std::to_string(kMaxSols) + " sols");
        }
        network->sol_of_index.push_back(pair.sol);
        it = network->sol_of_index.end() - 1;
      }
      const int sol_index = static_cast<int>(it - network->sol_of_index.begin());
      const int tier = std::max(0, std::min(kMaxTiers - 1, pair.tier));
      int32_t failed = 0;
      const Status ns = network->builder->syncPair(matcher->ties(), sol_index, tier, left.model, right_model,
                                                   *network->net, failed);
      if (!ok(ns)) {
        throw cli::InputError(pair.left.image_path, "model", std::string("cannot enter the network: ") + statusName(ns));
      }
      network->failed_observations += failed;
      network->stem_of_image.push_back(pair.left.stem);
      network->apriori_of_image.push_back(left.model);
      if (right != nullptr) {
        network->stem_of_image.push_back(right->stem);
        network->apriori_of_image.push_back(right->model);
      }
    }
    if (progress) {
      cli::info("pair " + std::to_string(k + 1) + "/" + std::to_string(dataset.pairs.size()) + " (" + pair.left.stem +
                "): " + statusName(s) + ", intra " + std::to_string(report.intra.selected) + ", inter " +
                std::to_string(report.inter_candidates) + " predicted, " + std::to_string(report.inter_matched) +
                " matched, " + std::to_string(report.inter_rejected) + " rejected, " +
                std::to_string(report.inter_observations) + " observations to " + std::to_string(report.neighbours) +
                " earlier pairs; " + std::to_string(report.inter_candidates_stored) + " candidates kept" +
                (report.births_deferred > 0 ? ", " + std::to_string(report.births_deferred) + " deferred (point share)" : "") +
                (report.overflow > 0 ? ", " + std::to_string(report.overflow) + " lost to full lists" : ""));
    }
  }
  run.seconds = cli::nowSeconds() - start;
  const auto& obs = matcher->observations();
  for (int32_t i = 0; i < obs.size(); ++i) {
    ImageObservation o;
    o.point = obs[i].point;
    o.image = run.stems[static_cast<size_t>(obs[i].image)];
    o.sample_px = obs[i].sample_px;
    o.line_px = obs[i].line_px;
    o.kind = obs[i].kind == TieKind::kIntra ? "intra" : "inter";
    (obs[i].kind == TieKind::kIntra ? run.intra_observations : run.inter_observations) += 1;
    run.observations.push_back(o);
  }
  for (int32_t i = 0; i < matcher->points().size(); ++i) run.points_m.push_back(matcher->points()[i].ground_m);
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
        const cv::Point p(static_cast<int>(std::lround(o.sample_px)), static_cast<int>(std::lround(o.line_px)));
        cv::drawMarker(colour, p, c, cv::MARKER_CROSS, 9, 1);
      }
      const std::string path = dir + "/" + im->stem + ".png";
      raster::writePng(path, colour);
    }
  }
}

}  // namespace areomap
