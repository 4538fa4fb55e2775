// The whole ground-products pass on a dataset folder, per stage (BENCHMARKS.md "ground products"):
//   products_bench DATASET OUT [--truth-models] [--threads N] [--reference]
// --threads N: the pass on N threads (default every core); --reference: first the same pass on 1 thread
// into OUT-1thread, the reference of the same run (wall and CPU seconds of both, their ratio).
// Images and models from panorama.json (with --truth-models: truth/models/<stem>.cahvor, standing in for
// the adjusted models, and the cells the true cameras see and do not see are measured: the "truth:" line),
// tie points from truth/observations.csv when present, truth/dem.tif for the DEM RMSE. Prints the stage
// timings and figures. Not a CTest test (minutes on the full navcam preset).
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <map>
#include <set>
#include <string>

#include "ground/cli/Cli.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/products/Products.hpp"

using namespace areomap;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: products_bench DATASET OUT [--truth-models] [--threads N] [--reference]\n");
    return 2;
  }
  const std::string root = argv[1];
  const std::string out = argv[2];
  bool truth_models = false, reference = false;
  int threads = 0;
  for (int k = 3; k < argc; ++k) {
    if (std::strcmp(argv[k], "--truth-models") == 0) truth_models = true;
    if (std::strcmp(argv[k], "--reference") == 0) reference = true;
    if (std::strcmp(argv[k], "--threads") == 0 && k + 1 < argc) threads = std::atoi(argv[++k]);
  }
  const double t0 = cli::nowSeconds();
  const Dataset ds = readDataset(root);
  products::ProductInputs in;
  in.site = ds.name;
  std::map<std::string, int> index;
  auto add = [&](const ImageRef& ref) {
    products::ProductImage im;
    im.stem = ref.stem;
    im.grey = io::loadImage8(ref.image_path);
    const std::string tm = root + "/truth/models/" + ref.stem + ".cahvor";
    im.model = io::readCameraModelFile(truth_models && std::filesystem::exists(tm) ? tm : ref.model_path);
    index[ref.stem] = static_cast<int>(in.images.size());
    if (truth_models) in.truth_models.push_back(im.model);
    in.images.push_back(im);
    return index[ref.stem];
  };
  for (const Pair& p : ds.pairs) {
    products::ProductPair pp;
    pp.id = p.id;
    pp.sol = p.sol;
    pp.left = add(p.left);
    if (p.right) pp.right = add(*p.right);
    in.pairs.push_back(pp);
  }
  if (!ds.rig.gimbal_m.empty()) in.gimbal_site_m = ds.rig.gimbal_m.begin()->second;
  const std::string obs = root + "/truth/observations.csv";
  if (std::filesystem::exists(obs)) {
    std::map<int64_t, std::set<int>> pairs_of;
    for (const ImageObservation& o : readObservationsCsv(obs)) {
      auto it = index.find(o.image);
      if (it == index.end()) continue;
      products::ProductTie t;
      t.point = static_cast<int>(o.point);
      t.image = it->second;
      t.pixel_px = Vec2(o.sample_px, o.line_px);
      in.ties.push_back(t);
      pairs_of[o.point].insert(it->second / 2);
    }
    for (products::ProductTie& t : in.ties) t.inter = pairs_of[t.point].size() > 1;
  }
  if (std::filesystem::exists(root + "/truth/dem.tif")) in.truth_dem_path = root + "/truth/dem.tif";
  const double t_load = cli::nowSeconds() - t0;
  double ref_wall = 0.0, ref_cpu = 0.0;
  if (reference) {
    cli::setThreads(1);
    const double w0 = cli::nowSeconds(), c0 = static_cast<double>(std::clock()) / CLOCKS_PER_SEC;
    ground::AdjustReport one;
    products::makeProducts(in, products::ProductOptions{}, out + "-1thread", &one);
    ref_wall = cli::nowSeconds() - w0;
    ref_cpu = static_cast<double>(std::clock()) / CLOCKS_PER_SEC - c0;
  }
  cli::setThreads(threads);
  const double w0 = cli::nowSeconds(), c0 = static_cast<double>(std::clock()) / CLOCKS_PER_SEC;
  ground::AdjustReport report;
  const products::ProductsResult r = products::makeProducts(in, products::ProductOptions{}, out, &report);
  const double wall = cli::nowSeconds() - w0, cpu = static_cast<double>(std::clock()) / CLOCKS_PER_SEC - c0;
  std::printf("%d threads: wall %.1f s, CPU %.1f s", cli::threadCount(), wall, cpu);
  if (reference) std::printf("; reference 1 thread: wall %.1f s (%.2fx), CPU %.1f s", ref_wall, ref_wall / wall, ref_cpu);
  std::printf("\n");
  products::mergeIntoReport(r, report);
  std::printf("| load (%zu images) | %.1f s |\n", in.images.size(), t_load);
  double total = t_load;
  for (const auto& kv : report.seconds) {
    std::printf("| %s | %.1f s |\n", kv.first.c_str(), kv.second);
    total += kv.second;
  }
  std::printf("| total | %.1f s |\n", total);
  std::printf("points %lld, pairs matched %d, DEM %dx%d cells of %.3f m, DEM RMSE vs truth %s, ortho seams %.2f px, "
              "%zu warnings\n",
              r.points, r.pairs_matched, r.dem ? r.dem->cols : 0, r.dem ? r.dem->rows : 0, r.dem ? r.dem->cell_m : 0.0,
              r.dem_rmse_m ? std::to_string(*r.dem_rmse_m).c_str() : "n/a", r.ortho_seam_px, r.warnings.size());
  return 0;
}
