// A valid site announcement (site_t, AREOMAP_SITE) of a simulated traverse, site `index` of `planned`:
// sites 10 m apart, 15 degrees of turn a leg, odometry sigmas of 5 % and 2 degrees; a panorama site. Shared
// by the adapters' tests and the fuzz seeds (tests/fuzz/FuzzSeeds.cpp), which change what they test.
#pragma once

#include <cstdint>
#include <string>

#include "areomap/site_t.hpp"

namespace areomap::test {

inline site_t makeSite(int32_t index, int32_t planned) {
  site_t s{};
  s.sequence = index;
  s.traverse = "sim-traverse-1";
  s.site_id = "site0" + std::to_string(index + 1);
  s.site_index = index;
  s.sites_planned = planned;
  s.panorama = "sim-traverse-1-" + s.site_id;
  s.kind = site_t::KIND_PANORAMA;
  s.position_m[0] = 10.0 * index;
  s.heading_deg = 15.0 * index;
  s.has_odometry = index > 0;
  if (index > 0) {
    s.odometry_from = "site0" + std::to_string(index);
    s.delta_m[0] = 10.0;
    s.delta_heading_deg = 15.0;
    s.distance_m = 10.4;
    s.sigma_m[0] = s.sigma_m[1] = 0.5;
    s.sigma_m[2] = 0.1;
    s.sigma_heading_deg = 2.0;
  }
  s.is_last = index == planned - 1;
  return s;
}

}  // namespace areomap::test
