// The table of every case key a stage read (CaseFile::read_keys) as CSV:
// `rectify check` writes it as keys.csv, one row per key with its value,
// whether the file gave it, and its admissible range.
#pragma once

#include <string>

#include "common/case_file.h"

namespace rectify
{
  /// "table,key,value,given,range" and a row per key read from `file`;
  /// cells with a comma, quote or line end are quoted ("" for a quote).
  std::string case_keys_csv(const CaseFile &file);
} // namespace rectify
