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
#include <cstdio>
#include <exception>

#include "app/commands.h"
#include "common/case_file.h"
#include "common/version.h"

int main(int argc, char **argv)
{
  CLI::App app{"rectify " RECTIFY_VERSION
               ": reed valves of smart-material pumps, from flow and structure to the whole actuator"};
  app.require_subcommand(1);
  app.set_version_flag("--version", rectify::version_text(),
                       "Print the version, the source revision and the libraries' versions, then exit");
  rectify::app::register_check_command(app);
  rectify::app::register_system_commands(app);
  rectify::app::register_map_commands(app);
  rectify::app::register_mesh_commands(app);
  rectify::app::register_stokes_commands(app);
  rectify::app::register_design_commands(app);
  rectify::app::register_stiffness_commands(app);
  rectify::app::register_diagnosis_commands(app);
  try
    {
      app.parse(argc, argv);
    }
  catch (const CLI::ParseError &e)
    {
      return app.exit(e);
    }
  catch (const rectify::InputError &e)
    {
      std::fprintf(stderr, "rectify: error: %s\n", e.what());
      return 2;
    }
  catch (const std::exception &e)
    {
      std::fprintf(stderr, "rectify: failed: %s\n", e.what());
      return 1;
    }
  return 0;
}
