#include "ground/io/PixelFrame.hpp"

#include <cmath>
#include <cstdio>
#include <vector>

namespace areomap::io {
namespace {

struct Candidate {
  PixelFrame frame;
  double placement_scale = 1.0;  // full-resolution pixels per delivered pixel, to place the detector's edge
  bool fits = false;
  bool full = false;
  double centre_offset = 0.0;        // the larger of |d - centre| / size over both axes
  Vec2 principal_px = Vec2::Zero();  // d, the principal point in delivered pixels
  std::string why;                   // why it does not fit (or is no full frame)
};

std::string format(const char* fmt, double a, double b) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, fmt, a, b);
  return buffer;
}

// Fills fits, full, centre_offset and why for one candidate (see the header for the geometry).
void judge(const FrameEvidence& e, Candidate& c) {
  const Vec2 origin = e.meta_origin_px - Vec2(1.0, 1.0);  // 0-based full-resolution offset of the subframe
  const double size[2] = {static_cast<double>(e.width), static_cast<double>(e.height)};
  const Vec2 d = (e.principal_px - c.frame.offset_px) / c.frame.scale;
  c.fits = true;
  c.full = true;
  c.centre_offset = 0.0;
  for (int k = 0; k < 2; ++k) {
    const double edge = -0.5 - origin(k) / c.placement_scale;  // the detector's first pixel edge
    const double half = d(k) - edge;                           // edge to principal point
    const double extent = size[k] - 0.5 - edge;                // edge to the image's far edge
    const char* axis = k == 0 ? "sample" : "line";
    std::string fail;
    if (half <= 0.0) {
      fail = std::string("it lies before the detector's first ") + axis;
    } else if (extent > 2.0 * half / (1.0 - 2.0 * kPrincipalPointTolerance)) {
      fail = std::string("the image extends past a detector centred on it (") + axis + ")";
    }
    if (!fail.empty() && c.fits) {
      c.fits = false;
      c.why = fail;
    }
    const double off = std::fabs(d(k) - 0.5 * (size[k] - 1.0)) / size[k];
    c.centre_offset = std::fmax(c.centre_offset, off);
    if (off > kPrincipalPointTolerance ||
        origin(k) / c.placement_scale > kPrincipalPointTolerance * size[k]) {
      c.full = false;
    }
  }
  c.full = c.full && c.fits;
  c.principal_px = d;
  if (c.fits) c.why = "no full frame, and a subframe is read at the metadata's scale only";
}

Candidate fullResolution(const FrameEvidence& e, int s) {
  Candidate c;
  c.frame.scale = s;
  c.frame.offset_px = e.meta_origin_px - Vec2(1.0, 1.0) + Vec2::Constant(0.5 * (s - 1));
  c.frame.name = "1/" + std::to_string(s) + " of the detector from " +
                 format("(%g, %g)", e.meta_origin_px.x(), e.meta_origin_px.y());
  c.placement_scale = s;
  judge(e, c);
  return c;
}

bool sameMap(const PixelFrame& a, const PixelFrame& b) {
  return a.scale == b.scale && (a.offset_px - b.offset_px).norm() == 0.0;
}

std::string puts(const Candidate& c) {
  return format("puts the principal point at (%.1f, %.1f)", c.principal_px.x(), c.principal_px.y());
}

std::string sizeOf(const FrameEvidence& e, double scale) {
  return format("%.0fx%.0f", scale * e.width, scale * e.height);
}

}  // namespace

namespace {

// The rule without the detector: 0 given full, 1 metadata full, 2 another down-sampling full (nearest the
// image centre first, by centre_offset), 3 metadata subframe, 4 given subframe, 5 no fit.
int rank(const Candidate& c, const Candidate* given, const Candidate* meta) {
  if (c.full) return &c == given ? 0 : (&c == meta ? 1 : 2);
  if (c.fits && &c == meta) return 3;
  if (c.fits && &c == given) return 4;
  return 5;
}

bool rankedBefore(const Candidate& a, const Candidate& b, const Candidate* given, const Candidate* meta) {
  const int ra = rank(a, given, meta), rb = rank(b, given, meta);
  if (ra != rb) return ra < rb;
  return ra == 2 && a.centre_offset < b.centre_offset;
}

// The principal point in detector pixels (0-based) and the larger of its offsets from the detector's
// centre over both axes, as a fraction of the detector's size; false when the candidate is not physical.
bool physical(const FrameEvidence& e, const Candidate& c, double& offset_px) {
  const Vec2 origin = e.meta_origin_px - Vec2(1.0, 1.0);
  const double size[2] = {static_cast<double>(e.width), static_cast<double>(e.height)};
  offset_px = 0.0;
  for (int k = 0; k < 2; ++k) {
    const double s = c.placement_scale;
    const double detector_pp = origin(k) + s * c.principal_px(k) + 0.5 * (s - 1.0);
    const double off = std::fabs(detector_pp - 0.5 * (e.detector_px(k) - 1.0));
    if (off > kPrincipalPointTolerance * e.detector_px(k)) return false;
    if (origin(k) + s * size[k] > (1.0 + kPrincipalPointTolerance) * e.detector_px(k)) return false;
    offset_px = std::fmax(offset_px, off);
  }
  return true;
}

}  // namespace

