// One writer per output (docs/cli.md): a run holds an advisory lock (flock) on OUTPUT.partial
// from before its first piece of work to its end, so a second run writing the same output is
// refused at once instead of silently replacing the first one's file. Output paths are checked
// first: a folder where a file is expected, a device, fifo or socket, and a symbolic link are
// refused with the path.
#pragma once
#include <string>

namespace btf {

/// Throws btf::Error naming `path` when it cannot be a run's output: an existing folder (when
/// `folder` is false), not a regular file or folder, or a symbolic link.
void checkOutputPath(const std::string& path, bool folder);

/// Creates `dir` and its parents; throws btf::Error "DIR: cannot create the folder (REASON)".
void makeFolder(const std::string& dir);

class OutputLock {
 public:
  /// Locks PATH.partial (created when missing). Throws btf::Error "PATH: another run is writing
  /// it" when another process holds the lock.
  explicit OutputLock(const std::string& path);
  ~OutputLock();
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

 private:
  std::string m_partial;
  int m_fd = -1;
  bool m_created = false;
};

}  // namespace btf
