// What the parsers link against but the fuzz build does not generate: the
// build information (common/version.cpp.in, made by the main CMake project).
#include "common/version.h"

namespace rectify
{
  const char    *source_revision() { return "fuzz"; }
  nlohmann::json build_info() { return {{"rectify", "fuzz"}}; }
  std::string    version_text() { return "rectify fuzz build"; }
} // namespace rectify
