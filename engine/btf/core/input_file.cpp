#include <btf/core/error.h>
#include <btf/core/input_file.h>
#include <btf/core/sysinfo.h>

#include <filesystem>

namespace btf {

uint64_t checkInputFile(const std::string& path, const std::string& what, uint64_t maxBytes,
                        const std::string& reason) {
  namespace fs = std::filesystem;
  if (path.empty()) throw Error("empty path given for a " + what);
  std::error_code ec;
  const fs::file_status s = fs::status(path, ec);  // follows links: the target is what is read
  if (ec || !fs::exists(s)) throw Error(path + ": " + what + " not found");
  if (fs::is_directory(s)) throw Error(path + ": is a folder, not a " + what);
  if (!fs::is_regular_file(s))
    throw Error(path + ": is not a regular file (a device, fifo or socket); cannot read a " + what +
                " from it");
  const uint64_t size = fs::file_size(path, ec);
  if (ec) throw Error(path + ": cannot read the size of the " + what + " (" + ec.message() + ")");
  if (size > maxBytes)
    throw Error(path + ": " + what + " of " + formatBytes(double(size)) + " is larger than the " +
                formatBytes(double(maxBytes)) + " this reader accepts" +
                (reason.empty() ? "" : " (" + reason + ")"));
  return size;
}

}  // namespace btf
