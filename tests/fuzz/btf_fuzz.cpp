// Raw BTF stores (.btf, docs/store-format.md), checksums repaired so mutations reach the
// layout, chunk and VMF code: `info` as the CLI runs it, every chunk, the VMF, and lookups
// through the Decoder API (finite, >= 0).
#include <btf/compress/codec.h>
#include <btf/core/error.h>
#include <btf/ops/ops.h>
#include <btf/store/btf_store.h>

#include <algorithm>

#include "fuzz.h"

namespace btf::fuzz {

const char* const kTargetName = "btf";

std::string cliArgs(const uint8_t* data, size_t size) {
  const std::string bytes = repairChecksums(std::string(reinterpret_cast<const char*>(data), size));
  return "info " + writeInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), "btf");
}

void btfFuzzOne(const uint8_t* data, size_t size) {
  const std::string bytes = repairChecksums(std::string(reinterpret_cast<const char*>(data), size));
  const std::string path =
      writeInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), "btf");
  RunContext ctx;
  ctx.threads = 1;
  ctx.progress = false;
  ops::Request info("info");
  info.set("btf", path);
  ops::run(info, ctx);
  const BtfReader r(path);
  const auto v = r.verify();
  check(v.chunks == r.info().chunks(), "verify() saw another chunk count");
  for (int c = 0; c < r.info().chunks(); ++c) {
    if (std::find(v.badChunks.begin(), v.badChunks.end(), c) != v.badChunks.end()) continue;
    const auto chunk = r.readChunk(c);
    check(chunk.size() == size_t(r.info().chunkEnd(c) - r.info().chunkBegin(c)) *
                              r.info().texelBytes() / sizeof(float),
          "a chunk of another size than its layout");
  }
  if (r.info().hasVmf) check(r.readVmf(0).size() == size_t(r.info().texels()) * 2, "VMF size");
  checkDecoder(*openBtf(path));
}

}  // namespace btf::fuzz
