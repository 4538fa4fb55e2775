#include "platform/TransportUrl.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace areomap::platform {
namespace {

bool startsWith(const char* s, const char* prefix) {
  return std::strncmp(s, prefix, std::strlen(prefix)) == 0;
}

}  // namespace

UrlScheme urlScheme(const char* url) {
  if (url == nullptr) return UrlScheme::kInvalid;
  if (startsWith(url, "udpm://")) return UrlScheme::kUdpm;
  if (startsWith(url, "file://")) return UrlScheme::kFile;
  if (startsWith(url, "memq://")) return UrlScheme::kMemq;
  return UrlScheme::kInvalid;
}

bool urlOption(const char* url, const char* name, int64_t& value) {
  if (url == nullptr || name == nullptr) return false;
  const char* query = std::strchr(url, '?');
  const std::size_t name_len = std::strlen(name);
  for (const char* p = query; p != nullptr && *p != '\0'; p = std::strchr(p + 1, '&')) {
    const char* key = p + 1;
    if (std::strncmp(key, name, name_len) == 0 && key[name_len] == '=') {
      char* end = nullptr;
      const long long v = std::strtoll(key + name_len + 1, &end, 10);
      if (end == key + name_len + 1 || (*end != '\0' && *end != '&')) return false;
      value = v;
      return true;
    }
  }
  return false;
}

Status completeUrl(const char* url, char* out, std::size_t capacity) {
  if (out == nullptr || capacity == 0) return Status::kInvalidArgument;
  const char* in = (url == nullptr || url[0] == '\0') ? kDefaultUdpmUrl : url;
  const UrlScheme scheme = urlScheme(in);
  if (scheme == UrlScheme::kInvalid) return Status::kInvalidArgument;
  const std::size_t len = std::strlen(in);
  if (len + 1 > capacity) return Status::kCapacityExceeded;
  std::memcpy(out, in, len + 1);
  if (scheme != UrlScheme::kUdpm) return Status::kOk;
  int64_t unused = 0;
  std::size_t used = len;
  const auto append = [&](const char* key, int64_t value) {
    const char separator = std::strchr(out, '?') == nullptr ? '?' : '&';
    const int n = std::snprintf(out + used, capacity - used, "%c%s=%lld", separator, key,
                                static_cast<long long>(value));
    if (n < 0 || static_cast<std::size_t>(n) >= capacity - used) return false;
    used += static_cast<std::size_t>(n);
    return true;
  };
  if (!urlOption(out, "ttl", unused) && !append("ttl", 0)) return Status::kCapacityExceeded;
  if (!urlOption(out, "recv_buf_size", unused) && !append("recv_buf_size", kDefaultRecvBufBytes)) {
    return Status::kCapacityExceeded;
  }
  return Status::kOk;
}

}  // namespace areomap::platform
