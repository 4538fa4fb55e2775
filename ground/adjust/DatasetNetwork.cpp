#include "ground/adjust/DatasetNetwork.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <filesystem>
#include <random>
#include <map>
#include <sstream>

#include "ground/cli/Cli.hpp"
#include "ground/dataset/RigSigmas.hpp"
#include "ground/io/CameraFile.hpp"

namespace areomap::ground {

namespace {

std::string vecText(const Vec3& v) {
  std::ostringstream s;
  s.precision(6);
  s << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
  return s.str();
}

void addCamera(const Dataset& dataset, const ImageRef& ref, const std::string& field, NetworkSource& source) {
  const std::string path = ref.model_path.empty() ? ref.image_path : ref.model_path;
  const CameraModel model = io::readCameraModelForImage(path, ref.image_path, dataset.width, dataset.height);
  PhotogrammetricCamera cam;
  ConversionResidual residual;
  const Status s = cahvorToPhotogrammetric(model, cam, residual);
  if (!ok(s)) {
    throw cli::InputError(path, field, std::string("cannot convert the camera model: ") + statusName(s));
  }
  source.stems.push_back(ref.stem);
  source.apriori_models.push_back(model);
  source.cameras.push_back(cam);
}

}  // namespace

void buildNetwork(const Dataset& dataset, const std::vector<ImageObservation>& observations,
                  const RigChoice& choice, Network& net, NetworkSource& source) {
  net.clear();
  net.rig = RigConstraints{};
  source = NetworkSource{};
  std::map<int, int> sol_index;
  const std::string pano = dataset.root + "/" + kPanoramaFileName;
  for (size_t p = 0; p < dataset.pairs.size(); ++p) {
    const Pair& pr = dataset.pairs[p];
    const std::string field = "pairs[" + std::to_string(p) + "]";
    if (sol_index.count(pr.sol) == 0) {
      if (static_cast<int>(sol_index.size()) >= kMaxSols) {
        throw cli::InputError(pano, field + ".sol", "more than " + std::to_string(kMaxSols) + " sols");
      }
      const int idx = static_cast<int>(sol_index.size());
      sol_index[pr.sol] = idx;
      source.sol_of_index.push_back(pr.sol);
    }
    if (pr.tier < 0 || pr.tier >= kMaxTiers) {
      throw cli::InputError(pano, field + ".tier", "tier outside 0.." + std::to_string(kMaxTiers - 1));
    }
    addCamera(dataset, pr.left, field + ".left.model", source);
    if (pr.right) addCamera(dataset, *pr.right, field + ".right.model", source);
    const PhotogrammetricCamera& l = source.cameras[source.cameras.size() - (pr.right ? 2 : 1)];
    const PhotogrammetricCamera& r = source.cameras.back();
    int32_t index = 0;
    const Status s = net.addPair(sol_index[pr.sol], pr.tier, l.io, l.eo.center_m, l.m,
                                 pr.right ? &r.io : nullptr, r.eo.center_m, r.m, index);
    if (!ok(s)) throw cli::InputError(pano, field, std::string("cannot add the pair: ") + statusName(s));
  }
  std::map<std::string, int> image_of_stem;
  for (size_t i = 0; i < source.stems.size(); ++i) image_of_stem[source.stems[i]] = static_cast<int>(i);

  // Points in order of first appearance.
  std::map<int64_t, int> point_of_id;
  std::map<std::string, int> unknown_stems;
  for (const ImageObservation& o : observations) {
    const auto it = image_of_stem.find(o.image);
    if (it == image_of_stem.end()) {
      ++unknown_stems[o.image];
      ++source.dropped_observations;
      continue;
    }
    int point = 0;
    const auto pit = point_of_id.find(o.point);
    if (pit == point_of_id.end()) {
      const Status s = net.addPoint(Vec3::Zero(), point);
      if (!ok(s)) {
        ++source.dropped_observations;
        continue;
      }
      point_of_id[o.point] = point;
      source.point_ids.push_back(o.point);
    } else {
      point = pit->second;
    }
    Vec2 ideal;
    const int img = it->second;
    if (!ok(pixelToIdeal(source.apriori_models[img], source.cameras[img], Vec2(o.sample_px, o.line_px),
                         ideal)) ||
        !ok(net.addObservation(point, img, ideal, choice.sigma_px))) {
      ++source.dropped_observations;
    }
  }
  for (const auto& [stem, count] : unknown_stems) {
    source.warnings.push_back(std::to_string(count) + " observations name image '" + stem +
                              "', which is not in the dataset; they were ignored.");
  }
  int32_t failed = 0;
  (void)net.triangulateAll(failed);
  if (failed > 0) {
    source.warnings.push_back(
        std::to_string(failed) +
        " tie points could not be triangulated from the a-priori EO (fewer than two rays "
        "or parallel rays); they are left out.");
  }
  estimateRig(dataset, net, source, choice.fido);
  // Pointing-derived models of a gimbal rig share one gimbal point exactly (a pointing error turns the head
  // about it), so a fit that misses their centres by 10x the bound Eq. 3 must meet means the mast is not
  // such a rig (e.g. a tilt axis off the pan axis): holding Eq. 3 would bend the network.
  if (choice.gimbal && source.rig_fit_rms_m > 10.0 * kRigMisfitBound_m) {
    std::ostringstream w;
    w << "The fitted gimbal centre and camera offsets miss the a-priori camera centres by "
      << source.rig_fit_rms_m * 1000.0 << " mm RMS (Eq. 3 must hold to " << kRigMisfitBound_m * 1000.0
      << " mm): the mast does not turn the cameras about one point. For a mast whose tilt axis is off its "
         "pan "
         "axis use --fido --no-gimbal (a virtual spin centre per tier).";
    source.warnings.push_back(w.str());
  }
  net.rig.use_gimbal = choice.gimbal;
  net.rig.use_base = choice.base;
  net.rig.use_spin_centre = choice.fido;
  net.rig.use_lr_distance = choice.fido;
  net.rig.use_datum_prior = choice.datum_prior;
}

namespace {

// Eq. 4's base e: as given, else the mean of M_L (C_R - C_L) over the pairs' a-priori models.
void estimateBase(const Rig& given, Network& net, NetworkSource& source) {
  RigConstraints& rig = net.rig;
  if (given.base_m) {
    rig.base_m = *given.base_m;
  } else {
    Vec3 sum = Vec3::Zero();
    int n = 0;
    for (int p = 0; p < net.pairCount(); ++p) {
      const NetPair& pr = net.pair(p);
      if (pr.right < 0) continue;
      sum += net.image(pr.left).m_apriori *
             (net.image(pr.right).center_apriori_m - net.image(pr.left).center_apriori_m);
      ++n;
    }
    rig.base_m = n > 0 ? Vec3(sum / n) : Vec3::Zero();
    source.estimated.push_back("rig.base_m: absent, estimated from the a-priori models as " +
                               vecText(rig.base_m) + " (mean of M_L (C_R - C_L) over " + std::to_string(n) +
                               " pairs).");
  }
}

// Eq. 3's gimbal centre per sol and camera offsets c: the given ones kept, the missing ones fitted to the
// a-priori models.
void estimateGimbalAndOffsets(const Rig& given, Network& net, NetworkSource& source) {
  RigConstraints& rig = net.rig;
  const int n_sols = static_cast<int>(source.sol_of_index.size());
  const int n_img = net.imageCount();
  // Gimbal centres and offsets: linear least squares of C_i - M_i^T c_side - XG_sol = 0 over the unknowns
  // that are missing (given ones are constants).
  std::vector<bool> gimbal_given(n_sols, false);
  for (int s = 0; s < n_sols; ++s) {
    const auto it = given.gimbal_m.find(source.sol_of_index[s]);
    if (it != given.gimbal_m.end()) {
      rig.gimbal_m[s] = it->second;
      gimbal_given[s] = true;
    }
    rig.gimbal_set[s] = true;
  }
  const bool offsets_given[2] = {given.left_offset_m.has_value(), given.right_offset_m.has_value()};
  if (offsets_given[0]) rig.left_offset_m = *given.left_offset_m;
  if (offsets_given[1]) rig.right_offset_m = *given.right_offset_m;
  std::vector<int> col_gimbal(n_sols, -1);
  int cols = 0;
  for (int s = 0; s < n_sols; ++s) {
    if (!gimbal_given[s]) {
      col_gimbal[s] = cols;
      cols += 3;
    }
  }
  int col_offset[2] = {-1, -1};
  for (int side = 0; side < 2; ++side) {
    if (!offsets_given[side]) {
      col_offset[side] = cols;
      cols += 3;
    }
  }
  if (cols > 0 && n_img > 0) {
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3 * n_img, cols);
    Eigen::VectorXd b(3 * n_img);
    // Fitted relative to the mean camera centre: the minimum-norm choice below must not depend on where
    // the frame's origin lies (a site frame's origin can be hundreds of metres from the rover).
    Vec3 mean_center = Vec3::Zero();
    for (int i = 0; i < n_img; ++i) mean_center += net.image(i).center_apriori_m;
    mean_center /= static_cast<double>(n_img);
    for (int i = 0; i < n_img; ++i) {
      const NetImage& im = net.image(i);
      const int side = im.side == Side::kLeft ? 0 : 1;
      Vec3 rhs = im.center_apriori_m - mean_center;
      if (col_gimbal[im.sol] >= 0) {
        a.block<3, 3>(3 * i, col_gimbal[im.sol]) = Mat3::Identity();
      } else {
        rhs -= rig.gimbal_m[im.sol] - mean_center;
      }
      if (col_offset[side] >= 0) {
        a.block<3, 3>(3 * i, col_offset[side]) = im.m_apriori.transpose();
      } else {
        rhs -= im.m_apriori.transpose() * (side == 0 ? rig.left_offset_m : rig.right_offset_m);
      }
      b.segment<3>(3 * i) = rhs;
    }
    // Minimum norm: a panorama that only pans leaves the vertical offset and gimbal height in trade-off.
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(a);
    cod.setThreshold(1e-9);
    const Eigen::VectorXd x = cod.solve(b);
    const double rms = std::sqrt((a * x - b).squaredNorm() / std::max(1, 3 * n_img));
    for (int s = 0; s < n_sols; ++s) {
      if (col_gimbal[s] < 0) continue;
      rig.gimbal_m[s] = x.segment<3>(col_gimbal[s]) + mean_center;
      source.estimated.push_back("rig.gimbal_m[" + std::to_string(source.sol_of_index[s]) +
                                 "]: absent, fitted to the a-priori camera centres as " +
                                 vecText(rig.gimbal_m[s]) + ".");
    }
    for (int side = 0; side < 2; ++side) {
      if (col_offset[side] < 0) continue;
      Vec3& off = side == 0 ? rig.left_offset_m : rig.right_offset_m;
      off = x.segment<3>(col_offset[side]);
      source.estimated.push_back(std::string(side == 0 ? "rig.left_offset_m" : "rig.right_offset_m") +
                                 ": absent, fitted to the a-priori models as " + vecText(off) + ".");
    }
    if (cod.rank() < cols) {
      source.warnings.push_back("The rig fit is rank deficient (rank " + std::to_string(cod.rank()) + " of " +
                                std::to_string(cols) + "): the minimum-norm rig was used.");
    }
    std::ostringstream s;
    s << "The rig fit leaves " << rms * 1000.0 << " mm RMS at the a-priori camera centres.";
    source.estimated.push_back(s.str());
    source.rig_fit_rms_m = rms;
  }
}

// The FIDO-style values from the a-priori models.
void estimateFidoVariants(Network& net, NetworkSource& source) {
  RigConstraints& rig = net.rig;
  const int n_img = net.imageCount();
  // FIDO variants: a virtual spin centre per tier (sphere fit |C - S|^2 = d^2 over the tier's centres, both
  // sides, linear in S and d^2 - |S|^2), camera-to-centre distances per side, left-right distance.
  double sum_d[2] = {0.0, 0.0};
  int n_d[2] = {0, 0};
  for (int t = 0; t < kMaxTiers; ++t) {
    std::vector<int> members;
    for (int i = 0; i < n_img; ++i) {
      if (net.image(i).tier == t) members.push_back(i);
    }
    if (members.empty()) continue;
    Eigen::MatrixXd a(members.size(), 4);
    Eigen::VectorXd b(members.size());
    for (size_t k = 0; k < members.size(); ++k) {
      const Vec3 c = net.image(members[k]).center_apriori_m;
      a.row(k) << 2.0 * c.x(), 2.0 * c.y(), 2.0 * c.z(), 1.0;
      b(k) = c.squaredNorm();
    }
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(a);
    const Eigen::Vector4d x = cod.solve(b);
    rig.spin_centre_m[t] = x.head<3>();
    rig.spin_centre_set[t] = true;
    for (int i : members) {
      const int side = net.image(i).side == Side::kLeft ? 0 : 1;
      sum_d[side] += (net.image(i).center_apriori_m - rig.spin_centre_m[t]).norm();
      ++n_d[side];
    }
    source.estimated.push_back("FIDO: virtual spin centre of tier " + std::to_string(t) + " fitted as " +
                               vecText(rig.spin_centre_m[t]) + ".");
  }
  rig.left_distance_m = n_d[0] > 0 ? sum_d[0] / n_d[0] : 0.0;
  rig.right_distance_m = n_d[1] > 0 ? sum_d[1] / n_d[1] : rig.left_distance_m;
  double lr = 0.0;
  int n_lr = 0;
  for (int p = 0; p < net.pairCount(); ++p) {
    if (net.pair(p).right < 0) continue;
    lr +=
        (net.image(net.pair(p).right).center_apriori_m - net.image(net.pair(p).left).center_apriori_m).norm();
    ++n_lr;
  }
  rig.lr_distance_m = n_lr > 0 ? lr / n_lr : 0.0;
  rig.sigma_distance_m = rig.sigma_base_m;
  source.estimated.push_back("FIDO: camera-to-centre distances " + std::to_string(rig.left_distance_m) +
                             " / " + std::to_string(rig.right_distance_m) + " m and left-right distance " +
                             std::to_string(rig.lr_distance_m) + " m from the a-priori models.");
}

}  // namespace

