// Subcommands of the `rectify` tool, one registration function per stage.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>

#include "common/case_file.h"

namespace rectify::app
{
  /// Loads a case file, reads every stage's parameters from it (so that any
  /// unknown key is reported, whichever subcommand runs) and checks keys.
  CaseFile load_case(const std::filesystem::path &path);

  /// `simulate` and `sweep` (system/).
  void register_system_commands(CLI::App &app);

  /// `stiffness`, `map-stiffness` (stiffness_solver/).
  void register_stiffness_commands(CLI::App &app);

  /// `map-thesis` (maps/).
  void register_map_commands(CLI::App &app);
} // namespace rectify::app
