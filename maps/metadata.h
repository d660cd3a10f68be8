// The convention every rectify map file shares: one comment line
// "# meta: {JSON}" with what made the table and with which settings.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "common/io.h"

namespace rectify::maps
{
  /// The JSON of the '# meta:' comment line of `csv` (an empty object if it
  /// has none). InputError naming `what` (e.g. "area map 'FILE'") if it is not valid JSON.
  nlohmann::json read_metadata(const CsvData &csv, const std::string &what);
} // namespace rectify::maps
