#include "ground/dataset/Dataset.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>

#include <nlohmann/json.hpp>

#include "ground/dataset/JsonFields.hpp"
#include "ground/dataset/RigSigmas.hpp"

namespace areomap {
namespace {

using Json = nlohmann::json;
using OrderedJson = nlohmann::ordered_json;  // the writer keeps the contract's key order
using Reader = JsonFieldReader;

OrderedJson vecJson(const Eigen::Vector3d& v) {
  return OrderedJson::array({v.x(), v.y(), v.z()});
}

ImageRef readImageRef(const Reader& r, const Json& side, const std::string& field, const std::string& root) {
  if (!side.is_object()) r.fail(field, "expected an object with \"image\" (and optionally \"model\")");
  if (!side.contains("image")) r.fail(field + ".image", "missing (required)");
  const std::string image = r.safePath(side["image"], field + ".image");
  std::optional<std::string> model;
  if (side.contains("model") && !side["model"].is_null()) model = r.safePath(side["model"], field + ".model");
  ImageRef ref = makeImageRef(root, image, model);
  if (ref.stem.empty()) r.fail(field + ".image", "no file name: '" + image + "'");
  return ref;
}

OrderedJson imageRefJson(const ImageRef& ref, const std::string& field) {
  std::string why;
  if (!isSafeRelativePath(ref.image, why)) throw DatasetError(kPanoramaFileName, field + ".image", why);
  OrderedJson j = {{"image", ref.image}};
  if (ref.model) {
    if (!isSafeRelativePath(*ref.model, why)) throw DatasetError(kPanoramaFileName, field + ".model", why);
    j["model"] = *ref.model;
  }
  return j;
}

// "name", defaulted to the dataset folder's name.
void readName(const Reader& r, const Json& root, Dataset& ds) {
  if (root.contains("name") && !root["name"].is_null()) {
    ds.name = r.string(root["name"], "name");
  } else {
    ds.name = std::filesystem::path(ds.root).lexically_normal().filename().string();
    if (ds.name.empty())
      ds.name = std::filesystem::path(ds.root).lexically_normal().parent_path().filename().string();
    ds.notes.push_back("name: absent, defaulted to the folder name '" + ds.name + "'");
  }
}

// "image_size": [width, height], both positive; absent, the images give it.
void readImageSize(const Reader& r, const Json& root, Dataset& ds) {
  if (root.contains("image_size") && !root["image_size"].is_null()) {
    const Json& s = root["image_size"];
    if (!s.is_array() || s.size() != 2) r.fail("image_size", "expected [width, height] (samples, lines)");
    ds.width = r.integer(s[0], "image_size[0]");
    ds.height = r.integer(s[1], "image_size[1]");
    if (ds.width <= 0) r.fail("image_size[0]", "width must be positive");
    if (ds.height <= 0) r.fail("image_size[1]", "height must be positive");
  } else {
    ds.notes.push_back("image_size: absent, to be read from the images");
  }
}

// "rig.gimbal_m": {"<sol>": [x, y, z]}, the keys sol numbers.
void readGimbalCentres(const Reader& r, const Json& g, Dataset& ds) {
  if (!g.is_object()) r.fail("rig.gimbal_m", "expected an object {\"<sol>\": [x, y, z]}");
  for (auto it = g.begin(); it != g.end(); ++it) {
    const std::string field = "rig.gimbal_m." + it.key();
    char* end = nullptr;
    errno = 0;
    const long sol = std::strtol(it.key().c_str(), &end, 10);
    if (it.key().empty() || *end != '\0' || errno != 0 || sol < -1000000 || sol > 1000000) {
      r.fail(field, "the key must be a sol number");
    }
    ds.rig.gimbal_m[static_cast<int>(sol)] = r.vec3(it.value(), field);
  }
}

// "rig": every value optional (noteRigDefaults says what the absent ones become); sigmas positive.
void readRig(const Reader& r, const Json& root, Dataset& ds) {
  if (!root.contains("rig") || root["rig"].is_null()) return;
  const Json& rig = root["rig"];
  if (!rig.is_object()) r.fail("rig", "expected an object");
  if (rig.contains("gimbal_m") && !rig["gimbal_m"].is_null()) readGimbalCentres(r, rig["gimbal_m"], ds);
  if (rig.contains("left_offset_m") && !rig["left_offset_m"].is_null())
    ds.rig.left_offset_m = r.vec3(rig["left_offset_m"], "rig.left_offset_m");
  if (rig.contains("right_offset_m") && !rig["right_offset_m"].is_null())
    ds.rig.right_offset_m = r.vec3(rig["right_offset_m"], "rig.right_offset_m");
  if (rig.contains("base_m") && !rig["base_m"].is_null()) ds.rig.base_m = r.vec3(rig["base_m"], "rig.base_m");
  if (rig.contains("sigma_gimbal_m") && !rig["sigma_gimbal_m"].is_null()) {
    ds.rig.sigma_gimbal_m = r.number(rig["sigma_gimbal_m"], "rig.sigma_gimbal_m");
    if (*ds.rig.sigma_gimbal_m <= 0.0) r.fail("rig.sigma_gimbal_m", "must be positive");
  }
  if (rig.contains("sigma_base_m") && !rig["sigma_base_m"].is_null()) {
    ds.rig.sigma_base_m = r.number(rig["sigma_base_m"], "rig.sigma_base_m");
    if (*ds.rig.sigma_base_m <= 0.0) r.fail("rig.sigma_base_m", "must be positive");
  }
}

// How many pairs took a default, for the notes.
struct PairDefaults {
  int sol = 0, tier = 0, id = 0, model_absent = 0;
};

// One entry of "pairs" (`index` in the list): id (the index when absent, unique), sol, tier (>= 0), left and
// optional right image with unique stems.
Pair readPair(const Reader& r, const Json& p, std::size_t index, const std::string& root, std::set<int>& ids,
              std::map<std::string, std::string>& stems, PairDefaults& defaults) {
  const std::string field = "pairs[" + std::to_string(index) + "]";
  if (!p.is_object()) r.fail(field, "expected an object");
  Pair pair;
  if (p.contains("id") && !p["id"].is_null()) {
    pair.id = r.integer(p["id"], field + ".id");
  } else {
    pair.id = static_cast<int>(index);
    ++defaults.id;
  }
  if (!ids.insert(pair.id).second) r.fail(field + ".id", "duplicate id " + std::to_string(pair.id));
  if (p.contains("sol") && !p["sol"].is_null()) {
    pair.sol = r.integer(p["sol"], field + ".sol");
  } else {
    ++defaults.sol;
  }
  if (p.contains("tier") && !p["tier"].is_null()) {
    pair.tier = r.integer(p["tier"], field + ".tier");
    if (pair.tier < 0) r.fail(field + ".tier", "must be >= 0");
  } else {
    ++defaults.tier;
  }
  if (!p.contains("left")) r.fail(field + ".left", "missing (required)");
  pair.left = readImageRef(r, p["left"], field + ".left", root);
  if (p.contains("right") && !p["right"].is_null())
    pair.right = readImageRef(r, p["right"], field + ".right", root);
  const ImageRef* sides[2] = {&pair.left, pair.right ? &*pair.right : nullptr};
  const char* side_names[2] = {".left", ".right"};
  for (int s = 0; s < 2; ++s) {
    if (sides[s] == nullptr) continue;
    const std::string f = field + side_names[s] + ".image";
    const auto [it, inserted] = stems.emplace(sides[s]->stem, f);
    if (!inserted) {
      r.fail(f, "image stem '" + sides[s]->stem + "' is already used by " + it->second +
                    " (files are named after stems, so stems must be unique)");
    }
    if (!sides[s]->model) ++defaults.model_absent;
  }
  return pair;
}

// "pairs": a non-empty list; a note for each default taken.
void readPairs(const Reader& r, const Json& root, Dataset& ds) {
  if (!root.contains("pairs")) r.fail("pairs", "missing (required: a list of stereo pairs)");
  const Json& pairs = root["pairs"];
  if (!pairs.is_array()) r.fail("pairs", "expected an array");
  if (pairs.empty()) r.fail("pairs", "empty: at least one pair is needed");
  std::set<int> ids;
  std::map<std::string, std::string> stems;  // stem -> field that used it
  PairDefaults d;
  for (std::size_t i = 0; i < pairs.size(); ++i)
    ds.pairs.push_back(readPair(r, pairs[i], i, ds.root, ids, stems, d));
  if (d.id > 0)
    ds.notes.push_back("pairs[].id: absent for " + std::to_string(d.id) +
                       " pair(s), defaulted to the list index");
  if (d.sol > 0)
    ds.notes.push_back("pairs[].sol: absent for " + std::to_string(d.sol) + " pair(s), defaulted to 0");
  if (d.tier > 0)
    ds.notes.push_back("pairs[].tier: absent for " + std::to_string(d.tier) + " pair(s), defaulted to 0");
  if (d.model_absent > 0)
    ds.notes.push_back("model: absent for " + std::to_string(d.model_absent) +
                       " image(s), to be read from the PDS3 label");
}

}  // namespace

// A note for every rig value the dataset leaves to be estimated or held.
void noteRigDefaults(Dataset& ds) {
  std::set<int> sols;
  for (const Pair& p : ds.pairs) sols.insert(p.sol);
  for (int sol : sols) {
    if (ds.rig.gimbal_m.count(sol) == 0) {
      ds.notes.push_back("rig.gimbal_m." + std::to_string(sol) +
                         ": absent, to be estimated from the a-priori models");
    }
  }
  if (!ds.rig.left_offset_m)
    ds.notes.push_back("rig.left_offset_m: absent, to be estimated from the a-priori models");
  if (!ds.rig.right_offset_m)
    ds.notes.push_back("rig.right_offset_m: absent, to be estimated from the a-priori models");
  if (!ds.rig.base_m) ds.notes.push_back("rig.base_m: absent, to be estimated from the a-priori models");
  if (!ds.rig.sigma_gimbal_m) ds.notes.push_back(heldSigmaNote("rig.sigma_gimbal_m"));
  if (!ds.rig.sigma_base_m) ds.notes.push_back(heldSigmaNote("rig.sigma_base_m"));
}

int Dataset::imageCount() const {
  int n = 0;
  for (const Pair& p : pairs) n += p.right ? 2 : 1;
  return n;
}

bool Dataset::findStem(const std::string& stem, int& pair_index, bool& is_right) const {
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    if (pairs[i].left.stem == stem) {
      pair_index = static_cast<int>(i);
      is_right = false;
      return true;
    }
    if (pairs[i].right && pairs[i].right->stem == stem) {
      pair_index = static_cast<int>(i);
      is_right = true;
      return true;
    }
  }
  return false;
}

