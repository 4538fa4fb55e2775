// Fuzz target: panorama.json (ground/dataset readDataset), the dataset contract of DESIGN.md. The input is
// written as panorama.json into a scratch folder. Expected failures: DatasetError (a cli::InputError).
// Invariants (safe inputs): every path of a dataset that reads is relative without "..",
// resolved inside the dataset folder; ids are unique.
#include <filesystem>
#include <set>
#include <string>

#include "ground/dataset/Dataset.hpp"
#include "tests/fuzz/FuzzSupport.hpp"

namespace {

void checkRef(const areomap::ImageRef& ref, const std::string& root) {
  std::string why;
  if (!areomap::isSafeRelativePath(ref.image, why)) areomap::fuzz::fail("panorama", "an unsafe image path was accepted");
  if (ref.image_path.rfind(root, 0) != 0) areomap::fuzz::fail("panorama", "an image resolves outside the folder");
  if (ref.model && !areomap::isSafeRelativePath(*ref.model, why)) {
    areomap::fuzz::fail("panorama", "an unsafe model path was accepted");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  using namespace areomap;
  static const std::string dir = [] {
    const std::string d = fuzz::scratchFolder() + "/dataset";
    std::filesystem::create_directories(d);
    return d;
  }();
  fuzz::writeFile(dir + "/" + kPanoramaFileName, data, size);
  try {
    const Dataset ds = readDataset(dir);
    std::set<int> ids;
    for (const Pair& p : ds.pairs) {
      if (!ids.insert(p.id).second) fuzz::fail("panorama", "duplicate pair id accepted");
      checkRef(p.left, ds.root);
      if (p.right) checkRef(*p.right, ds.root);
    }
    if (ds.width < 0 || ds.height < 0) fuzz::fail("panorama", "negative image size accepted");
  } catch (const cli::InputError&) {
  }
  return 0;
}