void estimateRig(const Dataset& dataset, Network& net, NetworkSource& source, bool fido) {
  applyRigSigmas(dataset.rig, net.rig, &source.estimated);
  estimateBase(dataset.rig, net, source);
  estimateGimbalAndOffsets(dataset.rig, net, source);
  if (fido) estimateFidoVariants(net, source);
}

std::vector<ImageObservation> noisyTruthObservations(const Dataset& dataset, double noise_px, uint64_t seed) {
  std::vector<ImageObservation> observations =
      readObservationsCsv(dataset.root + "/" + kTruthObservationsFile);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (ImageObservation& o : observations) {
    o.sample_px += noise_px * gauss(rng);
    o.line_px += noise_px * gauss(rng);
  }
  return observations;
}

NetworkTruth loadNetworkTruth(const Dataset& dataset, const NetworkSource& source, bool with_points) {
  NetworkTruth truth;
  for (const std::string& stem : source.stems) {
    const std::string path = dataset.root + "/" + kTruthModelsFolder + "/" + stem + ".cahvor";
    if (!std::filesystem::exists(path)) return NetworkTruth{};
    PhotogrammetricCamera cam;
    ConversionResidual residual;
    if (!ok(cahvorToPhotogrammetric(io::readCameraModelFile(path, dataset.width, dataset.height), cam,
                                    residual))) {
      throw cli::InputError(path, "model", "cannot convert the true model");
    }
    truth.centers.push_back(cam.eo.center_m);
    truth.rotations.push_back(cam.m);
  }
  truth.available = true;
  const std::string points_path = dataset.root + "/" + kTruthPointsFile;
  if (with_points && std::filesystem::exists(points_path)) {
    std::map<int64_t, Vec3> truth_of_id;
    for (const CheckPoint& c : readPointsCsv(points_path)) truth_of_id[c.point] = c.site_m;
    for (int64_t id : source.point_ids) {
      const auto it = truth_of_id.find(id);
      truth.points.push_back(it != truth_of_id.end() ? it->second : Vec3::Constant(std::nan("")));
    }
  }
  return truth;
}

}  // namespace areomap::ground
