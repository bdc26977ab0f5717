// Files the engine reads (scenes, meshes, height images, BTFs, pair lists) are checked before
// they are opened: a device (/dev/zero), a fifo or a folder would hang or feed a reader without
// end, and a file larger than its reader's bound is refused before anything is allocated.
#pragma once
#include <cstdint>
#include <string>

namespace btf {

/// The size of `path` in bytes. Throws btf::Error "PATH: WHAT not found", "PATH: is a folder, not
/// a WHAT", "PATH: is not a regular file (a device, fifo or socket)" or "PATH: WHAT of N is larger
/// than the M this reader accepts (REASON)" when `maxBytes` is exceeded.
uint64_t checkInputFile(const std::string& path, const std::string& what,
                        uint64_t maxBytes = UINT64_MAX, const std::string& reason = "");

}  // namespace btf
