// Reading a case file for any subcommand: every stage's parameters are read
// and range-checked, so that a key no stage knows is reported whichever
// subcommand runs. Add a stage's `from_case` here when a stage is added.
#pragma once

#include <filesystem>

#include "common/case_file.h"

namespace rectify::app
{
  /// `read_map_sets` false: the system's map sets are not opened (nor checked).
  CaseFile load_case(const std::filesystem::path &path, bool read_map_sets = true);

  /// What load_case checks, for a case made in memory (a what-if design).
  void check_every_stage(const CaseFile &file, bool read_map_sets = true);
} // namespace rectify::app
