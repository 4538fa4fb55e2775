// Fuzz target: the AREOMAP_SITE decoder (a traverse's site announcement) as the rover and the ground read it:
// msgs/adapters decodeSite (checkEncoding, the longest string against the reserved capacity, decode() into a
// site_t prepared once, checkSite). Input: the encoded site_t. Invariants: decodeSite never throws; a
// message it decodes never grows a reserved string (no heap on the rover); what checkSite accepts has
// the index inside the traverse, finite numbers and positive odometry sigmas.
#include <cmath>
#include <string>

#include "areomap/site_t.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "msgs/MessageCheck.hpp"
#include "msgs/adapters/MessageAdapters.hpp"
#include "tests/fuzz/FuzzSupport.hpp"

namespace {

using areomap::fuzz::fail;

bool finite3(const double v[3]) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  // One message object prepared at start-up and reused, as the rover holds it.
  static areomap::site_t site = [] {
    areomap::site_t s;
    areomap::prepareSite(s);
    return s;
  }();
  const std::size_t capacities[4] = {site.traverse.capacity(), site.site_id.capacity(),
                                     site.panorama.capacity(), site.odometry_from.capacity()};
  const char* field = "";
  const areomap::Status status = areomap::decodeSite(data, size, site, field);
  if (field == nullptr) fail("site", "decodeSite left no field name");
  const std::size_t after[4] = {site.traverse.capacity(), site.site_id.capacity(), site.panorama.capacity(),
                                site.odometry_from.capacity()};
  for (int k = 0; k < 4; ++k) {
    if (after[k] != capacities[k]) fail("site", "decoding a site announcement grew a reserved string (heap)");
  }
  // checkEncoding alone agrees with the generated decode() on what is a whole message.
  areomap::site_t plain;
  const areomap::Status checked = areomap::msgs::decodeMessage(data, size, plain);
  if (areomap::ok(status) && !areomap::ok(checked))
    fail("site", "decodeSite accepted bytes decodeMessage refuses");
  if (!areomap::ok(status)) return 0;
  if (site.site_index < 0 || site.site_index >= site.sites_planned ||
      site.sites_planned > areomap::kMaxGroundSites)
    fail("site", "an accepted site index lies outside the traverse");
  if (!finite3(site.position_m) || !std::isfinite(site.heading_deg))
    fail("site", "an accepted a-priori pose is not finite");
  if (site.has_odometry && !(site.sigma_m[0] > 0.0 && site.sigma_m[1] > 0.0 && site.sigma_m[2] > 0.0 &&
                             site.sigma_heading_deg > 0.0))
    fail("site", "accepted odometry sigmas are not positive");
  if (site.site_id.empty() || site.panorama.empty())
    fail("site", "an accepted site has no id or no panorama");
  return 0;
}
