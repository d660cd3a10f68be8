// What both executables' main() share: the version flag, the exit codes.
#pragma once

#include <CLI/CLI.hpp>

#include "common/version.h"

namespace rectify::app
{
  /// Parses and runs `app`: exit code 2 for bad input (InputError), 1 for a
  /// failed computation, CLI11's own for its parse errors, 0 otherwise.
  int run_app(CLI::App &app, int argc, char **argv);
} // namespace rectify::app
