// Fuzz target: the CSV files of the dataset contract (ground/dataset TruthFiles): tie-point and
// observation lists (readObservationsCsv: tiepoints.csv, truth/observations.csv, --ties lists) and check
// points (readPointsCsv: truth/points.csv). Expected failures: DatasetError (a cli::InputError).
// Invariant: every value read is finite (a NaN pixel would poison an adjustment).
#include <cmath>
#include <string>

#include "ground/dataset/TruthFiles.hpp"
#include "tests/fuzz/FuzzSupport.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  using namespace areomap;
  static const std::string path = fuzz::scratchFolder() + "/input.csv";
  fuzz::writeFile(path, data, size);
  try {
    for (const ImageObservation& o : readObservationsCsv(path)) {
      if (!std::isfinite(o.sample_px) || !std::isfinite(o.line_px)) fuzz::fail("tiepoints", "non-finite pixel read");
    }
  } catch (const cli::InputError&) {
  }
  try {
    for (const CheckPoint& p : readPointsCsv(path)) {
      if (!p.site_m.allFinite()) fuzz::fail("tiepoints", "non-finite point read");
    }
  } catch (const cli::InputError&) {
  }
  return 0;
}
