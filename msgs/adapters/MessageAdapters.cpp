#include "msgs/adapters/MessageAdapters.hpp"

#include <cmath>
#include <cstring>

#include "msgs/MessageCheck.hpp"

namespace areomap {
namespace {

bool finite3(const double v[3]) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}
Vec3 vec(const double v[3]) {
  return Vec3(v[0], v[1], v[2]);
}
void put(const Vec3& v, double out[3]) {
  out[0] = v.x();
  out[1] = v.y();
  out[2] = v.z();
}

// Big-endian reader over encoded LCM bytes (the check already proved the lengths fit).
struct Reader {
  const uint8_t* data;
  std::size_t size;
  std::size_t at;
  bool skip(std::size_t n) {
    if (n > size - at) return false;
    at += n;
    return true;
  }
  bool int32(int32_t& v) {
    if (size - at < 4) return false;
    const uint32_t u = (uint32_t{data[at]} << 24) | (uint32_t{data[at + 1]} << 16) |
                       (uint32_t{data[at + 2]} << 8) | uint32_t{data[at + 3]};
    v = static_cast<int32_t>(u);
    at += 4;
    return true;
  }
  // An LCM string: int32 length including the NUL, then the bytes.
  bool string(int32_t& chars) {
    int32_t len = 0;
    if (!int32(len) || len < 1) return false;
    chars = len - 1;
    return skip(static_cast<std::size_t>(len));
  }
};

Status walkImage(Reader& r, const char* side, const char*& field) {
  int32_t chars = 0;
  if (!r.string(chars)) return Status::kTruncated;
  if (chars > kMaxMessageStringChars) {
    field = side[0] == 'l' ? "left.stem" : "right.stem";
    return Status::kCapacityExceeded;
  }
  int32_t width = 0, height = 0, jpeg = 0;
  if (!r.int32(width) || !r.int32(height) || !r.int32(jpeg)) return Status::kTruncated;
  if (jpeg > kMaxJpegBytes) {
    field = side[0] == 'l' ? "left.jpeg_bytes" : "right.jpeg_bytes";
    return Status::kCapacityExceeded;
  }
  if (jpeg < 0 || !r.skip(static_cast<std::size_t>(jpeg)) || !r.skip(kEncodedCameraModelBytes))
    return Status::kTruncated;
  return Status::kOk;
}

}  // namespace

Status toCameraModel(const camera_model_t& in, CameraModel& out, const char*& field) {
  field = "type";
  switch (in.type) {
    case camera_model_t::TYPE_CAHV:
      out.type = CameraType::kCahv;
      break;
    case camera_model_t::TYPE_CAHVOR:
      out.type = CameraType::kCahvor;
      break;
    case camera_model_t::TYPE_CAHVORE:
      out.type = CameraType::kCahvore;
      break;
    default:
      return Status::kUnsupported;
  }
  const double* vectors[] = {in.c_m, in.a, in.h_px, in.v_px, in.o, in.r, in.e};
  const char* names[] = {"C", "A", "H", "V", "O", "R", "E"};
  for (int32_t i = 0; i < 7; ++i) {
    if (!finite3(vectors[i])) {
      field = names[i];
      return Status::kNotFinite;
    }
  }
  if (!std::isfinite(in.linearity)) {
    field = "L";
    return Status::kNotFinite;
  }
  out.c = vec(in.c_m);
  out.a = vec(in.a);
  out.h = vec(in.h_px);
  out.v = vec(in.v_px);
  out.o = vec(in.o);
  out.r = vec(in.r);
  out.e = vec(in.e);
  out.cahvore_kind = in.cahvore_kind == camera_model_t::CAHVORE_FISHEYE   ? CahvoreKind::kFisheye
                     : in.cahvore_kind == camera_model_t::CAHVORE_GENERAL ? CahvoreKind::kGeneral
                                                                          : CahvoreKind::kPerspective;
  out.linearity = in.linearity;
  out.width = in.width_px;
  out.height = in.height_px;
  const Status s = validateModel(out, field);
  return ok(s) ? s : (s == Status::kNotFinite ? s : Status::kInvalidArgument);
}

void toMessage(const CameraModel& in, camera_model_t& out) {
  out.type = in.type == CameraType::kCahv     ? camera_model_t::TYPE_CAHV
             : in.type == CameraType::kCahvor ? camera_model_t::TYPE_CAHVOR
                                              : camera_model_t::TYPE_CAHVORE;
  put(in.c, out.c_m);
  put(in.a, out.a);
  put(in.h, out.h_px);
  put(in.v, out.v_px);
  put(in.o, out.o);
  put(in.r, out.r);
  put(in.e, out.e);
  out.cahvore_kind = in.type != CameraType::kCahvore            ? camera_model_t::CAHVORE_INVALID
                     : in.cahvore_kind == CahvoreKind::kFisheye ? camera_model_t::CAHVORE_FISHEYE
                     : in.cahvore_kind == CahvoreKind::kGeneral ? camera_model_t::CAHVORE_GENERAL
                                                                : camera_model_t::CAHVORE_PERSPECTIVE;
  out.linearity = in.linearity;
  out.width_px = in.width;
  out.height_px = in.height;
}

void prepareStereoPair(stereo_pair_t& pair) {
  pair.panorama.reserve(kMaxMessageStringChars + 1);
  for (stereo_image_t* side : {&pair.left, &pair.right}) {
    side->stem.reserve(kMaxMessageStringChars + 1);
    side->jpeg.reserve(static_cast<std::size_t>(kMaxJpegBytes));
  }
}

