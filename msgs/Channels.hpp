// The LCM channel names of areomap (DESIGN.md "Messages"): one channel carries one message type.
#pragma once

namespace areomap::channels {

constexpr const char* kStereoPair = "AREOMAP_STEREO_PAIR";    // areomap::stereo_pair_t (camera stream)
constexpr const char* kTiePoints = "AREOMAP_TIEPOINTS";       // areomap::tiepoints_t (rover)
constexpr const char* kEoSolution = "AREOMAP_EO_SOLUTION";    // areomap::eo_solution_t (rover)
constexpr const char* kCoarseDem = "AREOMAP_COARSE_DEM";      // areomap::coarse_dem_t (rover)
constexpr const char* kRoverStatus = "AREOMAP_ROVER_STATUS";  // areomap::rover_status_t (rover)
constexpr const char* kProduct = "AREOMAP_PRODUCT";           // areomap::product_t (ground manifest)
constexpr const char* kSite =
    "AREOMAP_SITE";  // areomap::site_t (camera stream: a traverse site, before its pairs)
constexpr const char* kSitePose = "AREOMAP_SITE_POSE";  // areomap::site_pose_t (rover: its site poses)

}  // namespace areomap::channels
