// The frames among a list of inputs (files, and folders recursed): every camera record or label with its
// pixels -- a Mars 2020 raw-image record (X.json, X-metadata.json) with its image beside it (X.png, ...), a
// PDS3 product (.IMG with an attached label, or a .LBL with its data file), a VICAR product, a PDS4 label
// (.xml) with its data file -- read into a Frame; every other input is left out with its reason.
#pragma once

#include <string>
#include <vector>

#include "ground/io/CameraFile.hpp"

namespace areomap::ingest {

enum class Eye { kLeft, kRight, kUnknown };

struct Frame {
  std::string source;      // the input as given (a file given, or the folder given joined with the file)
  std::string image_path;  // where the pixels are (the source itself for .IMG, VICAR)
  std::string stem;        // names the frame's image and model in a dataset: the image file's stem
  io::CameraFile camera;   // the model in the delivered image's pixels, in camera.reference_frame
  Eye eye = Eye::kUnknown;
};

struct Skipped {
  std::string input;
  std::string reason;
  bool error = false;  // a bad file (unreadable label or record, missing or corrupt image), not a choice
};

struct FrameScan {
  std::vector<Frame> frames;
  std::vector<Skipped> skipped;
};

// Reads every frame of `inputs` (folders recursed, files in name order). A file that fails is a Skipped
// with error = true and the message (file and field); the others go on.
FrameScan scanInputs(const std::vector<std::string>& inputs);

}  // namespace areomap::ingest
