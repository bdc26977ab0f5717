#include <btf/core/error.h>
#include <btf/core/output_lock.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

namespace btf {

namespace fs = std::filesystem;

void checkOutputPath(const std::string& path, bool folder) {
  std::error_code ec;
  const fs::file_status s = fs::symlink_status(path, ec);
  if (ec || !fs::exists(s)) return;
  if (fs::is_symlink(s))
    throw Error(path +
                ": is a symbolic link; give the path of its target (the finished file "
                "is renamed into place, which would replace the link)");
  if (fs::is_directory(s) && !folder)
    throw Error(path + ": is a folder; the output must be a file path");
  if (!fs::is_directory(s) && !fs::is_regular_file(s))
    throw Error(path +
                ": is not a regular file (a device, fifo or socket); refusing to replace it");
  if (fs::is_regular_file(s) && folder) throw Error(path + ": is a file; this output is a folder");
}

void makeFolder(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw Error(dir + ": cannot create the folder (" +
                (ec ? ec.message() : std::string("a file is in the way")) + ")");
}

OutputLock::OutputLock(const std::string& path) : m_partial(path + ".partial") {
  const fs::path dir = fs::path(m_partial).parent_path();
  std::error_code ec;
  if (!dir.empty()) fs::create_directories(dir, ec);
  m_created = !fs::exists(m_partial);
  m_fd = ::open(m_partial.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (m_fd < 0)
    throw Error(m_partial + ": cannot create (" + std::string(std::strerror(errno)) + ")");
  if (::flock(m_fd, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    ::close(m_fd);
    m_fd = -1;
    if (e == EWOULDBLOCK)
      throw Error(path + ": another run is writing it (" + m_partial +
                  " is locked); wait for it or choose another output");
    throw Error(m_partial + ": cannot lock (" + std::string(std::strerror(e)) + ")");
  }
}

OutputLock::~OutputLock() {
  if (m_fd < 0) return;
  // An empty partial this lock created (nothing was written into it) is removed.
  struct stat st;
  if (m_created && ::fstat(m_fd, &st) == 0 && st.st_size == 0 && st.st_nlink > 0) {
    std::error_code ec;
    fs::remove(m_partial, ec);
  }
  ::flock(m_fd, LOCK_UN);
  ::close(m_fd);
}

}  // namespace btf
