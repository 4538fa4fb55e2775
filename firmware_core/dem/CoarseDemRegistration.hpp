// The relative pose of two neighbouring sites from their coarse DEMs, on board (the rover's port of the
// ground's DEM registration, ground/traverse/DemRegistration.hpp, with its structure: samples of B moved into
// A by a levelled pose, a grid search of the variance of the elevation differences over +-search_m in x, y
// and +-search_deg in heading with the z offset the mean difference at each candidate, a second-minimum test
// for ambiguity, then Gauss-Newton on A's DEM gradients, trimmed at 3 robust sigmas). Differences from the
// ground's: the DEMs are the rover's (kCoarseDemCellM cells from its tie points), so the search steps are
// one cell and one degree and there is no fine search; no dem_sigma weights; the covariance is the
// least-squares one (no inflation for correlated differences: the rover uses the pose to place its search
// windows, not as an observation).
//
// Memory: the workspace holds the samples (kMaxRegistrationSamples); no heap; every loop bounded.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/dem/CoarseDem.hpp"

namespace areomap {

// Samples of B's DEM: every measured cell of the kCoarseDemCells^2 grid at most.
constexpr int32_t kMaxRegistrationSamples = kCoarseDemCells * kCoarseDemCells;
// Grid search: at most +-kMaxRegistrationSteps steps per axis (one cell, one degree each).
constexpr int32_t kMaxRegistrationSteps = 16;
constexpr int32_t kMaxRegistrationIterations = 40;

// The registration's 4-vectors and their normal matrix: x, y, z (m), heading (rad).
using RegVec4 = Eigen::Matrix<double, 4, 1>;
using RegMat4 = Eigen::Matrix<double, 4, 4>;

// Levelled rigid map of site B's frame into site A's: p_a = Rz(heading) p_b + translation.
struct LevelledPose {
  Vec3 translation_m = Vec3::Zero();
  double heading_rad = 0.0;
  Mat3 rotation() const;
  Vec3 toA(const Vec3& b_m) const { return rotation() * b_m + translation_m; }
};

enum class DemRegistrationStatus : uint8_t { kOk = 0, kNoOverlap = 1, kAmbiguous = 2, kNotConverged = 3 };
const char* demRegistrationStatusName(DemRegistrationStatus status);

struct DemRegistrationParams {
  double search_m = 2.0;     // +- in x and y about the a-priori translation (at most kMaxRegistrationSteps cells)
  double search_deg = 5.0;   // +- in heading (at most kMaxRegistrationSteps degrees)
  double max_range_m = 30.0;      // samples within this horizontal range of both site origins
  int32_t min_overlap_cells = 60;  // fewer common samples: kNoOverlap
  double max_cost_ratio = 0.7;     // best / second minimum above it: kAmbiguous
  double second_min_distance_m = 1.0;  // a second minimum lies this far from the best (or second_min_deg)
  double second_min_deg = 2.0;
};

struct DemRegistrationResult {
  DemRegistrationStatus status = DemRegistrationStatus::kNoOverlap;
  LevelledPose a_from_b;       // registered (the a-priori pose when not kOk)
  RegVec4 sigma = RegVec4::Zero();   // x, y, z (m), heading (rad)
  int32_t overlap = 0;         // common samples at the solution
  int32_t used = 0;            // after trimming
  double rms_m = 0.0;          // RMS elevation difference of the used samples
  double cost_ratio = 0.0;     // best / second minimum of the grid search (0: no second minimum)
  int32_t iterations = 0;
};

class CoarseDemRegistration {
 public:
  // B's DEM registered onto A's about `apriori` (A from B).
  DemRegistrationResult run(const CoarseDem& a, const CoarseDem& b, const LevelledPose& apriori,
                            const DemRegistrationParams& params);

 private:
  struct Moments {
    double sum = 0.0, sum2 = 0.0;
    int32_t n = 0;
  };
  Moments moments(const CoarseDem& a, const LevelledPose& pose, double max_range_m, int32_t stride) const;
  bool gaussNewton(const CoarseDem& a, const DemRegistrationParams& params, int32_t min_used,
                   LevelledPose& pose, DemRegistrationResult& out);

  float sample_[kMaxRegistrationSamples][3] = {};
  float abs_difference_[kMaxRegistrationSamples] = {};
  int32_t sample_count_ = 0;
  double cost_[2 * kMaxRegistrationSteps + 1][2 * kMaxRegistrationSteps + 1][2 * kMaxRegistrationSteps + 1] = {};
};

}  // namespace areomap