Status checkStereoPairCapacity(const uint8_t* data, std::size_t size, const char*& field) {
  field = "";
  Reader r{data, size, 0};
  // fingerprint, utime, sequence, kind
  if (!r.skip(8 + 8 + 8 + 1)) return Status::kTruncated;
  int32_t chars = 0;
  if (!r.string(chars)) return Status::kTruncated;
  if (chars > kMaxMessageStringChars) {
    field = "panorama";
    return Status::kCapacityExceeded;
  }
  // pair_id, sol, tier, pairs_planned, has_right
  if (!r.skip(4 * 4 + 1)) return Status::kTruncated;
  Status s = walkImage(r, "left", field);
  if (!ok(s)) return s;
  return walkImage(r, "right", field);
}

int32_t plannedPairs(int32_t pairs_planned) {
  return pairs_planned > 0 && pairs_planned <= kMaxPairs ? pairs_planned : kMaxPairs;
}

Status checkImageSizes(const stereo_image_t& side, const char*& field) {
  field = "jpeg_bytes";
  if (side.jpeg_bytes <= 0) return Status::kMissingField;
  field = "width_px";
  if (side.width_px > kMaxBinnedSourceWidth) return Status::kCapacityExceeded;
  if (side.width_px <= 0) return Status::kInvalidArgument;
  field = "height_px";
  if (side.height_px > kMaxBinnedSourceHeight) return Status::kCapacityExceeded;
  if (side.height_px <= 0) return Status::kInvalidArgument;
  field = "model.width_px";
  if (side.model.width_px != side.width_px) return Status::kInvalidArgument;
  field = "model.height_px";
  if (side.model.height_px != side.height_px) return Status::kInvalidArgument;
  field = "";
  return Status::kOk;
}

uint64_t encodedFingerprint(const uint8_t* data, std::size_t size) {
  if (data == nullptr || size < 8) return 0;
  uint64_t v = 0;
  for (int32_t i = 0; i < 8; ++i) v = (v << 8) | data[i];
  return v;
}

void copyText(const char* text, char* out, std::size_t capacity) {
  if (capacity == 0) return;
  std::size_t n = 0;
  while (text != nullptr && text[n] != '\0' && n + 1 < capacity) {
    out[n] = text[n];
    ++n;
  }
  out[n] = '\0';
}

void prepareSite(site_t& site) {
  for (std::string* text : {&site.traverse, &site.site_id, &site.panorama, &site.odometry_from}) {
    text->reserve(kMaxMessageStringChars + 1);
  }
}

Status decodeSite(const uint8_t* data, std::size_t size, site_t& out, const char*& field) {
  field = "encoding";
  int64_t longest = 0;
  const Status s = msgs::checkEncoding(site_t::getTypeName(), static_cast<uint64_t>(site_t::getHash()), data,
                                       size, longest);
  if (!ok(s)) return s;
  if (longest > kMaxMessageStringChars) {
    field = "a string longer than kMaxMessageStringChars";
    return Status::kCapacityExceeded;
  }
  if (out.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) return Status::kCorruptData;
  return checkSite(out, field);
}

namespace {

bool safeId(const std::string& id) {
  if (id.empty()) return false;
  for (const char c : id) {
    const bool good =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    if (!good) return false;
  }
  return true;
}

}  // namespace

Status checkSite(const site_t& site, const char*& field) {
  field = "";
  if (!safeId(site.site_id)) {
    field = "site_id";
    return Status::kInvalidArgument;
  }
  if (site.panorama.empty()) {
    field = "panorama";
    return Status::kMissingField;
  }
  if (site.kind != site_t::KIND_PANORAMA && site.kind != site_t::KIND_STOP) {
    field = "kind";
    return Status::kInvalidArgument;
  }
  if (site.sites_planned < 1 || site.sites_planned > kMaxGroundSites) {
    field = "sites_planned";
    return Status::kInvalidArgument;
  }
  if (site.site_index < 0 || site.site_index >= site.sites_planned) {
    field = "site_index";
    return Status::kInvalidArgument;
  }
  if (site.is_last != (site.site_index == site.sites_planned - 1)) {
    field = "is_last";
    return Status::kInvalidArgument;
  }
  if (!finite3(site.position_m) || !std::isfinite(site.heading_deg)) {
    field = "position_m/heading_deg";
    return Status::kNotFinite;
  }
  if (site.site_index == 0) {
    if (site.has_odometry) {
      field = "has_odometry";
      return Status::kInvalidArgument;
    }
    return Status::kOk;
  }
  if (!site.has_odometry) {
    field = "has_odometry";
    return Status::kMissingField;
  }
  if (!safeId(site.odometry_from) || site.odometry_from == site.site_id) {
    field = "odometry_from";
    return Status::kInvalidArgument;
  }
  if (!finite3(site.delta_m) || !std::isfinite(site.delta_heading_deg) || !std::isfinite(site.distance_m) ||
      !finite3(site.sigma_m) || !std::isfinite(site.sigma_heading_deg)) {
    field = "odometry";
    return Status::kNotFinite;
  }
  if (!(site.sigma_m[0] > 0.0 && site.sigma_m[1] > 0.0 && site.sigma_m[2] > 0.0 &&
        site.sigma_heading_deg > 0.0)) {
    field = "sigma_m/sigma_heading_deg";
    return Status::kInvalidArgument;
  }
  if (site.distance_m < 0.0) {
    field = "distance_m";
    return Status::kInvalidArgument;
  }
  return Status::kOk;
}

}  // namespace areomap
