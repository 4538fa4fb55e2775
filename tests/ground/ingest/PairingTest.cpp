// The pairing rule (Pairing.hpp) on frames made here: one exposure's eyes pair, two exposures never do,
// a lone eye is left out with its reason; Mars 2020, MSL and MER id forms.
#include <string>
#include <vector>

#include "ground/ingest/Pairing.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::ingest;

namespace {

Frame frame(const std::string& id, const std::string& instrument, double sclk, int site = 17,
            int drive = 1064) {
  Frame f;
  f.source = id + ".json";
  f.camera.acquisition.product_id = id;
  f.camera.acquisition.instrument = instrument;
  f.camera.acquisition.mission = io::missionFromProductId(id);
  f.camera.acquisition.sclk_s = sclk;
  f.camera.acquisition.site = site;
  f.camera.acquisition.drive = drive;
  f.eye = eyeOf(f.camera);
  return f;
}

}  // namespace

TEST_GROUP(Pairing){};

TEST(Pairing, OneExposurePairsTwoNever) {
  const std::vector<Frame> frames = {
      frame("NLF_0395_0702014201_058ECM_N0171064NCAM03395_01_195J", "NAVCAM_LEFT", 702014201.641),
      frame("NRF_0395_0702014384_287ECM_N0171064NCAM03395_01_195J", "NAVCAM_RIGHT",
            702014385.746),  // other exposure
      frame("NRF_0395_0702014201_058ECM_N0171064NCAM03395_01_195J", "NAVCAM_RIGHT", 702014201.646),
      frame("NLF_0380_0700686262_301ECM_N0112472NCAM03380_01_195J", "NAVCAM_LEFT", 700686264.748),  // lone
  };
  const Pairing p = pairFrames(frames);
  CHECK_EQUAL(1, static_cast<int>(p.pairs.size()));
  CHECK_EQUAL(0, p.pairs[0].left);
  CHECK_EQUAL(2, p.pairs[0].right);
  CHECK_EQUAL(2, static_cast<int>(p.unpaired.size()));
  for (const std::string& why : p.unpaired_reason) CHECK(why.find("an eye without its partner") == 0);
}

// Same id but the eye letter, yet clocks 5 s apart, or another site: not one exposure.
TEST(Pairing, ClockAndPositionMustAgree) {
  const std::string tail = "_0395_0702014201_058ECM_N0171064NCAM03395_01_195J";
  const Pairing late =
      pairFrames({frame("NLF" + tail, "NAVCAM_LEFT", 100.0), frame("NRF" + tail, "NAVCAM_RIGHT", 105.0)});
  CHECK_EQUAL(0, static_cast<int>(late.pairs.size()));
  const Pairing moved = pairFrames(
      {frame("NLF" + tail, "NAVCAM_LEFT", 100.0), frame("NRF" + tail, "NAVCAM_RIGHT", 100.05, 18)});
  CHECK_EQUAL(0, static_cast<int>(moved.pairs.size()));
  const Pairing ok =
      pairFrames({frame("NLF" + tail, "NAVCAM_LEFT", 100.0), frame("NRF" + tail, "NAVCAM_RIGHT", 100.08)});
  CHECK_EQUAL(1, static_cast<int>(ok.pairs.size()));
}

// The same left given twice: one pair, the duplicate left over.
TEST(Pairing, DuplicateEyePairsOnce) {
  const std::string tail = "_0395_0702014201_058ECM_N0171064NCAM03395_01_195J";
  const Pairing p =
      pairFrames({frame("NLF" + tail, "NAVCAM_LEFT", 100.0), frame("NLF" + tail, "NAVCAM_LEFT", 100.0),
                  frame("NRF" + tail, "NAVCAM_RIGHT", 100.01)});
  CHECK_EQUAL(1, static_cast<int>(p.pairs.size()));
  CHECK_EQUAL(1, static_cast<int>(p.unpaired.size()));
}

// MER (eye letter 24th, no instrument needed) and MSL (2nd letter) ids; an id of no known form pairs
// with nothing.
TEST(Pairing, MerAndMslIds) {
  const Pairing mer = pairFrames({frame("2N194463440EFFAPA0P0685L0M1", "", 194463440.0, 125, 100),
                                  frame("2N194463440EFFAPA0P0685R0M1", "", 194463440.0, 125, 100),
                                  frame("2N194463612EFFAPA0P0685R0M1", "", 194463612.0, 125, 100)});
  CHECK_EQUAL(1, static_cast<int>(mer.pairs.size()));
  CHECK_EQUAL(1, static_cast<int>(mer.unpaired.size()));
  CHECK_EQUAL(2, mer.unpaired[0]);
  const Pairing msl = pairFrames({frame("NLB_424748435EDR_F0060560NCAM05104M1", "NAV_LEFT_B", 424748435.0),
                                  frame("NRB_424748435EDR_F0060560NCAM05104M1", "NAV_RIGHT_B", 424748435.0)});
  CHECK_EQUAL(1, static_cast<int>(msl.pairs.size()));
  const Pairing odd =
      pairFrames({frame("left_frame", "NAVCAM_LEFT", 1.0), frame("right_frame", "NAVCAM_RIGHT", 1.0)});
  CHECK_EQUAL(0, static_cast<int>(odd.pairs.size()));
  CHECK(odd.unpaired_reason[0].find("no known mission") != std::string::npos);
}
