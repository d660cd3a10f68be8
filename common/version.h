// The tool's version, the source revision it was built from (git describe at
// configure time, "unknown" outside git) and the versions of the libraries
// it was built with. They live in one generated source file, so a new
// commit recompiles that file alone.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace rectify
{
  const char *source_revision();
  /// {"rectify": version, "revision": ..., "deal.II": ..., "PETSc": ...,
  /// "SUNDIALS": ..., "TetGen": ..., "CGAL": ...}: for --version, every
  /// summary.json and every map set.
  nlohmann::json build_info();
  /// The same as lines for `rectify --version`.
  std::string version_text();
} // namespace rectify
