// Compressed BTFs (.cbtf, docs/compression.md), checksums repaired: read, `info` as the CLI
// runs it, then each codec's decoder — every array shape against the header, lookups finite
// and >= 0; a pyramid (--mip, docs/mip.md) also at its last level.
#include <btf/compress/cbtf.h>
#include <btf/compress/codec.h>
#include <btf/compress/mip.h>
#include <btf/core/error.h>

#include "fuzz.h"

namespace btf::fuzz {

const char* const kTargetName = "cbtf";

std::string cliArgs(const uint8_t* data, size_t size) {
  return "info " + writeRepaired(data, size, "cbtf");
}

void btfFuzzOne(const uint8_t* data, size_t size) {
  const std::string path = writeRepaired(data, size, "cbtf");
  CompressedBtf c = readCompressed(path);
  runCliReaders(path);
  const int last = int(c.levels.size()) - 1;
  if (last > 0) checkDecoder(*makePyramidDecoder(c, last));
  checkDecoder(*makeDecoder(std::move(c)));
}

}  // namespace btf::fuzz
