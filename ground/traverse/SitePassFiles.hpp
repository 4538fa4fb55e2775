// A site's pass rebuilt from the folder a finished pass wrote (areomap-traverse --reuse-sites, --resume, and
// --join after the sites' jobs): the one place the traverse reads a pass back from disk; every other step
// works on the SitePass the run made.
#pragma once

#include <memory>
#include <string>

#include "ground/dataset/Traverse.hpp"
#include "ground/pass/GroundPass.hpp"

namespace areomap::traverse {

// Whether `out_dir` holds a finished pass (report.json and models/).
bool hasFinishedPass(const std::string& out_dir);

// The pass of `site` from `out_dir`: the site's dataset and its images and a-priori models (site.dir), the
// adjusted models (models/<stem>.cahvor; an image without one is not in the network), dem.tif,
// dem_sigma.tif and ortho.tif when present, and report.json's figures (method1_px.after, method2_m.after,
// method3_px.after, truth.eo_px; absent ones -1). No network: the solution is its models. nullptr when
// report.json cannot be parsed; throws cli::InputError / DatasetError for an unreadable dataset or model.
std::shared_ptr<const ground::SitePass> loadSitePass(const TraverseSite& site, const std::string& out_dir);

}  // namespace areomap::traverse
