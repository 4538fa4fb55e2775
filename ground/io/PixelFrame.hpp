// The pixel frame of a camera model relative to the image it is delivered with. A model may come in the
// delivered image's own pixels, or in full-resolution detector pixels while the image is a down-sampled
// and/or cut-out part of the detector (the M2020 raw-image service does both). choosePixelFrame decides
// which from the image's size, the model's principal point and the metadata's scale and subframe origin.
//
// The physical fact used: the optical axis meets the detector near its centre. A candidate frame puts the
// principal point at d (delivered pixels) and the detector's first pixel edge at L = -0.5 - origin / scale
// (the metadata places the image in the detector); the detector is then about 2 (d - L) pixels wide. The
// candidate fits when the image lies inside that detector, the principal point being allowed
// kPrincipalPointTolerance of the detector's size off its centre; it is a full frame when, in addition,
// the image starts at the detector's edge and the principal point lies within that tolerance of the image
// centre. Candidates:
//   F0   the model as given (already in the delivered image's pixels), placed by the metadata;
//   Fm   full-resolution pixels, down-sampled by the metadata's scale from its subframe origin;
//   Fs   full-resolution pixels, down-sampled by s = 1 .. kMaxDownsampling from the subframe origin.
// Rule, first match wins:
//   1. a full frame: F0, then Fm, then the Fs whose principal point lies nearest the image centre
//      (thumbnails whose metadata says nothing of their scale: the M2020 NLF browse image is 1/4);
//   2. a subframe: Fm if it fits (a full-resolution model of a cut-out), else F0 if it fits (a model
//      already in a cut-out's pixels: the M2020 NRF frame, principal point near the image's left edge).
//      A subframe is read at the metadata's scale only: without a full frame the principal point does not
//      tell the scale.
//   3. none: the model fits no frame of this image (an error that lists every candidate).
// Limits. A thumbnail whose metadata does not give its scale is told from its neighbours 1/(s-1), 1/(s+1)
// only while the principal point lies within 1/(4 s) of the detector's size from its centre on at least
// one axis (1.6 % at 1/16; most real cameras are within about 1 %). A delivered-frame model of a cut-out
// that starts at or near the detector's first corner can also be read as full-resolution pixels -- of a
// whole smaller detector at some scale when its principal point then falls near the image centre (rule 1),
// or of a cut-out at the metadata's scale (rule 2) -- and that reading wins: the principal point alone
// cannot tell them apart without the detector's size.
//
// When the detector's size is known (the instrument's, knownDetector in Detector.hpp), that reading is
// settled on physical grounds instead: a candidate places the image in the detector (first pixel at the
// subframe origin, placement_scale detector pixels per delivered pixel) and so puts the principal point at a
// detector pixel; it is physical when that pixel lies within kPrincipalPointTolerance of the detector's size
// from the detector's centre and the image lies inside the detector (the same tolerance past its far edge).
// The physical candidate whose principal point lies nearest the detector's centre wins; candidates that put
// it at the same detector pixel (within half a pixel: a full-resolution model of a thumbnail whose
// metadata omits its scale reads the same as a full-resolution model of a cut-out) are ranked by the rule
// above. No physical candidate: the rule above, with a note that the detector disagrees.
#pragma once

#include <string>

#include "firmware_core/camera/CameraModel.hpp"

namespace areomap::io {

// The optical axis meets the detector within this fraction of its size from its centre. The real Navcams
// in ../shared/data: M2020 NLF 0.4 % / 0.2 % (sample / line), MER Opportunity 1.1 % / 0.9 %, Spirit right
// 0.8 % / 1.3 %, Spirit left 4.1 % / 0.5 % (its O axis is 7.5 deg off A). A wider bound would let a
// delivered-frame cut-out pass for a full frame of a smaller detector more often (rule 1).
constexpr double kPrincipalPointTolerance = 0.05;
// The largest down-sampling tried: 1/64 of a 5120-px detector is an 80-px thumbnail.
constexpr int kMaxDownsampling = 64;

// Delivered pixel = (model pixel - offset_px) / scale.
struct PixelFrame {
  double scale = 1.0;
  Vec2 offset_px = Vec2::Zero();
  std::string name;  // "as given", "1/4 of the detector from (1, 1)", ...
  std::string note;  // non-empty when the known detector fits no candidate and the rule above decided
};

struct FrameEvidence {
  Vec2 principal_px = Vec2::Zero();  // (A.H, A.V) of the model as the file gives it
  int width = 0;                     // the delivered image
  int height = 0;
  int meta_scale = 1;                    // the metadata's down-sampling (M2020 scale_factor)
  Vec2 meta_origin_px = Vec2(1.0, 1.0);  // the subframe's first sample and line, 1-based detector pixels
  Vec2 detector_px = Vec2::Zero();       // the detector's full-resolution size; zero = unknown
};

// The frame by the rule above: true and `frame`; false and `tried`, one clause per candidate with the size
// of the model's frame and why it does not fit.
bool choosePixelFrame(const FrameEvidence& evidence, PixelFrame& frame, std::string& tried);

}  // namespace areomap::io
