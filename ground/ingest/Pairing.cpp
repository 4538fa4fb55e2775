#include "ground/ingest/Pairing.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace areomap::ingest {
namespace {

// The index of the eye letter in a product id of `mission`, or -1.
int eyeLetterIndex(const io::Acquisition& a) {
  const std::string& id = a.product_id;
  switch (a.mission) {
    case io::Mission::kM2020:
    case io::Mission::kMsl:
      return id.size() > 4 ? 1 : -1;
    case io::Mission::kMer:
      return id.size() >= 27 ? 23 : -1;
    case io::Mission::kUnknown:
      break;
  }
  return -1;
}

template <typename T>
bool disagree(const std::optional<T>& a, const std::optional<T>& b) {
  return a && b && *a != *b;
}

bool compatible(const Frame& l, const Frame& r) {
  const io::Acquisition& a = l.camera.acquisition;
  const io::Acquisition& b = r.camera.acquisition;
  if (a.sclk_s && b.sclk_s && std::fabs(*a.sclk_s - *b.sclk_s) > kMaxEyeClockDifferenceS) return false;
  return !disagree(a.sol, b.sol) && !disagree(a.site, b.site) && !disagree(a.drive, b.drive);
}

double clockGap(const Frame& l, const Frame& r) {
  const io::Acquisition& a = l.camera.acquisition;
  const io::Acquisition& b = r.camera.acquisition;
  return a.sclk_s && b.sclk_s ? std::fabs(*a.sclk_s - *b.sclk_s) : 0.0;
}

}  // namespace

Eye eyeOf(const io::CameraFile& camera) {
  const std::string& instrument = camera.acquisition.instrument;
  if (instrument.find("LEFT") != std::string::npos) return Eye::kLeft;
  if (instrument.find("RIGHT") != std::string::npos) return Eye::kRight;
  const int i = eyeLetterIndex(camera.acquisition);
  if (i < 0) return Eye::kUnknown;
  const char letter = camera.acquisition.product_id[static_cast<std::size_t>(i)];
  return letter == 'L' ? Eye::kLeft : letter == 'R' ? Eye::kRight : Eye::kUnknown;
}

std::string exposureKey(const io::Acquisition& acquisition) {
  const int i = eyeLetterIndex(acquisition);
  if (i < 0) return "";
  std::string key = acquisition.product_id;
  key.erase(static_cast<std::size_t>(i), 1);
  return std::string(io::missionName(acquisition.mission)) + ":" + key;
}

Pairing pairFrames(const std::vector<Frame>& frames) {
  Pairing out;
  std::map<std::string, std::vector<int>> by_exposure;
  std::vector<bool> used(frames.size(), false);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const std::string key = exposureKey(frames[i].camera.acquisition);
    if (!key.empty() && frames[i].eye != Eye::kUnknown) by_exposure[key].push_back(static_cast<int>(i));
  }
  for (const auto& [key, members] : by_exposure) {
    // Candidate left-right pairs of this exposure, nearest clocks first.
    std::vector<std::pair<double, StereoPair>> candidates;
    for (int l : members) {
      for (int r : members) {
        const Frame& fl = frames[static_cast<std::size_t>(l)];
        const Frame& fr = frames[static_cast<std::size_t>(r)];
        if (fl.eye == Eye::kLeft && fr.eye == Eye::kRight && compatible(fl, fr)) {
          candidates.push_back({clockGap(fl, fr), StereoPair{l, r}});
        }
      }
    }
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [gap, pair] : candidates) {
      (void)gap;
      if (used[static_cast<std::size_t>(pair.left)] || used[static_cast<std::size_t>(pair.right)]) continue;
      used[static_cast<std::size_t>(pair.left)] = used[static_cast<std::size_t>(pair.right)] = true;
      out.pairs.push_back(pair);
    }
  }
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (used[i]) continue;
    const Frame& f = frames[i];
    std::string reason;
    if (f.eye == Eye::kUnknown) {
      reason = "neither the instrument ('" + f.camera.acquisition.instrument + "') nor the product id ('" +
               f.camera.acquisition.product_id + "') tells the eye";
    } else if (exposureKey(f.camera.acquisition).empty()) {
      reason = "the product id '" + f.camera.acquisition.product_id +
               "' is of no known mission's form: no partner can be told";
    } else {
      reason = std::string("an eye without its partner: no ") + (f.eye == Eye::kLeft ? "right" : "left") +
               " eye of exposure " + f.camera.acquisition.product_id +
               " (same id but the eye letter, clocks within " + "1 s, same sol, site and drive)";
    }
    out.unpaired.push_back(static_cast<int>(i));
    out.unpaired_reason.push_back(reason);
  }
  std::sort(out.pairs.begin(), out.pairs.end(), [&](const StereoPair& a, const StereoPair& b) {
    return frames[static_cast<std::size_t>(a.left)].source < frames[static_cast<std::size_t>(b.left)].source;
  });
  return out;
}

}  // namespace areomap::ingest
