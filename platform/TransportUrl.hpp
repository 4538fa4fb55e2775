// LCM provider URLs from configuration, made safe by default (DESIGN.md "Messages"):
//   udpm://GROUP:PORT?ttl=N&recv_buf_size=BYTES   UDP multicast. ttl=0 (stay on this host) unless the
//                                                 operator gives ttl; recv_buf_size defaults to
//                                                 kDefaultRecvBufBytes, because UDP multicast drops a large
//                                                 message silently when the socket's receive buffer is
//                                                 smaller than the burst of its fragments.
//   file:///path/to.log?mode=r|w[&speed=S]        log replay (speed 0 = as fast as possible) or recording.
//   memq://                                       in-process queue, for tests.
// The kernel caps the receive buffer at net.core.rmem_max; LcmTransport reports the size the kernel
// granted (receiveBufferBytes()). Raise the cap with: sysctl -w net.core.rmem_max=16777216
#pragma once

#include <cstddef>
#include <cstdint>

#include "firmware_core/base/Status.hpp"

namespace areomap::platform {

// An image message is a stereo pair with two JPEGs (each up to kMaxJpegBytes = 2 MiB): 4 MiB + headers.
// The kernel doubles the requested size for its bookkeeping, so asking for 8 MiB leaves room for a burst.
constexpr int64_t kDefaultRecvBufBytes = 8 * 1024 * 1024;
constexpr const char* kDefaultUdpmUrl = "udpm://239.255.76.67:7667";
constexpr std::size_t kMaxUrlChars = 512;  // URL buffers, terminating NUL included

enum class UrlScheme : uint8_t { kInvalid = 0, kUdpm, kFile, kMemq };

// The scheme of `url` (kInvalid for anything else).
UrlScheme urlScheme(const char* url);

// Copies `url` to `out` (capacity bytes, NUL-terminated), completing a udpm URL: an empty or null url
// becomes kDefaultUdpmUrl; ttl=0 and recv_buf_size=kDefaultRecvBufBytes are added when absent. Other
// schemes are copied unchanged. kInvalidArgument for an unknown scheme, kCapacityExceeded when out is short.
[[nodiscard]] Status completeUrl(const char* url, char* out, std::size_t capacity);

// The integer value of option `name` in the query of `url` (false when absent or not a number).
bool urlOption(const char* url, const char* name, int64_t& value);

}  // namespace areomap::platform