bool choosePixelFrame(const FrameEvidence& e, PixelFrame& frame, std::string& tried) {
  Candidate given;
  given.frame.name = "as given";
  given.placement_scale = e.meta_scale;
  judge(e, given);
  const Candidate meta = fullResolution(e, e.meta_scale);
  const bool meta_distinct = !sameMap(meta.frame, given.frame);
  std::vector<Candidate> scaled;
  for (int s = 1; s <= kMaxDownsampling; ++s) {
    if (s == e.meta_scale) continue;
    scaled.push_back(fullResolution(e, s));
    if (sameMap(scaled.back().frame, given.frame)) scaled.pop_back();
  }
  std::vector<const Candidate*> all = {&given};
  if (meta_distinct) all.push_back(&meta);
  for (const Candidate& c : scaled) all.push_back(&c);
  const Candidate* meta_ptr = meta_distinct ? &meta : nullptr;

  // The known detector: the physical candidate nearest its centre, ties by the rule.
  const bool detector_known = e.detector_px.x() > 0.0 && e.detector_px.y() > 0.0;
  const Candidate* pick = nullptr;
  double pick_offset = 0.0;
  if (detector_known) {
    for (const Candidate* c : all) {
      double offset = 0.0;
      if (!physical(e, *c, offset)) continue;
      if (pick == nullptr || offset < pick_offset - 0.5 ||
          (offset <= pick_offset + 0.5 && rankedBefore(*c, *pick, &given, meta_ptr))) {
        pick = c;
        pick_offset = offset;
      }
    }
    if (pick != nullptr) {
      frame = pick->frame;
      return true;
    }
  }
  // The rule: full frames (as given, the metadata's, the down-sampling nearest the centre), then subframes
  // at the metadata's scale (full resolution, then as given).
  for (const Candidate* c : all) {
    if (rank(*c, &given, meta_ptr) < 5 && (pick == nullptr || rankedBefore(*c, *pick, &given, meta_ptr)))
      pick = c;
  }
  if (pick != nullptr) {
    frame = pick->frame;
    if (detector_known) {
      frame.note =
          format("no frame puts the principal point within %.0f %% of the %.0f",
                 100.0 * kPrincipalPointTolerance, e.detector_px.x()) +
          format("x%.0f detector's centre: read by the principal point alone", e.detector_px.y(), 0.0);
    }
    return true;
  }

  // 3. None: say what each candidate gave.
  tried = "as given (" + sizeOf(e, 1.0) + ") " + puts(given) + ": " + given.why;
  if (meta_distinct) {
    tried += "; scale_factor " + std::to_string(e.meta_scale) + " from subframe_rect " +
             format("(%g, %g)", e.meta_origin_px.x(), e.meta_origin_px.y()) + " (" + sizeOf(e, e.meta_scale) +
             ") " + puts(meta) + ": " + meta.why;
  }
  const Candidate* nearest = nullptr;
  for (const Candidate& c : scaled) {
    if (nearest == nullptr || c.centre_offset < nearest->centre_offset) nearest = &c;
  }
  if (nearest != nullptr) {
    const double first = scaled.front().frame.scale;
    tried += "; the other down-samplings 1/" + std::to_string(static_cast<int>(first)) + " .. 1/" +
             std::to_string(kMaxDownsampling) + " of the detector from subframe_rect " +
             format("(%g, %g)", e.meta_origin_px.x(), e.meta_origin_px.y()) + " (" + sizeOf(e, first) +
             " .. " + sizeOf(e, kMaxDownsampling) + "): no full frame (the nearest, " + nearest->frame.name +
             " (" + sizeOf(e, nearest->frame.scale) + "), " + puts(*nearest) +
             format(", %.1f %% of the image size off its centre; %.0f %% allowed)",
                    100.0 * nearest->centre_offset, 100.0 * kPrincipalPointTolerance);
  }
  return false;
}

}  // namespace areomap::io
