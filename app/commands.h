// Subcommands of the `rectify` tool, one registration function per stage.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>

#include "app/case_loading.h"
#include "common/case_file.h"

namespace rectify::app
{
  /// `simulate` and `sweep` (system/).
  void register_system_commands(CLI::App &app);

  /// `stiffness`, `map-stiffness` (stiffness_solver/).
  void register_stiffness_commands(CLI::App &app);

  /// `map-thesis` (maps/).
  void register_map_commands(CLI::App &app);
} // namespace rectify::app
