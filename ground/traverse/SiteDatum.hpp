// How well a site's adjusted cameras know their common rotation: the datum of its pass (DESIGN.md
// "Datum": with no ground control the adjustment keeps the mean a-priori pointing). That mean carries the
// a-priori pointing errors averaged over the site's independent pointings, so the camera set of a site is
// rotated against its levelled site frame by about s / sqrt(n), where s is the scatter of the pass's
// per-pair rotation corrections (adjusted against a-priori models) and n the number of pairs (a stereo
// pair is one pointing of the mast). Two sites' camera sets are then tilted against each other by more
// than the levelling of their frames: the multi-site adjustment widens the legs' tilt and heading sigmas
// by both sites' datum sigmas (CrossSiteAdjustment.cpp), from each dataset's own figures, not a constant.
// The estimate assumes the pairs' pointing errors independent; a bias common to every pointing (a mast
// calibration error) is not seen by it.
#pragma once

#include <string>
#include <vector>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/pass/GroundPass.hpp"

namespace areomap::traverse {

struct SiteDatum {
  bool known = false;               // false: fewer than 2 pairs with both models (sigma left 0)
  int pairs = 0;                    // pairs with a-priori and adjusted models
  Vec3 scatter_rad = Vec3::Zero();  // per axis of the site frame (x north, y east, z down): s
  Vec3 sigma_rad = Vec3::Zero();    // the datum's: s / sqrt(pairs)
};

// One image of a site as its pass left it: its pair (index in the dataset), its a-priori and adjusted model
// (site frame).
struct SiteCamera {
  std::string stem;
  int pair_index = 0;
  CameraModel apriori, adjusted;
};
using SiteCameras = std::vector<SiteCamera>;  // in the dataset's pair order

// The cameras of a finished pass: every dataset image the pass adjusted.
SiteCameras siteCameras(const ground::SitePass& pass);
// The same from files: the site's a-priori models from its dataset (site.dir) and the adjusted ones in
// models_dir (<stem>.cahvor); an image without an adjusted model is left out. Throws cli::InputError for an
// unreadable dataset or model.
SiteCameras readSiteCameras(const TraverseSite& site, const std::string& models_dir);

// The site's a-priori models against its adjusted ones.
SiteDatum siteDatum(const SiteCameras& cameras);

}  // namespace areomap::traverse
