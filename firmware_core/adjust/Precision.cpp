#include "firmware_core/adjust/Precision.hpp"

#include <cmath>

namespace areomap {

namespace {

// The stereo views of one point: per pair (up to kMaxObsPerPoint), its left and right observation.
struct PairViews {
  int32_t pair[kMaxObsPerPoint];
  int32_t left_obs[kMaxObsPerPoint];
  int32_t right_obs[kMaxObsPerPoint];
  int32_t count = 0;
};

void collectViews(const Network& net, const NetPoint& pt, PairViews& v) {
  v.count = 0;
  if (!pt.solvable) return;  // the measures use the tie points that the adjustment uses
  for (int32_t k = 0; k < pt.obs_count; ++k) {
    const NetObservation& o = net.observation(pt.obs[k]);
    if (o.rejected) continue;
    const NetImage& im = net.image(o.image);
    int32_t slot = -1;
    for (int32_t s = 0; s < v.count; ++s) {
      if (v.pair[s] == im.pair) slot = s;
    }
    if (slot < 0) {
      slot = v.count++;
      v.pair[slot] = im.pair;
      v.left_obs[slot] = -1;
      v.right_obs[slot] = -1;
    }
    if (im.side == Side::kLeft) {
      v.left_obs[slot] = pt.obs[k];
    } else {
      v.right_obs[slot] = pt.obs[k];
    }
  }
}

bool triangulatePair(const Network& net, const PairViews& v, int32_t slot, Vec3& xyz) {
  if (v.left_obs[slot] < 0 || v.right_obs[slot] < 0) return false;
  const int32_t obs[2] = {v.left_obs[slot], v.right_obs[slot]};
  Vec3 origins[2], dirs[2];
  for (int32_t s = 0; s < 2; ++s) {
    const NetObservation& o = net.observation(obs[s]);
    const NetImage& im = net.image(o.image);
    origins[s] = im.centre_m;
    dirs[s] = rayOfIdealPixel(im.io, im.m, o.ideal_px);
  }
  return ok(intersectRays(origins, dirs, 2, xyz));
}

void addImageDifference(ImageDifferences& d, const Vec2& diff) {
  d.x += std::fabs(diff.x());
  d.y += std::fabs(diff.y());
  d.dist += diff.norm();
  ++d.count;
}

void finish(ImageDifferences& d) {
  if (d.count == 0) return;
  d.x /= d.count;
  d.y /= d.count;
  d.dist /= d.count;
}

}  // namespace

ImageDifferences precisionMethod1(const Network& net) {
  ImageDifferences d;
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    const NetObservation& o = net.observation(k);
    if (o.rejected || !net.point(o.point).solvable) continue;
    const NetImage& im = net.image(o.image);
    Vec2 pixel;
    if (!ok(collinearity(im.io, im.centre_m, im.m, net.point(o.point).xyz_m, pixel))) continue;
    addImageDifference(d, o.ideal_px - pixel);
  }
  finish(d);
  return d;
}

GroundDifferences precisionMethod2(const Network& net) {
  GroundDifferences d;
  PairViews v;
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    collectViews(net, net.point(p), v);
    if (v.count < 2) continue;
    Vec3 first;
    int32_t first_slot = -1;
    for (int32_t s = 0; s < v.count; ++s) {
      Vec3 xyz;
      if (!triangulatePair(net, v, s, xyz)) continue;
      if (first_slot < 0) {
        first = xyz;
        first_slot = s;
        continue;
      }
      const Vec3 diff = xyz - first;
      d.x += std::fabs(diff.x());
      d.y += std::fabs(diff.y());
      d.z += std::fabs(diff.z());
      ++d.count;
    }
  }
  if (d.count > 0) {
    d.x /= d.count;
    d.y /= d.count;
    d.z /= d.count;
  }
  return d;
}

ImageDifferences precisionMethod3(const Network& net) {
  ImageDifferences d;
  PairViews v;
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    collectViews(net, net.point(p), v);
    if (v.count < 2) continue;
    for (int32_t a = 0; a < v.count; ++a) {
      Vec3 xyz;
      if (!triangulatePair(net, v, a, xyz)) continue;
      for (int32_t b = 0; b < v.count; ++b) {
        if (b == a) continue;
        const int32_t obs[2] = {v.left_obs[b], v.right_obs[b]};
        for (int32_t s = 0; s < 2; ++s) {
          if (obs[s] < 0) continue;
          const NetObservation& o = net.observation(obs[s]);
          const NetImage& im = net.image(o.image);
          Vec2 pixel;
          if (!ok(collinearity(im.io, im.centre_m, im.m, xyz, pixel))) continue;
          addImageDifference(d, o.ideal_px - pixel);
        }
      }
    }
  }
  finish(d);
  return d;
}

TiePointCounts countTiePoints(const Network& net) {
  TiePointCounts c;
  PairViews v;
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    collectViews(net, net.point(p), v);
    if (v.count >= 2) {
      ++c.inter;
    } else if (v.count == 1) {
      ++c.intra;
    }
  }
  for (int32_t k = 0; k < net.observationCount(); ++k) c.rejected += net.observation(k).rejected ? 1 : 0;
  return c;
}

}  // namespace areomap
