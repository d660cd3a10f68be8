// rectify: design tool for the fluid rectification reed valves of
// smart-material pumps and electrohydrostatic actuators (EHAs).
//
//   rectify simulate --scenario no-flow --frequency 10 --cycles 5 --out runs/nf10
//   rectify sweep --scenario loaded --from 10 --to 3500 --n 100 --out runs/vel
//
// Every subcommand takes --case FILE (default: cases/reference.toml) and
// --out DIR, and writes DIR/summary.json beside its CSV tables and plots.
// Errors in input name the file, key and value; the exit code is 2 for bad
// input, 1 for a failure of the computation.
//
// This front end runs the system commands; the finite-element ones are
// handed over to rectify-fe (app/fe_commands.h), so that a simulation does
// not load the FE stack.
#include "app/commands.h"
#include "app/fe_commands.h"
#include "app/main_common.h"

int main(int argc, char **argv)
{
  if (const int failed = rectify::app::forward_to_fe(argc, argv))
    return failed;
  CLI::App app{"rectify " RECTIFY_VERSION
               ": reed valves of smart-material pumps, from flow and structure to the whole actuator"};
  rectify::app::register_check_command(app);
  rectify::app::register_geometry_command(app);
  rectify::app::register_system_commands(app);
  rectify::app::register_map_commands(app);
  rectify::app::register_fe_command_stubs(app);
  rectify::app::register_diagnosis_commands(app);
  return rectify::app::run_app(app, argc, argv);
}
