#include "tests/platform/MessageFixtures.hpp"

#include <string>

namespace areomap::test {

areomap::camera_model_t makeCameraModel(int seed) {
  areomap::camera_model_t m{};
  m.type = areomap::camera_model_t::TYPE_CAHVOR;
  for (int i = 0; i < 3; ++i) {
    m.c_m[i] = 0.1 * seed + i;
    m.a[i] = 0.5 + 0.01 * i;
    m.h_px[i] = 1000.0 + i + seed;
    m.v_px[i] = 2000.0 - i;
    m.o[i] = 0.3 * i;
    m.r[i] = 1e-3 * (i + 1);
    m.e[i] = 0.0;
  }
  m.cahvore_kind = areomap::camera_model_t::CAHVORE_INVALID;
  m.linearity = 1.0;
  m.width_px = 1024;
  m.height_px = 1024;
  return m;
}

namespace {
areomap::stereo_image_t makeImage(int seed, const char* side, int32_t jpeg_bytes) {
  areomap::stereo_image_t image{};
  image.stem = "p" + std::to_string(seed) + "_" + side;
  image.width_px = 1024;
  image.height_px = 1024;
  image.jpeg_bytes = jpeg_bytes;
  image.jpeg.resize(static_cast<std::size_t>(jpeg_bytes));
  for (int32_t i = 0; i < jpeg_bytes; ++i) image.jpeg[i] = static_cast<uint8_t>((i * 31 + seed) & 0xFF);
  image.model = makeCameraModel(seed + (side[0] == 'R' ? 100 : 0));
  return image;
}
}  // namespace

areomap::stereo_pair_t makeStereoPair(int seed, int32_t jpeg_bytes) {
  areomap::stereo_pair_t p{};
  p.utime = 1700000000000000 + seed;
  p.sequence = seed;
  p.kind = areomap::stereo_pair_t::KIND_PAIR;
  p.panorama = "test-panorama";
  p.pair_id = seed;
  p.sol = 3;
  p.tier = seed % 2;
  p.pairs_planned = 64;
  p.has_right = 1;
  p.left = makeImage(seed, "L", jpeg_bytes);
  p.right = makeImage(seed, "R", jpeg_bytes / 2);
  for (int i = 0; i < 3; ++i) {
    p.gimbal_m[i] = 1.5 + i;
    p.left_offset_m[i] = -0.1 * i;
    p.right_offset_m[i] = 0.1 * i;
    p.base_m[i] = i == 0 ? 0.2 : 0.0;
  }
  p.sigma_gimbal_m = 0.001;
  p.sigma_base_m = 0.0005;
  p.gimbal_given = 1;
  p.offsets_given = 0;
  p.base_given = 1;
  p.sigmas_given = 0;
  return p;
}

areomap::tiepoints_t makeTiePoints(int seed, int32_t observations) {
  areomap::tiepoints_t t{};
  t.utime = 1700000000000000 + seed;
  t.sequence = seed;
  t.panorama = "test-panorama";
  t.pair_id = seed;
  t.num_images = 3;
  t.image_stems = {"p000_L", "p000_R", "a_rather_long_image_stem_that_does_not_fit_sso"};
  t.num_observations = observations;
  for (int32_t i = 0; i < observations; ++i) {
    t.point_id.push_back(i / 2);
    t.image_index.push_back(static_cast<int16_t>(i % 3));
    t.sample_px.push_back(10.25 + i);
    t.line_px.push_back(900.5 - i);
    // Unary + : lcm-gen declares the consts without a definition, so they must not be bound to a reference.
    t.kind.push_back(static_cast<int8_t>(i % 5 == 0 ? +areomap::tiepoints_t::KIND_INTER
                                                    : +areomap::tiepoints_t::KIND_INTRA));
  }
  return t;
}

areomap::eo_solution_t makeEoSolution(int seed, int32_t images) {
  areomap::eo_solution_t s{};
  s.utime = 1700000000000000 + seed;
  s.sequence = seed;
  s.panorama = "test-panorama";
  s.last_pair_id = images / 2;
  s.num_images = images;
  for (int32_t i = 0; i < images; ++i) {
    areomap::eo_entry_t e{};
    e.stem = "p" + std::to_string(i / 2) + (i % 2 == 0 ? "_L" : "_R");
    e.pair_id = i / 2;
    e.side = i % 2 == 0 ? areomap::eo_entry_t::SIDE_LEFT : areomap::eo_entry_t::SIDE_RIGHT;
    for (int k = 0; k < 3; ++k) {
      e.center_m[k] = 0.01 * i + k;
      e.sigma_center_m[k] = 1e-4 * (k + 1);
      e.sigma_angles_rad[k] = 1e-5 * (k + 1);
    }
    e.omega_rad = 0.1 * i;
    e.phi_rad = -0.2;
    e.kappa_rad = 3.0;
    e.model = makeCameraModel(i);
    s.images.push_back(e);
  }
  s.sweeps = 7;
  s.iterations = 42;
  s.rms_px = 0.31;
  s.sigma0 = 0.9;
  s.stop_rule = areomap::eo_solution_t::STOP_CONVERGED;
  s.is_final = 1;
  return s;
}

areomap::coarse_dem_t makeCoarseDem(int seed, int32_t rows, int32_t cols) {
  areomap::coarse_dem_t d{};
  d.utime = 1700000000000000 + seed;
  d.sequence = seed;
  d.panorama = "test-panorama";
  d.pair_id = -1;
  d.east0_m = -20.0;
  d.north0_m = 20.0;
  d.cell_m = 0.5;
  d.rows = rows;
  d.cols = cols;
  d.nodata_m = -9999.0f;
  d.num_points = 1234;
  d.num_cells = rows * cols;
  for (int32_t i = 0; i < rows * cols; ++i) d.elevation_m.push_back(i % 7 == 0 ? -9999.0f : 0.01f * i);
  return d;
}

areomap::rover_status_t makeRoverStatus(int seed) {
  areomap::rover_status_t r{};
  r.utime = 1700000000000000 + seed;
  r.sequence = seed;
  r.state = areomap::rover_status_t::STATE_RUNNING;
  r.pairs_seen = 10;
  r.pairs_accepted = 8;
  r.pairs_rejected = 2;
  r.pairs_binned = 1;
  for (int i = 0; i < areomap::rover_status_t::NUM_CAUSES; ++i) r.rejected_by_cause[i] = 0;
  r.rejected_by_cause[areomap::rover_status_t::CAUSE_CORRUPT_DATA] = 1;
  r.rejected_by_cause[areomap::rover_status_t::CAUSE_CAPACITY_EXCEEDED] = 1;
  r.sequence_gaps = 1;
  r.duplicates = 0;
  r.reordered = 2;
  for (int i = 0; i < areomap::rover_status_t::NUM_STAGES; ++i) r.stage_seconds[i] = 0.5 * i;
  r.sweeps = 5;
  r.rms_px = 0.4;
  r.heap_allocs_after_init = 0;
  r.static_bytes = 50 * 1024 * 1024;
  r.last_error = "pair 7: corrupt_data (left JPEG)";
  return r;
}

areomap::product_t makeProduct(int seed, int32_t files) {
  areomap::product_t p{};
  p.utime = 1700000000000000 + seed;
  p.sequence = seed;
  p.panorama = "test-panorama";
  p.out_dir = "/tmp/out";
  p.num_files = files;
  for (int32_t i = 0; i < files; ++i) {
    p.names.push_back("models/p" + std::to_string(i) + "_L.cahvor");
    p.bytes.push_back(1000 + i);
    p.sha256_hex.push_back(std::string(64, static_cast<char>('a' + i % 6)));
  }
  return p;
}

}  // namespace areomap::test
