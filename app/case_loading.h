// Reading a case file for any subcommand: every stage's parameters are read
// and range-checked, so that a key no stage knows is reported whichever
// subcommand runs. Add a stage's `from_case` here when a stage is added.
#pragma once

#include <filesystem>

#include "common/case_file.h"

namespace rectify::app
{
  CaseFile load_case(const std::filesystem::path &path);
} // namespace rectify::app
