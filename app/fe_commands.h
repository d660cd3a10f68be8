// The finite-element commands (mesh, stokes, map-resistance, stiffness,
// map-stiffness, design) live in a second executable, rectify-fe, linked with
// deal.II, PETSc, MPI, TetGen and CGAL. The `rectify` front end, which runs
// the system commands (simulate, sweep, synth, diagnose, check, map-thesis),
// does not load that stack: it starts in milliseconds instead of about 0.4 s
// (docs/benchmarks.md). For an FE command it replaces itself with rectify-fe
// (execv, same arguments, same process: mpirun and signals see one program).
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <utility>
#include <vector>

namespace rectify::app
{
  /// Name and one-line description of each command rectify-fe runs.
  const std::vector<std::pair<std::string, std::string>> &fe_commands();

  /// Lists the FE commands in the front end's help (they are never parsed
  /// there: forward_to_fe runs first).
  void register_fe_command_stubs(CLI::App &app);

  /// If argv names an FE command (the first argument that is not an option),
  /// replaces this process with rectify-fe beside this executable. Returns
  /// only if it does not, or with an exit code if rectify-fe cannot be run.
  int forward_to_fe(int argc, char **argv);
} // namespace rectify::app