bool isSafeRelativePath(const std::string& path, std::string& why) {
  if (path.empty()) {
    why = "empty path";
    return false;
  }
  if (path.front() == '/' || path.front() == '\\' || (path.size() > 1 && path[1] == ':')) {
    why = "absolute paths are not allowed (paths are relative to the dataset folder)";
    return false;
  }
  if (path.find('\0') != std::string::npos) {
    why = "NUL character in path";
    return false;
  }
  std::size_t start = 0;
  while (start <= path.size()) {
    std::size_t end = path.find_first_of("/\\", start);
    if (end == std::string::npos) end = path.size();
    if (path.compare(start, end - start, "..") == 0 && end - start == 2) {
      why = "'..' components are not allowed (paths must stay inside the dataset folder)";
      return false;
    }
    start = end + 1;
  }
  return true;
}

std::string pathStem(const std::string& path) {
  const std::size_t slash = path.find_last_of("/\\");
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const std::size_t dot = name.find_last_of('.');
  if (dot == std::string::npos || dot == 0) return name;
  return name.substr(0, dot);
}

ImageRef makeImageRef(const std::string& root, const std::string& image,
                      const std::optional<std::string>& model) {
  ImageRef ref;
  ref.image = image;
  ref.image_path = resolvePath(root, image);
  ref.stem = pathStem(image);
  ref.model = model;
  if (model) ref.model_path = resolvePath(root, *model);
  return ref;
}

