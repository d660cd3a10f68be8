// Subcommands of the `rectify` tool, one registration function per stage.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "app/case_loading.h"
#include "common/case_file.h"

namespace rectify::app
{
  /// "" if `folder` can be created and written (tried, then undone), else why not.
  std::string check_output_folder(const std::filesystem::path &folder);

  /// The options every subcommand has: --case FILE (default: the reference
  /// case) and --out DIR (required; checked writable while the options are
  /// read, before any work).
  void add_case_and_out(CLI::App &command, std::string &case_path, std::string &out_dir);

  /// An option's check: "auto" or a number in [lower, upper].
  CLI::Validator auto_or_range(double lower, double upper, const std::string &name);

  /// Echoes a command's settings at start-up, one "name value" line each, on stderr.
  void echo_settings(const std::string                                       &command,
                     const std::vector<std::pair<std::string, std::string>> &settings);

  /// `simulate` and `sweep` (system/).
  void register_system_commands(CLI::App &app);

  /// `stiffness`, `map-stiffness` (stiffness_solver/).
  void register_stiffness_commands(CLI::App &app);

  /// `mesh` (mesher/).
  void register_mesh_commands(CLI::App &app);

  /// `stokes`, `map-resistance` (stokes_solver/).
  void register_stokes_commands(CLI::App &app);

  /// `check`: validate a case file for every stage.
  void register_check_command(CLI::App &app);

  /// `geometry`: check and draw a valve's geometry.
  void register_geometry_command(CLI::App &app);

  /// `synth`, `diagnose` (diagnosis/).
  void register_diagnosis_commands(CLI::App &app);
  /// `synth` (cmd_synth.cpp; registered with the diagnosis's commands)
  void register_synth_command(CLI::App &app);

  /// `design` (design/): the map set of a valve.
  void register_design_commands(CLI::App &app);

  /// `whatif` (whatif/): many designs' map sets and system answers, one MPI batch.
  void register_whatif_command(CLI::App &app);

  /// `map-thesis` (maps/).
  void register_map_commands(CLI::App &app);
} // namespace rectify::app
