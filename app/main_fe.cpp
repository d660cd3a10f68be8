// rectify-fe: the finite-element commands of rectify (mesh, stokes,
// map-resistance, stiffness, map-stiffness, design, whatif), linked with deal.II,
// PETSc, MPI, TetGen and CGAL. Users call them through `rectify`, which
// hands these commands over to this program (app/fe_commands.h).
#include "app/commands.h"
#include "app/main_common.h"

int main(int argc, char **argv)
{
  CLI::App app{"rectify " RECTIFY_VERSION ": the finite-element stages (run through `rectify`)"};
  rectify::app::register_mesh_commands(app);
  rectify::app::register_stokes_commands(app);
  rectify::app::register_design_commands(app);
  rectify::app::register_whatif_command(app);
  rectify::app::register_stiffness_commands(app);
  return rectify::app::run_app(app, argc, argv);
}
