// The batch's summary (a part of `rectify whatif`, batch.h): OUT/whatif.csv
// and whatif.json (one row per design: its map set's numbers, its sweeps'
// answers from valid runs, its reeds' life), and the plots of each answer
// against the varied keys.
#pragma once

#include <vector>

#include "whatif/batch.h"
#include "whatif/paths.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  /// Writes the table, its JSON and the plots; returns how many designs failed.
  std::size_t write_summary(const BatchSettings &bs, const std::vector<DesignCase> &designs, const Paths &paths);
} // namespace rectify::whatif
