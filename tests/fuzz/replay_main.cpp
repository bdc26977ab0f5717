// Replays a corpus through a fuzz target in the ordinary build (`make test`):
//   fuzz_NAME [--expect-error | --btfsim BTFSIM] [--timeout S] [--max-memory-mb M] PATH...
// Each PATH is a file or a folder of files (sorted). Every input runs in a child process, so a
// crash, an abort or a hang is reported against the input that caused it and the others still
// run; the child's address space is limited to M MiB (an allocation past it fails, and a
// bad_alloc is a finding) and its run to S seconds. With --expect-error every input must end in
// a clean refusal: one btf::Error of one line that names the input file. Prints one line per
// input and "N passed, N failed". With --btfsim each input is instead given to btfsim as a user
// would give it (the target's cliArgs), which must exit 1 with one "btfsim: error:" line.
#include <sys/resource.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "fuzz.h"

namespace fs = std::filesystem;

// Sanitizers reserve terabytes of address space for their shadow memory: under them the
// address-space limit is left off (ASan reports huge allocations itself).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kLimitAddressSpace = false;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kLimitAddressSpace = false;
#else
constexpr bool kLimitAddressSpace = true;
#endif
#else
constexpr bool kLimitAddressSpace = true;
#endif

namespace {

std::string readAll(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// Runs one input in a child; returns "" when it passed, else why it failed. `message` receives
// the refusal, if any.
std::string replay(const fs::path& file, bool expectError, int timeoutS, long maxMemoryMb,
                   std::string* message) {
  int pipefd[2];
  if (::pipe(pipefd) != 0) return "cannot create a pipe";
  const pid_t pid = ::fork();
  if (pid < 0) return "cannot fork";
  if (pid == 0) {
    ::close(pipefd[0]);
    if (kLimitAddressSpace && maxMemoryMb > 0) {
      const rlim_t lim = rlim_t(maxMemoryMb) << 20;
      struct rlimit rl {
        lim, lim
      };
      ::setrlimit(RLIMIT_AS, &rl);
    }
    ::alarm(unsigned(timeoutS));
    static tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    const std::string bytes = readAll(file);
    btf::fuzz::runOne(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
    const std::string& msg = btf::fuzz::lastError;
    [[maybe_unused]] ssize_t w = ::write(pipefd[1], msg.data(), msg.size());
    ::close(pipefd[1]);
    std::_Exit(0);
  }
  ::close(pipefd[1]);
  std::string msg;
  char buf[4096];
  for (ssize_t n; (n = ::read(pipefd[0], buf, sizeof buf)) != 0;) {
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) break;
    msg.append(buf, size_t(n));
  }
  ::close(pipefd[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    if (sig == SIGALRM) return "hang: still running after " + std::to_string(timeoutS) + " s";
    return std::string("crashed: signal ") + strsignal(sig);
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return "exited with status " + std::to_string(WEXITSTATUS(status));
  *message = msg;
  if (!expectError) return "";
  if (msg.empty()) return "was accepted; a refusal (btf::Error) was expected";
  if (msg.find('\n') != std::string::npos) return "refusal of more than one line: " + msg;
  if (msg.find("input.") == std::string::npos && msg.find("/btf-fuzz-") == std::string::npos)
    return "refusal does not name the input file: " + msg;
  if (msg.find("json.exception") != std::string::npos ||
      msg.find("basic_string") != std::string::npos)
    return "refusal carries a library's text: " + msg;
  return "";
}

// Runs btfsim on the input as a user would (cliArgs) and checks the refusal: exit status 1 and
// exactly one line of output, "btfsim: error: ..." naming the input file, no library text.
std::string replayCli(const fs::path& file, const std::string& btfsim, std::string* message) {
  const std::string bytes = readAll(file);
  std::string args;
  try {
    args = btf::fuzz::cliArgs(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  } catch (const std::exception& e) {
    return std::string("cannot prepare the command: ") + e.what();
  }
  const std::string cmd = "timeout 120 " + btfsim + " " + args + " -q < /dev/null 2>&1";
  const auto t0 = std::chrono::steady_clock::now();
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return "cannot run " + btfsim;
  std::string out;
  char buf[4096];
  for (size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  const int status = ::pclose(p);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  char took[32];
  std::snprintf(took, sizeof took, "(%.2f s) ", seconds);
  *message = took + out.substr(0, out.find('\n'));
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (code == 124) return "btfsim " + args + ": still running after 120 s";
  if (code != 1) return "btfsim " + args + ": exit status " + std::to_string(code) + ": " + out;
  if (std::count(out.begin(), out.end(), '\n') != 1) return "more than one line of output: " + out;
  if (out.rfind("btfsim: error: ", 0) != 0) return "not a btfsim error line: " + out;
  if (out.find("input.") == std::string::npos && out.find("scene.json") == std::string::npos &&
      out.find("plane.json") == std::string::npos)
    return "the error does not name the input file: " + out;
  if (out.find("json.exception") != std::string::npos) return "library text: " + out;
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  bool expectError = false;
  std::string btfsim;
  int timeoutS = 20;
  long maxMemoryMb = 4096;
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--expect-error") {
      expectError = true;
    } else if (a == "--btfsim" && i + 1 < argc) {
      btfsim = argv[++i];
      expectError = true;
    } else if (a == "--timeout" && i + 1 < argc) {
      timeoutS = std::atoi(argv[++i]);
    } else if (a == "--max-memory-mb" && i + 1 < argc) {
      maxMemoryMb = std::atol(argv[++i]);
    } else if (fs::is_directory(a)) {
      std::vector<fs::path> in;
      for (const auto& e : fs::directory_iterator(a))
        if (e.is_regular_file()) in.push_back(e.path());
      std::sort(in.begin(), in.end());
      files.insert(files.end(), in.begin(), in.end());
    } else if (fs::is_regular_file(a)) {
      files.push_back(a);
    } else {
      std::fprintf(stderr, "fuzz replay: %s: no such file or folder\n", a.c_str());
      return 2;
    }
  }
  btf::fuzz::inputDir();  // made once here: every child writes its input into the same folder
  int passed = 0, failed = 0;
  for (const auto& f : files) {
    std::string msg;
    const std::string why = btfsim.empty() ? replay(f, expectError, timeoutS, maxMemoryMb, &msg)
                                           : replayCli(f, btfsim, &msg);
    if (why.empty()) {
      ++passed;
      std::printf("ok    %s%s%s\n", f.filename().c_str(), msg.empty() ? "" : ": ", msg.c_str());
    } else {
      ++failed;
      std::printf("FAIL  %s: %s\n", f.c_str(), why.c_str());
    }
  }
  std::printf("fuzz replay %s: %d passed, %d failed\n", btf::fuzz::kTargetName, passed, failed);
  fs::remove_all(btf::fuzz::inputDir());
  return failed == 0 && passed > 0 ? 0 : 1;
}
