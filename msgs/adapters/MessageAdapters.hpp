// Conversions between the core's types and the generated LCM message types (msgs/*.lcm), and the checks a
// received stereo pair must pass before the generated decode() may touch it. Used by the rover node and by
// the ground (stream collection, ground pass, areomap-pack); it depends on the message types, the camera
// models and base only (library areomap_msg_adapters), so the ground does not link the rover pipeline.
// Heap: none, as long as the message objects were prepared once at start-up (prepareStereoPair and friends
// reserve their vectors and strings; encoding never allocates; decoding stays within the reserved capacities
// because checkStereoPairCapacity rejects anything larger first).
#pragma once

#include <cstddef>
#include <cstdint>

#include "areomap/camera_model_t.hpp"
#include "areomap/site_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/Status.hpp"
#include "firmware_core/camera/CameraModel.hpp"

namespace areomap {

// Characters reserved for every string of a message (panorama name, image stems, last_error): a stem of a
// PDS product id is ~30 characters; 128 is ample and keeps the reserved strings small.
constexpr int32_t kMaxMessageStringChars = 128;

// Encoded sizes (LCM: fixed fields at their declared width; a string is an int32 length, its characters and
// a NUL; a byte array its elements), from msgs/stereo_pair_t.lcm, stereo_image_t.lcm and camera_model_t.lcm.
// camera_model_t: type, 7 three-vectors, cahvore_kind, linearity, width, height.
constexpr std::size_t kEncodedCameraModelBytes = 1 + 7 * 3 * 8 + 1 + 8 + 4 + 4;
constexpr std::size_t kMaxEncodedStringBytes = 4 + static_cast<std::size_t>(kMaxMessageStringChars) + 1;
// stereo_image_t: stem, width, height, jpeg_bytes, the JPEG, the model.
constexpr std::size_t kMaxEncodedStereoImageBytes =
    kMaxEncodedStringBytes + 3 * 4 + static_cast<std::size_t>(kMaxJpegBytes) + kEncodedCameraModelBytes;
// The largest stereo_pair_t that checkStereoPairCapacity accepts (~4.0 MiB): fingerprint, utime, sequence,
// kind, panorama, pair_id, sol, tier, pairs_planned, has_right, both images, four rig three-vectors, two
// sigmas, four flags.
constexpr std::size_t kMaxStereoPairMessageBytes = 8 + 8 + 8 + 1 + kMaxEncodedStringBytes + 4 * 4 + 1 +
                                                   2 * kMaxEncodedStereoImageBytes + 4 * 3 * 8 + 2 * 8 + 4;

// camera_model_t <-> CameraModel. toCameraModel: kUnsupported for an unknown type, kNotFinite for NaN or
// infinity, kInvalidArgument for a model that validateModel refuses (`field` names the component).
[[nodiscard]] Status toCameraModel(const camera_model_t& in, CameraModel& out, const char*& field);
void toMessage(const CameraModel& in, camera_model_t& out);

// Reserves the vectors and strings of a stereo_pair_t so that decoding any pair within the capacities
// (kMaxJpegBytes per image, kMaxMessageStringChars per string) never allocates.
void prepareStereoPair(stereo_pair_t& pair);

// Walks the encoded bytes of a stereo_pair_t (after msgs::checkEncoding said kOk) and checks every string
// and JPEG length against the reserved capacities: kCapacityExceeded names what in `field`.
[[nodiscard]] Status checkStereoPairCapacity(const uint8_t* data, std::size_t size, const char*& field);

// The LCM fingerprint (first 8 bytes, big-endian) of an encoded message; 0 when shorter than 8 bytes.
uint64_t encodedFingerprint(const uint8_t* data, std::size_t size);

// The pair count a panorama's tie budget is planned for (PanoramaMatcher::planForPairs): the count the
// stream announces (stereo_pair_t.pairs_planned, which areomap-pack sets to the dataset's pair count, the
// count areomap-ties plans for), so that the rover and the offline tool make the same tie lists; unknown
// (<= 0) or above the capacity: kMaxPairs.
int32_t plannedPairs(int32_t pairs_planned);

// The message's image and model sizes, before any decoding: a JPEG present (kMissingField), 1..
// kMaxBinnedSourceWidth x 1..kMaxBinnedSourceHeight, the largest frames that binning by at most kMaxBinning
// brings within kMaxImageWidth x kMaxImageHeight (kCapacityExceeded above, kInvalidArgument at or below 0),
// the model's size equal to the image's (kInvalidArgument). `field` names what.
[[nodiscard]] Status checkImageSizes(const stereo_image_t& side, const char*& field);

// Reserves the strings of a site_t (kMaxMessageStringChars each) so that decodeSite never allocates.
void prepareSite(site_t& site);

// A received AREOMAP_SITE message: checks the encoding (msgs::checkEncoding), refuses a string longer than
// kMaxMessageStringChars before decoding (kCapacityExceeded), decodes into `out` (prepared) and checks what
// the traverse needs (checkSite). On failure `field` names the field, or "encoding".
[[nodiscard]] Status decodeSite(const uint8_t* data, std::size_t size, site_t& out, const char*& field);

// The content of a decoded site_t: a site id of letters, digits, _ and - (kInvalidArgument), a panorama
// name (kMissingField), 0 <= site_index < sites_planned <= kMaxGroundSites and is_last exactly on the last
// index (kInvalidArgument), finite numbers (kNotFinite), odometry on every site but the first (from a
// named site, positive finite sigmas, distance >= 0; kMissingField / kInvalidArgument) and none on the
// first. `field` names the first field that fails.
[[nodiscard]] Status checkSite(const site_t& site, const char*& field);

// Copies a NUL-terminated text into `out` (capacity chars incl. the NUL), truncating.
void copyText(const char* text, char* out, std::size_t capacity);

}  // namespace areomap