Dataset readDataset(const std::string& dir) {
  const std::string file = joinPath(dir, kPanoramaFileName);
  const Reader r(file);
  const Json root = parseJsonFile(r, file);
  Dataset ds;
  ds.root = dir;
  readName(r, root, ds);
  readImageSize(r, root, ds);
  readRig(r, root, ds);
  readPairs(r, root, ds);
  noteRigDefaults(ds);
  return ds;
}

void writeDataset(const Dataset& ds, const std::string& dir) {
  const std::string file = joinPath(dir, kPanoramaFileName);
  OrderedJson root = OrderedJson::object();
  if (!ds.name.empty()) root["name"] = ds.name;
  if (ds.width > 0 && ds.height > 0) root["image_size"] = Json::array({ds.width, ds.height});
  OrderedJson rig = OrderedJson::object();
  if (!ds.rig.gimbal_m.empty()) {
    OrderedJson g = OrderedJson::object();
    for (const auto& [sol, centre] : ds.rig.gimbal_m) g[std::to_string(sol)] = vecJson(centre);
    rig["gimbal_m"] = g;
  }
  if (ds.rig.left_offset_m) rig["left_offset_m"] = vecJson(*ds.rig.left_offset_m);
  if (ds.rig.right_offset_m) rig["right_offset_m"] = vecJson(*ds.rig.right_offset_m);
  if (ds.rig.base_m) rig["base_m"] = vecJson(*ds.rig.base_m);
  if (ds.rig.sigma_gimbal_m) rig["sigma_gimbal_m"] = *ds.rig.sigma_gimbal_m;
  if (ds.rig.sigma_base_m) rig["sigma_base_m"] = *ds.rig.sigma_base_m;
  if (!rig.empty()) root["rig"] = rig;
  OrderedJson pairs = OrderedJson::array();
  for (std::size_t i = 0; i < ds.pairs.size(); ++i) {
    const Pair& p = ds.pairs[i];
    const std::string field = "pairs[" + std::to_string(i) + "]";
    OrderedJson j = {
        {"id", p.id}, {"sol", p.sol}, {"tier", p.tier}, {"left", imageRefJson(p.left, field + ".left")}};
    if (p.right) j["right"] = imageRefJson(*p.right, field + ".right");
    pairs.push_back(j);
  }
  root["pairs"] = pairs;

  writeJsonFile(dir, file, root.dump(2));
}

void checkDatasetFiles(const Dataset& ds, bool images, bool models) {
  const std::string file = joinPath(ds.root, kPanoramaFileName);
  for (std::size_t i = 0; i < ds.pairs.size(); ++i) {
    const Pair& p = ds.pairs[i];
    const ImageRef* sides[2] = {&p.left, p.right ? &*p.right : nullptr};
    const char* side_names[2] = {".left", ".right"};
    for (int s = 0; s < 2; ++s) {
      if (sides[s] == nullptr) continue;
      const std::string field = "pairs[" + std::to_string(i) + "]" + side_names[s];
      std::error_code ec;
      if (images && !std::filesystem::is_regular_file(sides[s]->image_path, ec)) {
        throw DatasetError(file, field + ".image", "file not found: " + sides[s]->image_path);
      }
      if (models && sides[s]->model && !std::filesystem::is_regular_file(sides[s]->model_path, ec)) {
        throw DatasetError(file, field + ".model", "file not found: " + sides[s]->model_path);
      }
    }
  }
}

}  // namespace areomap
