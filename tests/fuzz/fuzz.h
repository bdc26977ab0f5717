// Fuzz targets, one per reader (docs/reliability.md). Each target file defines btfFuzzOne();
// fuzz_main.cpp wraps it as libFuzzer's LLVMFuzzerTestOneInput, and replay_main.cpp replays a
// corpus with it in the ordinary build (`make test`). An input may end in a btf::Error — the
// clean refusal; anything else that escapes (another exception, a crash, a contract broken, an
// allocation past the limit, a hang) is a finding.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

namespace btf {
class Decoder;
}

namespace btf::fuzz {

/// The target: reads `data` as its input file would be read.
void btfFuzzOne(const uint8_t* data, size_t size);
/// Writes what btfsim needs to read this input the way a user would (the input file, and a scene
/// that refers to it where the input is a part's file) and returns btfsim's arguments, e.g.
/// "plan DIR/input.json". The replay driver's --btfsim mode runs them (docs/reliability.md).
std::string cliArgs(const uint8_t* data, size_t size);
/// A scene of one part of `type` with `key` = `path` (a mesh or a height image), written to
/// inputDir()/scene.json; returns its path.
std::string sceneWithFile(const std::string& type, const std::string& key, const std::string& path);
/// The target's name (its corpus folders are tests/fuzz/{corpus,regressions}/NAME).
extern const char* const kTargetName;

/// Writes the input to this process's temp folder as input.EXT and returns its path. The folder
/// is private to the process and holds nothing else the input could refer to.
std::string writeInput(const uint8_t* data, size_t size, const std::string& ext);
std::string inputDir();

/// A contract of the reader broken (a value not finite, a size inconsistent): abort, so the
/// fuzzer records the input.
[[noreturn]] void fail(const std::string& what);
inline void check(bool ok, const std::string& what) {
  if (!ok) fail(what);
}

/// Recomputes the checksums of a .btf or .cbtf (preamble, chunk table, VMF, arrays) wherever the
/// file's own sizes make that possible, so mutations reach the code behind the checksums; other
/// bytes are left as they are.
std::string repairChecksums(std::string bytes);

/// The Decoder contract on a file that was accepted: the first and last texels, one value and
/// one interpolated lookup, all finite and >= 0.
void checkDecoder(const Decoder& d);

/// The input with its checksums repaired, written as input.EXT; returns its path.
std::string writeRepaired(const uint8_t* data, size_t size, const std::string& ext);
/// A BTF file through the use cases the CLI runs on it: `info`, a `slice` of the texel average
/// (every texel, every view) and a `compare` with itself, whose error must be exactly 0.
void runCliReaders(const std::string& path);

/// What the last call ended with: "" when it succeeded, else the btf::Error's message.
extern std::string lastError;
/// Runs the target on one input, recording lastError; aborts on any other exception.
void runOne(const uint8_t* data, size_t size);

}  // namespace btf::fuzz
