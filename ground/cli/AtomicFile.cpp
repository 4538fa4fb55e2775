#include "ground/cli/AtomicFile.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "ground/cli/Cli.hpp"

namespace areomap::cli {
namespace {
std::atomic<unsigned> g_counter{0};

void removeQuietly(const std::string& path) {
  std::error_code ec;
  std::filesystem::remove(path, ec);
}
}  // namespace

std::string temporaryPathFor(const std::string& path) {
  return path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(g_counter.fetch_add(1));
}

void writeFileAtomic(const std::string& path, const void* data, std::size_t size) {
  const std::string tmp = temporaryPathFor(path);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw InputError(path, "", std::string("cannot write: ") + std::strerror(errno));
  const auto* bytes = static_cast<const unsigned char*>(data);
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::write(fd, bytes + done, size - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : ENOSPC;
      ::close(fd);
      removeQuietly(tmp);
      throw InputError(path, "", std::string("cannot write: ") + std::strerror(err));
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    const int err = errno;
    removeQuietly(tmp);
    throw InputError(path, "", std::string("cannot write: ") + std::strerror(err));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    removeQuietly(tmp);
    throw InputError(path, "", std::string("cannot rename into place: ") + std::strerror(err));
  }
}

void writeFileAtomic(const std::string& path, const std::string& text) {
  writeFileAtomic(path, text.data(), text.size());
}

void writeViaTemporary(const std::string& path, const std::function<void(const std::string& tmp_path)>& write) {
  // Keep the extension last so that format-by-extension writers (imwrite, GDAL drivers) still work.
  const std::filesystem::path p(path);
  const std::string tmp =
      (p.parent_path() / (p.stem().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                          std::to_string(g_counter.fetch_add(1)) + p.extension().string()))
          .string();
  try {
    write(tmp);
  } catch (const std::exception& e) {
    // Whatever the writer says (it names the temporary, if anything), the error names the product.
    removeQuietly(tmp);
    throw InputError(path, "", std::string("not written (") + e.what() + ")");
  } catch (...) {
    removeQuietly(tmp);
    throw;
  }
  std::error_code ec;
  if (!std::filesystem::exists(tmp, ec) || std::filesystem::file_size(tmp, ec) == 0) {
    removeQuietly(tmp);
    throw InputError(path, "", "nothing was written (disk full or folder not writable?)");
  }
  // On disk before the rename, as writeFileAtomic does: a crash leaves the old product or the new one.
  const int fd = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
  const bool synced = fd >= 0 && ::fsync(fd) == 0;
  const int err = errno;
  if (fd >= 0) ::close(fd);
  if (!synced) {
    removeQuietly(tmp);
    throw InputError(path, "", std::string("cannot sync: ") + std::strerror(err));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int rename_err = errno;
    removeQuietly(tmp);
    throw InputError(path, "", std::string("cannot rename into place: ") + std::strerror(rename_err));
  }
}

}  // namespace areomap::cli
