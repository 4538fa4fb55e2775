#include <algorithm>
#include <cmath>
#include <cstdio>
#include <unordered_map>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/dense/DenseMatcher.hpp"
#include "ground/products/ProductStages.hpp"

namespace areomap::products {

namespace {

// floor(exact), from a cheaper estimate within `error` of it: the exact value is made only where the
// estimate lies that near a whole number.
template <typename Exact>
long long floorNear(double estimate, double error, const Exact& exact) {
  const double f = std::floor(estimate);
  if (estimate - f > error && f + 1.0 - estimate > error) return static_cast<long long>(f);
  return static_cast<long long>(std::floor(exact()));
}

// The polar bin of a point (1 m in range x 2 degrees in azimuth about `centre`): range * 1000 + azimuth,
// floor(hypot) and floor((atan2 + pi) / 2 degrees). The floors from sqrt and a float atan2 (errors far
// below the margins: a few ulps, and 1e-6 rad with the float rounding of its arguments), hypot and the
// double atan2 only within those margins of a bin's edge: the same bins, at a fraction of the cost.
long long polarBin(const dem::DemPoint& p, const Vec3& centre) {
  const double dn = p.north_m - centre.x(), de = p.east_m - centre.y();
  constexpr double kBinRad = 2.0 * M_PI / 180.0;
  const auto exact_range = [&] { return std::hypot(dn, de); };
  const auto exact_bin = [&] { return (std::atan2(de, dn) + M_PI) / kBinRad; };
  const double range = std::sqrt(dn * dn + de * de);
  if (!(range > 1e-20 && range < 1e20)) {  // beyond a float's range: the exact values
    return static_cast<long long>(std::floor(exact_range())) * 1000 + static_cast<long long>(std::floor(exact_bin()));
  }
  const long long r = floorNear(range, 1e-12 * (1.0 + range), exact_range);
  const double azimuth = std::atan2(static_cast<float>(de), static_cast<float>(dn));
  const long long a = floorNear((azimuth + M_PI) / kBinRad, 1e-4, exact_bin);
  return r * 1000 + a;
}

// The cloud's chunks for threads (dem::forEachChunk): a multiple of 64 points, so that a chunk's keep bits
// fill whole words.
constexpr std::size_t kOutlierChunk = std::size_t{1} << 20;

// Drops gross outliers before gridding: points whose height sigma exceeds `max_sigma_m`, and points far
// from the median height of their polar bin (polarBin) more than max(0.3 m, 6 MAD-sigmas) away. Mismatches
// at depth edges and near the horizon are such points. In place. The bins' heights are gathered a band of
// whole metres of range at a time, about an eighth of the points each, so that beside the cloud only one
// band's heights are held (all of them would be 4 bytes a point). The passes over the cloud are split
// between threads in chunks; a bin's median and MAD do not depend on the order of its heights, and a
// point's verdict is its own (a bit per point), so the kept points are the same for any thread count.
void dropOutliers(Cloud& cloud, const Vec3& centre, double max_sigma_m, long long& dropped) {
  constexpr std::size_t kMaxBand = 100000;  // metres; farther points share the last band
  const auto range2 = [&centre](const dem::DemPoint& p) {
    const double dn = p.north_m - centre.x(), de = p.east_m - centre.y();
    return dn * dn + de * de;
  };
  const std::size_t chunks = (cloud.size() + kOutlierChunk - 1) / kOutlierChunk;
  std::vector<std::size_t> per_metre;  // points per whole metre of range (sizes the bands only)
  std::size_t counted = 0;
  {
    std::vector<std::vector<std::size_t>> per_chunk(chunks);
    dem::forEachChunk(cloud.dem, kOutlierChunk, [&](std::size_t chunk, std::size_t, const dem::DemPoint& p) {
      if (!(p.sigma_m <= max_sigma_m)) return;
      const std::size_t m = static_cast<std::size_t>(std::min<double>(kMaxBand, std::sqrt(range2(p))));
      std::vector<std::size_t>& counts = per_chunk[chunk];
      if (m >= counts.size()) counts.resize(m + 1, 0);
      ++counts[m];
    });
    for (const std::vector<std::size_t>& counts : per_chunk) {
      if (counts.size() > per_metre.size()) per_metre.resize(counts.size(), 0);
      for (std::size_t m = 0; m < counts.size(); ++m) {
        per_metre[m] += counts[m];
        counted += counts[m];
      }
    }
  }
  std::unordered_map<long long, std::pair<float, float>> stat;  // median, tolerance
  const std::size_t band_points = std::max<std::size_t>(1, counted / 8);
  for (std::size_t lo = 0; lo < per_metre.size();) {
    std::size_t hi = lo, n = per_metre[lo];
    while (hi + 1 < per_metre.size() && n + per_metre[hi + 1] <= band_points) n += per_metre[++hi];
    const bool last = hi + 1 == per_metre.size();
    // Candidates by their squared range, a metre wide on either side; the bin's own range decides.
    const double near2 = lo >= 1 ? static_cast<double>(lo - 1) * static_cast<double>(lo - 1) : 0.0;
    const double far2 = static_cast<double>(hi + 2) * static_cast<double>(hi + 2);
    using Bins = std::unordered_map<long long, std::vector<float>>;
    std::vector<Bins> chunk_bins(chunks);
    dem::forEachChunk(cloud.dem, kOutlierChunk, [&](std::size_t chunk, std::size_t, const dem::DemPoint& p) {
      if (!(p.sigma_m <= max_sigma_m)) return;
      const double r2 = range2(p);
      if (r2 < near2 || (!last && r2 >= far2)) return;
      const long long k = polarBin(p, centre);
      const long long m = k / 1000;
      if (m >= static_cast<long long>(lo) && (last || m <= static_cast<long long>(hi)))
        chunk_bins[chunk][k].push_back(static_cast<float>(p.elevation_m));
    });
    // Each bin's heights (its chunks' parts, in chunk order), median and MAD on threads, a bin per item.
    using Parts = std::vector<const std::vector<float>*>;
    std::unordered_map<long long, Parts> parts;
    for (const Bins& b : chunk_bins) {
      for (const auto& kv : b) parts[kv.first].push_back(&kv.second);
    }
    const std::vector<std::pair<long long, Parts>> bins(parts.begin(), parts.end());
    std::vector<std::pair<float, float>> bin_stat(bins.size());
    cli::parallelFor(bins.size(), 0, [&](std::size_t j) {
      std::vector<float> v;
      for (const std::vector<float>* part : bins[j].second) v.insert(v.end(), part->begin(), part->end());
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      const float med = v[v.size() / 2];
      for (float& x : v) x = std::fabs(x - med);
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      const float mad = v[v.size() / 2];
      bin_stat[j] = {med, std::max(0.3f, 6.0f * 1.4826f * mad)};
    });
    for (std::size_t j = 0; j < bins.size(); ++j) stat[bins[j].first] = bin_stat[j];
    lo = hi + 1;
  }
  std::vector<uint64_t> keep((cloud.size() + 63) / 64, 0);
  dem::forEachChunk(cloud.dem, kOutlierChunk, [&](std::size_t, std::size_t i, const dem::DemPoint& p) {
    if (p.sigma_m > max_sigma_m) return;
    const auto it = stat.find(polarBin(p, centre));
    const std::pair<float, float> st = it != stat.end() ? it->second : std::pair<float, float>{0.f, 0.f};
    if (!(std::fabs(p.elevation_m - st.first) > st.second)) keep[i / 64] |= uint64_t{1} << (i % 64);
  });
  const std::size_t before = cloud.size();
  cloud.dem.keepIf([&keep](std::size_t i, const dem::DemPoint&) { return ((keep[i / 64] >> (i % 64)) & 1u) != 0; },
                   [&cloud](std::size_t from, std::size_t to) { cloud.extra[to] = cloud.extra[from]; });
  dropped = static_cast<long long>(before - cloud.size());
  cloud.extra.resize(cloud.size());
}

}  // namespace

PairDenseInputs pairDenseInputs(const ProductInputs& inputs, const ProductOptions& options,
                                const ProductPair& pair) {
  PairDenseInputs out;
  out.left = sized(inputs.images[pair.left]);
  out.right = sized(inputs.images[pair.right]);
  // Tie observations of the two images per point: pixels for the parallax ranges.
  std::map<int, Vec2> left_px, right_px;
  for (const ProductTie& t : inputs.ties) {
    if (t.image == pair.left) left_px[t.point] = t.pixel_px;
    if (t.image == pair.right) right_px[t.point] = t.pixel_px;
  }
  for (const auto& kv : left_px) {
    const auto it = right_px.find(kv.first);
    if (it == right_px.end()) continue;
    out.left_ties_px.push_back(kv.second);
    out.right_ties_px.push_back(it->second);
  }
  out.options.max_disparity_px = options.dense_max_disparity_px;
  out.options.match_sigma_px = dense::kMatchSigmaPx;  // where a pair's own estimate has too few samples
  out.options.max_range_m = options.max_range_m;
  return out;
}

namespace {

// One pair matched off the run's thread: its cloud (the points within its support range, in the cloud's
// layout) and what the log and the report say of it.
struct MatchedPair {
  dense::PairCloud pc;  // without its points (in `kept`)
  Cloud kept;           // origin: the gimbal centre
};

MatchedPair matchPair(const Context& ctx, const ProductPair& pair, const ProductImage& L,
                      const ProductImage& R) {
  MatchedPair m;
  m.kept = Cloud(ctx.in.gimbal_site_m);
  const PairDenseInputs p = pairDenseInputs(ctx.in, ctx.options, pair);
  // The points go straight into the cloud's layout as they are triangulated (never a pair's cloud of full
  // points); reserved for one point per left pixel (address space: pages are touched as points arrive).
  m.kept.reserve(L.grey.total());
  const Vec3 gimbal = ctx.in.gimbal_site_m;
  const auto keep = [&m, &gimbal](const dense::CloudPoint& c, double support_range_m) {
    if ((c.site_m - gimbal).head<2>().norm() <= support_range_m) m.kept.push(c);
  };
  m.pc = dense::pairCloud(p.left, p.right, L.grey, R.grey, p.left_ties_px, p.right_ties_px, pair.id, p.options,
                          keep);
  if (!m.pc.error.empty()) m.kept.release();
  return m;
}

}  // namespace

Cloud denseCloud(Context& ctx) {
  Cloud cloud(ctx.in.gimbal_site_m);
  {
    // Reserved for the largest possible cloud (address space only: pages are touched as points arrive), so
    // that growing never copies gigabytes or doubles the footprint.
    std::size_t most = 0;
    for (const ProductPair& pair : ctx.in.pairs) {
      if (pair.left >= 0 && pair.left < static_cast<int>(ctx.in.images.size()))
        most += ctx.in.images[pair.left].grey.total();
    }
    cloud.reserve(most);
  }
  double t_rect = 0, t_dense = 0, t_tri = 0;
  std::set<int> sols;
  {
    cli::Progress progress("dense matching", ctx.in.pairs.size());
    const int n_images = static_cast<int>(ctx.in.images.size());
    const auto inside = [n_images](int image) { return image >= 0 && image < n_images; };
    // The pairs are matched in parallel (matchPair: no shared state) and handed on in pair order, so that
    // the cloud, the report and the log are the same for any thread count.
    const auto match = [&](std::size_t i) {
      const ProductPair& pair = ctx.in.pairs[i];
      MatchedPair m;
      if (!inside(pair.left) || !inside(pair.right)) return m;
      const ProductImage& L = ctx.in.images[pair.left];
      const ProductImage& R = ctx.in.images[pair.right];
      if (!unusableReason(L).empty() || !unusableReason(R).empty()) return m;
      m = matchPair(ctx, pair, L, R);
      return m;
    };
    const auto use = [&](std::size_t i, MatchedPair m) {
      const ProductPair& pair = ctx.in.pairs[i];
      progress.step();
      const std::string name = "pair " + std::to_string(pair.id);
      if (!inside(pair.left)) return;
      const bool left_ok = usable(ctx, ctx.in.images[pair.left]);
      if (left_ok) sols.insert(pair.sol);
      if (!inside(pair.right)) return;
      const bool right_ok = usable(ctx, ctx.in.images[pair.right]);
      if (!left_ok || !right_ok) {
        ctx.warn(name + ": not matched (image or model unusable)");
        return;
      }
      const dense::PairCloud& pc = m.pc;
      t_rect += pc.seconds_rectify;
      t_dense += pc.seconds_dense;
      if (!pc.error.empty()) {
        ctx.warn(name + ": " + pc.error);
        return;
      }
      ctx.result.dense_pairs.push_back(ground::DensePairNoise{pair.id, pc.match_noise.sigma_px,
                                                              pc.match_noise.source, pc.match_noise.samples});
      const double t0 = cli::nowSeconds();
      cloud.append(m.kept);
      const long long kept = static_cast<long long>(m.kept.size());
      m.kept.release();
      t_tri += pc.seconds_triangulate + cli::nowSeconds() - t0;
      {
        char b[400];
        std::snprintf(
            b, sizeof b,
            "%s: %zu ties, %.1f %% matched, %lld triangulated (%lld geometry, %lld residual "
            "rejected), %lld kept; matching noise %.3f px (%s, %lld samples), block matches %.3f px "
            "(%s, %lld samples)",
            name.c_str(), pc.ties, 100 * pc.matched_fraction, pc.stats.triangulated,
            pc.stats.rejected_geometry, pc.stats.rejected_residual, kept, pc.match_noise.sigma_px,
            pc.match_noise.source.c_str(), pc.match_noise.samples, pc.block_noise.sigma_px,
            pc.block_noise.source.empty() ? "none" : pc.block_noise.source.c_str(), pc.block_noise.samples);
        cli::info(b);
      }
      if (kept == 0) {
        ctx.warn(name + ": no valid matches triangulated");
        return;
      }
      ++ctx.result.pairs_matched;
    };
    cli::orderedFor(ctx.in.pairs.size(), 0, match, use);
    progress.done();
  }
  ctx.result.seconds.emplace_back("rectify", t_rect);
  ctx.result.seconds.emplace_back("dense", t_dense);
  if (!cloud.empty()) {
    long long dropped = 0;
    dropOutliers(cloud, ctx.in.gimbal_site_m, ctx.options.max_point_sigma_m, dropped);
    cli::info("dense cloud: " + std::to_string(cloud.size()) + " points (" + std::to_string(dropped) +
              " outliers dropped)");
  }
  ctx.result.seconds.emplace_back("triangulate", t_tri);
  ctx.result.points = static_cast<long long>(cloud.size());
  ctx.meta.site = ctx.in.site;
  ctx.meta.sols.assign(sols.begin(), sols.end());

  if (!cloud.empty()) {
    try {
      // Thinned evenly to at most ply_max_points (a full navcam panorama has ~1.7e7 matches, 0.7 GB).
      const std::size_t stride =
          std::max<std::size_t>(1, (cloud.size() + ctx.options.ply_max_points - 1) /
                                       std::max<std::size_t>(1, ctx.options.ply_max_points));
      // Streamed from the cloud (a thinned copy would be 0.24 GB at the peak of the pass).
      const std::size_t count = (cloud.size() + stride - 1) / stride;
      cli::writeViaTemporary(ctx.out_dir + "/points.ply", [&](const std::string& tmp) {
        dense::writePly(
            tmp, count, [&cloud, stride](std::size_t i) { return cloud.cloudPoint(i * stride); },
            "areomap " + ctx.in.site + " site frame; every " + std::to_string(stride) + ". dense point");
      });
      ctx.result.files.push_back(ctx.out_dir + "/points.ply");
    } catch (const std::exception& e) {
      ctx.writeFailed(e);
    }
  } else {
    ctx.warn("no dense points: no points.ply, dem.tif or ortho.tif");
  }

  return cloud;
}

}  // namespace areomap::products
