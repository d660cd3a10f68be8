// libFuzzer target: rectify::fuzz::case_file (fuzz_targets.h).
#include "fuzz/fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t *data, std::size_t size)
{
  rectify::fuzz::case_file(data, size);
  return 0;
}
