// libFuzzer target: rectify::fuzz::measured_run (fuzz_targets.h).
#include "fuzz/fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t *data, std::size_t size)
{
  rectify::fuzz::measured_run(data, size);
  return 0;
}
