#include "ground/ingest/FrameScan.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>

#include <cpl_string.h>
#include <gdal.h>

#include "ground/cli/Cli.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/ingest/Pairing.hpp"
#include "ground/io/GdalLabel.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/io/Pds3Label.hpp"

namespace areomap::ingest {
namespace {

namespace fs = std::filesystem;

enum class Kind { kRecord, kPds3, kGdal, kImage, kOther };

// An input that is readable but no frame to map (left out with the reason, not an error).
struct LeftOut : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

Kind kindOf(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  char head[64] = {};
  f.read(head, sizeof head);
  const std::string text(head, static_cast<std::size_t>(f.gcount()));
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '{') return Kind::kRecord;
  if (io::isGdalLabelFile(path)) return Kind::kGdal;
  const std::string ext = lower(fs::path(path).extension().string());
  if (text.find("PDS_VERSION_ID") != std::string::npos || ext == ".lbl") return Kind::kPds3;
  for (const char* e : {".png", ".jpg", ".jpeg", ".pgm", ".ppm", ".tif", ".tiff", ".img"}) {
    if (ext == e) return Kind::kImage;
  }
  return Kind::kOther;
}

// Every file under the inputs, in name order per folder; missing inputs reported.
std::vector<std::string> expand(const std::vector<std::string>& inputs, std::vector<Skipped>& skipped) {
  std::vector<std::string> files;
  for (const std::string& input : inputs) {
    std::error_code ec;
    if (fs::is_directory(input, ec)) {
      std::vector<std::string> found;
      for (fs::recursive_directory_iterator it(input, ec), end; !ec && it != end; it.increment(ec)) {
        if (it->is_regular_file(ec))
          found.push_back((fs::path(input) / fs::relative(it->path(), input, ec)).string());
      }
      std::sort(found.begin(), found.end());
      files.insert(files.end(), found.begin(), found.end());
    } else if (fs::is_regular_file(input, ec)) {
      files.push_back(input);
    } else {
      skipped.push_back({input, "no such file or folder", true});
    }
  }
  return files;
}

std::string canonical(const std::string& path) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(path, ec);
  return ec ? path : p.string();
}

// The files of a PDS4 or VICAR product as GDAL lists them (the label first, then its data files).
std::vector<std::string> gdalFiles(const std::string& path) {
  GDALAllRegister();
  std::vector<std::string> files;
  GDALDatasetH ds = GDALOpen(path.c_str(), GA_ReadOnly);
  if (ds == nullptr) return files;
  char** list = GDALGetFileList(ds);
  for (char** f = list; f != nullptr && *f != nullptr; ++f) files.push_back(canonical(*f));
  CSLDestroy(list);
  GDALClose(ds);
  return files;
}

Frame readFrame(const std::string& path, Kind kind, std::set<std::string>& consumed) {
  Frame frame;
  frame.source = path;
  if (kind == Kind::kRecord) {
    frame.image_path = io::imageBeside(path);
    if (frame.image_path.empty()) {
      (void)io::readCameraFile(path);  // a corrupt record is named for its own field first
      throw cli::InputError(path, "image", "no image beside the record (X.png, X.jpg, ... for X.json)");
    }
    consumed.insert(canonical(frame.image_path));
    frame.camera = io::readCameraFileForImage(path, frame.image_path);
  } else if (kind == Kind::kPds3) {
    const io::Pds3Label label = io::Pds3Label::read(path);
    if (!label.hasScope("IMAGE") && label.find("^IMAGE", "") == nullptr) {
      throw LeftOut("a label without its image (no IMAGE object): nothing to map");
    }
    frame.image_path = io::readPds3ImageInfo(label).data_file;
    consumed.insert(canonical(frame.image_path));
    frame.camera = io::readPds3Camera(label);
  } else {
    frame.camera = io::readCameraFile(path);
    // GDAL reads the pixels through the label (a PDS4 label names its data file).
    frame.image_path = path;
    for (const std::string& f : gdalFiles(path)) consumed.insert(f);
  }
  frame.stem = pathStem(frame.camera.format == io::CameraFileFormat::kM2020Json ? frame.image_path : path);
  if (frame.camera.acquisition.product_id.empty()) frame.camera.acquisition.product_id = frame.stem;
  frame.eye = eyeOf(frame.camera);
  return frame;
}

}  // namespace

FrameScan scanInputs(const std::vector<std::string>& inputs) {
  FrameScan scan;
  const std::vector<std::string> files = expand(inputs, scan.skipped);
  std::set<std::string> consumed;
  std::vector<std::string> images;
  cli::Progress progress("reading frames", files.size());
  for (const std::string& path : files) {
    const Kind kind = kindOf(path);
    if (kind == Kind::kImage) {
      images.push_back(path);
    } else if (kind == Kind::kOther) {
      scan.skipped.push_back({path, "not a frame: no camera record, PDS3/VICAR/PDS4 label or image", false});
    } else {
      try {
        scan.frames.push_back(readFrame(path, kind, consumed));
      } catch (const LeftOut& e) {
        scan.skipped.push_back({path, e.what(), false});
      } catch (const cli::InputError& e) {
        cli::warn(e.what());
        scan.skipped.push_back({path, e.what(), true});
      }
    }
    progress.step();
  }
  progress.done();
  for (const std::string& path : images) {
    if (consumed.count(canonical(path)) != 0) continue;
    scan.skipped.push_back({path, "an image without a camera model (no record or label beside it)", false});
  }
  return scan;
}

}  // namespace areomap::ingest
