// `rectify design`: the valve of a case file, every map (design/).
// Run with `mpirun -np N rectify design ...` for N processes.
#include <cstdio>

#include "app/commands.h"
#include "app/fe_lock.h"
#include "common/io.h"
#include "design/design.h"

namespace rectify::app
{
  namespace
  {
    struct DesignOptions
    {
      std::string case_path;
      std::string out_dir;
    };

    void design_command(const DesignOptions &o)
    {
      const CaseFile file = load_case(o.case_path, false);
      const auto     ss   = stokes::SweepSettings::from_case(file);
      const std::filesystem::path out(o.out_dir);
      stokes::MpiSession mpi;
      const bool         root = mpi.rank() == 0;
      if (root)
        {
          echo_settings("design", {{"case", o.case_path},
                                   {"openings [m]", format_number(ss.from_m) + " .. " + format_number(ss.to_m) +
                                                      ", " + std::to_string(ss.initial_openings) +
                                                      " to start, then midpoints"},
                                   {"stop", ss.short_of_stop().empty() ? "the openings reach it, " +
                                                                           format_number(ss.stop_lift_m) + " m"
                                                                     : ss.short_of_stop()},
                                   {"interpolation tolerance", format_number(ss.tolerance)},
                                   {"processes", std::to_string(mpi.size())},
                                   {"output", o.out_dir}});
        }
      OutputLock lock;
      lock_on_root(lock, out, mpi, true);
      const auto r = design::run_design(file, out, mpi);
      if (!root)
        return;
      std::printf("map set %s: k_r = %.6g N/m, f1 in oil %.5g Hz; R(x), A_eff(x) at %zu openings (%zu from the "
                  "checkpoint), interpolation error R %.3f %%, A_eff %.3f %% (tolerance %.3g %%)%s; %.0f s\n",
                  out.c_str(), r.k_N_per_m, r.f1_in_fluid_Hz, r.sweep.points.size(), r.sweep.n_resumed,
                  100 * r.sweep.max_R_error,
                  100 * r.sweep.max_A_error, 100 * ss.tolerance,
                  r.sweep.converged ? "" : " NOT CONVERGED (min_ratio or max_openings reached)", r.wall_time_s);
    }
  } // namespace

  void register_design_commands(CLI::App &app)
  {
    auto  o   = std::make_shared<DesignOptions>();
    auto *cmd = app.add_subcommand(
      "design",
      "One valve design, every map: reed stiffness and FE shape, then Stokes R(x) and A_eff(x) on that shape\n"
      "over openings chosen by accuracy ([design] in the case), written as a map set the system model reads\n"
      "([valves] map_set, or --map-set on simulate and sweep). Resumable.\n"
      "Example: mpirun -np 2 rectify design --out runs/map-set");
    add_case_and_out(*cmd, o->case_path, o->out_dir);
    cmd->callback([o]() { design_command(*o); });
  }
} // namespace rectify::app
