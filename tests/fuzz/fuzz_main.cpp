// libFuzzer's entry points (the fuzz build, `make fuzz`): one thread, inputs through runOne.
#include <tbb/global_control.h>

#include "fuzz.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // One worker: the fuzzer's own parallelism is its -jobs/-workers.
  static tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  btf::fuzz::runOne(data, size);
  return 0;
}
