// The adjustment products (DESIGN.md "Products"), reusable by areomap-adjust, areomap-ties and
// areomap-ground: DIR/models/<stem>.cahvor (the a-priori model moved rigidly to the adjusted EO), DIR/eo.csv
// (EO and its a-posteriori sigmas, column `image` = stem) and DIR/report.json.
//
// Figures: method1_px, method3_px (x, y, dist) and method2_m (x, y, z) are MEAN ABSOLUTE differences (the
// paper's averages of absolute differences); rms_px is the RMS of the image residuals per coordinate;
// truth.eo_px / ground_m are RMS over images / points (eo in pixel equivalent: f x (angle + |dC| / 5 m)),
// after removing the common datum rotation about the gimbal centre, with the raw values beside them.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/adjust/Precision.hpp"
#include "firmware_core/camera/CameraModel.hpp"

namespace areomap::ground {

struct TruthFigures {
  double eo_px = 0.0;
  std::optional<double> ground_m;    // absent when no tie point has a true position
  std::optional<double> dem_rmse_m;  // absent: no DEM is made by the adjustment alone
  double eo_px_raw = 0.0;
  std::optional<double> ground_m_raw;
  std::optional<double> eo_px_before;  // a-priori, aligned
  // What the true cameras see against the products (ground/products/TruthSeen.hpp; absent without the
  // true models and DEM): of the cells they do not see, the fraction dem.tif leaves empty; of those they
  // see, the fraction it fills, and the fraction where ortho.tif agrees with an ortho made from truth.
  std::optional<double> dem_unseen_empty, dem_seen_filled, ortho_agreement;
};

// One stereo pair's matching noise as the dense products estimated it (ground/dense/MatchNoise.hpp):
// report.json dense.pairs[].
struct DensePairNoise {
  int pair = 0;                    // the pair's id
  double match_sigma_px = 0.0;     // the matching sigma its points and the DEM sigma carry
  std::string match_sigma_source;  // "left_right" | "fallback_constant" | "constant"
  long long samples = 0;           // left-right differences the estimate used
};

// One stereo pair's DEM coverage as the products measured it (ground/products/DemCoverage.hpp): of the
// DEM cells both cameras see at 2-5 m and at 5-10 m horizontal range, how many hold an elevation.
// report.json dem_coverage.
struct DemCoverageFigure {
  int pair = 0;
  long seen_2_5m = 0, filled_2_5m = 0;
  long seen_5_10m = 0, filled_5_10m = 0;
};
// Over every pair and both bands: the cells seen and, of those, filled.
void demCoverageTotal(const std::vector<DemCoverageFigure>& figures, long& seen, long& filled);

struct AdjustReport {
  ImageDifferences method1_before, method1_after, method3_before, method3_after;
  GroundDifferences method2_before, method2_after;
  double rms_px = 0.0;
  double sigma0 = 0.0;
  int iterations = 0;
  TiePointCounts tie_points;
  std::vector<std::pair<std::string, double>> seconds;  // per stage, in order
  std::optional<TruthFigures> truth;
  std::vector<std::string> warnings;
  // Extra description of the run (solver, stop rule, constraints, estimated rig values).
  std::string solver;
  std::string stop_rule;
  std::map<std::string, bool> constraints;
  std::vector<std::string> estimated;
  double max_gimbal_misfit_m = 0.0;
  double max_base_misfit_m = 0.0;
  double sigma_gimbal_m = 0.0;  // the constraint sigmas of the solution (after the held-sigma rule)
  double sigma_base_m = 0.0;
  std::vector<DensePairNoise> dense_pairs;  // filled by the products (empty: no dense matching ran)
  std::vector<DemCoverageFigure> dem_coverage;  // filled by the products (empty: no DEM)
};

// The rig figures of the network's current solution: the largest Eq. 3 / Eq. 4 misfits, the sigmas used and
// what the held-sigma rule did (ground/dataset/RigSigmas.hpp: notes into `estimated`, a missed bound into
// `warnings`).
void setRigFigures(AdjustReport& report, const Network& net);

// Each throws cli::InputError naming the file when it cannot be written.
void writeReportJson(const std::string& path, const AdjustReport& report);
void writeEoCsv(const std::string& path, const Network& net, const std::vector<std::string>& stems);
// `apriori[i]` is image i's a-priori model; the adjusted one is written to dir/<stem>.cahvor. With `errors`,
// a model that cannot be written is recorded there (its error naming the file) and the others are still
// written; without, the first failure throws.
void writeAdjustedModels(const std::string& dir, const Network& net, const std::vector<CameraModel>& apriori,
                         const std::vector<std::string>& stems, std::vector<std::string>* errors = nullptr);
// The adjusted model of image i (the a-priori model moved by M_new^T M_old to the new centre).
CameraModel adjustedModelOf(const Network& net, int image, const CameraModel& apriori);

}  // namespace areomap::ground
