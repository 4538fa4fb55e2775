// The full-resolution detector sizes of the rover cameras whose records and labels are read here, keyed by
// mission and instrument, so that a model's pixel frame can be told on physical grounds (PixelFrame.hpp):
// the optical axis meets the detector near its centre.
//   Mars 2020 Navcam and Hazcams: 5120 x 3840 (20-Mpixel CMOS; the 1288 x 968 browse tiles are quarters of
//   it at 1/2, the 1280 x 960 frames the whole of it at 1/4).
//   MSL and MER Navcams, Hazcams and (MER) Pancams: 1024 x 1024 (1-Mpixel CCD).
// Another camera is unknown (zero): its frame is then read by the principal point alone.
#pragma once

#include <string>

#include "firmware_core/camera/CameraModel.hpp"

namespace areomap::io {

enum class Mission { kUnknown, kMer, kMsl, kM2020 };

// "MER", "MSL", "M2020" ("" for kUnknown).
const char* missionName(Mission mission);
// The mission of a record or label from what it says of itself: INSTRUMENT_HOST_ID / MISSION_NAME
// ("MER1", "MER2", "MSL", "M20", "M2020", "MARS 2020", "MARS SCIENCE LABORATORY", "MARS EXPLORATION ROVER").
Mission missionFromHost(const std::string& host);
// The mission that a product id's form implies: M2020 ids are a 3-letter camera code, the 4-digit sol and
// the clock ("NLF_0395_0702014201_..."), MSL ids the camera code and the clock ("NLB_424748435EDR_..."),
// MER ids the spacecraft digit 1 or 2, the camera letter and the clock ("1N491020376...").
Mission missionFromProductId(const std::string& product_id);

// The detector size (samples, lines) of `instrument` ("NAVCAM_LEFT", "FRONT_HAZCAM_RIGHT_A", "NAV_LEFT_B",
// ...) on `mission`; zero when unknown.
Vec2 knownDetector(Mission mission, const std::string& instrument);

}  // namespace areomap::io
