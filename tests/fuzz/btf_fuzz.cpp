// Raw BTF stores (.btf, docs/store-format.md), checksums repaired so mutations reach the
// layout, chunk and VMF code: `info` as the CLI runs it, every chunk, the VMF, and lookups
// through the Decoder API (finite, >= 0).
#include <btf/compress/codec.h>
#include <btf/core/error.h>
#include <btf/store/btf_store.h>

#include <algorithm>

#include "fuzz.h"

namespace btf::fuzz {

const char* const kTargetName = "btf";

std::string cliArgs(const uint8_t* data, size_t size) {
  return "info " + writeRepaired(data, size, "btf");
}

void btfFuzzOne(const uint8_t* data, size_t size) {
  const std::string path = writeRepaired(data, size, "btf");
  runCliReaders(path);
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
