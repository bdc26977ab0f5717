// Compressed BTFs (.cbtf, docs/compression.md), checksums repaired: read, `info` as the CLI
// runs it, then each codec's decoder — every array shape against the header, lookups finite
// and >= 0.
#include <btf/compress/cbtf.h>
#include <btf/compress/codec.h>
#include <btf/core/error.h>
#include <btf/ops/ops.h>

#include "fuzz.h"

namespace btf::fuzz {

const char* const kTargetName = "cbtf";

std::string cliArgs(const uint8_t* data, size_t size) {
  const std::string bytes = repairChecksums(std::string(reinterpret_cast<const char*>(data), size));
  return "info " + writeInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), "cbtf");
}

void btfFuzzOne(const uint8_t* data, size_t size) {
  const std::string bytes = repairChecksums(std::string(reinterpret_cast<const char*>(data), size));
  const std::string path =
      writeInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), "cbtf");
  CompressedBtf c = readCompressed(path);
  RunContext ctx;
  ctx.threads = 1;
  ctx.progress = false;
  ops::Request info("info");
  info.set("btf", path);
  ops::run(info, ctx);
  checkDecoder(*makeDecoder(std::move(c)));
}

}  // namespace btf::fuzz
