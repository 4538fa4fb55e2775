// Left and right eyes of one exposure, never of two.
//
// Rule. A frame's eye is its instrument's LEFT / RIGHT (NAVCAM_LEFT, NAV_RIGHT_B, ...), else its product
// id's eye letter. Its exposure is its product id with the eye letter taken out: Mars 2020 and MSL ids carry
// the eye as their second letter ("NLF_0395_0702014201_..." / "NRF_0395_0702014201_...": the rest, the clock
// included, is shared), MER ids as their 24th ("1N491020376ILFCNY9P0706L0M1" / "...R0M1"). Two frames pair
// when their exposures are equal, their eyes differ, and where both give them, their spacecraft clocks
// differ by at most kMaxEyeClockDifferenceS and their sol, site and drive agree. Several candidates of one
// exposure (the same product given twice, or two versions of it) pair by the nearest clocks; an eye left
// over has no partner. A product id of another form pairs with nothing.
#pragma once

#include <string>
#include <vector>

#include "ground/ingest/FrameScan.hpp"

namespace areomap::ingest {

// The two eyes of one exposure are read out within a fraction of a second (the Mars 2020 right Navcam
// 0-0.08 s after the left); two exposures of a stereo pair sequence are seconds apart.
constexpr double kMaxEyeClockDifferenceS = 1.0;

Eye eyeOf(const io::CameraFile& camera);
// The product id with the eye letter taken out; "" when the id's form is unknown (it pairs with nothing).
std::string exposureKey(const io::Acquisition& acquisition);

struct StereoPair {
  int left = -1;  // indices into the frames
  int right = -1;
};

struct Pairing {
  std::vector<StereoPair> pairs;
  std::vector<int> unpaired;                 // frames with no partner
  std::vector<std::string> unpaired_reason;  // per unpaired frame
};

Pairing pairFrames(const std::vector<Frame>& frames);

}  // namespace areomap::ingest
