// `rectify stokes` (one opening) and `rectify map-resistance` (R(x)):
// stokes_solver/. Run with `mpirun -np N rectify stokes ...` for N processes.
#include <cmath>
#include <cstdio>

#include "app/commands.h"
#include "common/io.h"
#include "mesher/mesher.h"
#include "stokes_solver/stokes.h"

namespace rectify::app
{
  namespace
  {
    struct StokesOptions
    {
      std::string case_path;
      std::string out_dir;
      std::string opening;
      bool        no_vtu = false;
    };

    nlohmann::json result_json(const stokes::StokesResult &r)
    {
      return {{"R_Pa_s_per_m3", r.R_pressure_Pa_s_per_m3},
              {"R_dissipation_Pa_s_per_m3", r.R_dissipation_Pa_s_per_m3},
              {"inlet_pressure_Pa", r.inlet_pressure_Pa},
              {"outlet_pressure_Pa", r.outlet_pressure_Pa},
              {"inlet_flux_m3_per_s", r.inlet_flux_m3_per_s},
              {"outlet_flux_m3_per_s", r.outlet_flux_m3_per_s},
              {"mass_balance_rel_error", r.mass_balance_rel_error},
              {"reed_force_N", r.reed_force_N},
              {"A_eff_m2", r.A_eff_m2},
              {"inlet_area_m2", r.inlet_area_m2},
              {"outlet_area_m2", r.outlet_area_m2},
              {"n_dofs", r.n_dofs},
              {"n_velocity_dofs", r.n_velocity_dofs},
              {"n_pressure_dofs", r.n_pressure_dofs},
              {"n_cells", r.n_cells},
              {"solver", r.solver},
              {"iterations", r.iterations},
              {"n_processes", r.n_processes},
              {"setup_time_s", r.setup_time_s},
              {"assembly_time_s", r.assembly_time_s},
              {"solve_time_s", r.solve_time_s},
              {"wall_time_s", r.wall_time_s}};
    }

    void stokes_command(const StokesOptions &o)
    {
      const CaseFile file    = load_case(o.case_path);
      const auto     mp      = mesher::MeshParameters::from_case(file);
      const auto     fp      = stokes::FlowParameters::from_case(file);
      const double   opening = mesher::parse_length(o.opening, "--opening");
      stokes::MpiSession mpi;
      const bool         root = mpi.rank() == 0;
      if (root)
        echo_settings("stokes", {{"case", o.case_path},
                                 {"tip opening [m]", format_number(opening)},
                                 {"flow rate [m^3/s]", format_number(fp.settings.flow_rate_m3_per_s)},
                                 {"viscosity [Pa s]", format_number(fp.fluid.viscosity_Pa_s)},
                                 {"solver", fp.settings.solver},
                                 {"processes", std::to_string(mpi.size())},
                                 {"output", o.out_dir}});
      const auto valve = mesher::mesh_valve(mp, opening, root);
      const std::filesystem::path out(o.out_dir);
      if (root)
        ensure_directory(out);
      const auto r = stokes::solve_stokes(valve.mesh, fp, o.no_vtu ? std::filesystem::path{} : out, true);
      if (!root)
        return;
      const double rho = fp.fluid.density_kg_per_m3, mu = fp.fluid.viscosity_Pa_s, Q = fp.settings.flow_rate_m3_per_s;
      const auto  &g   = mp.geometry;
      nlohmann::json summary = result_json(r);
      summary["command"]         = "stokes";
      summary["rectify_version"] = RECTIFY_VERSION;
      summary["case"]            = o.case_path;
      summary["opening_m"]       = opening;
      summary["flow_rate_m3_per_s"] = Q;
      // Reynolds numbers: in the port (diameter D) and in the gap's exit
      // (2 h U / nu with U = Q / (perimeter h): independent of h).
      summary["reynolds"] = 4 * rho * Q / (M_PI * g.port_diameter_m * mu);
      summary["reynolds_gap_exit"] = 2 * rho * Q / ((2 * g.reed_length_m + g.reed_width_m) * mu);
      summary["mesh"] = mesher::to_json(valve.info);
      write_json(out / "summary.json", summary);
      std::printf("opening %s m: R = %.6e Pa s/m^3 (dissipation %.6e), dp = %.6g Pa, reed force %.6g N, "
                  "A_eff = %.6g m^2, mass balance %.1e, %zu DoFs, %s, %u iterations, %.1f s\n",
                  format_number(opening).c_str(), r.R_pressure_Pa_s_per_m3, r.R_dissipation_Pa_s_per_m3,
                  r.inlet_pressure_Pa - r.outlet_pressure_Pa, r.reed_force_N[2], r.A_eff_m2,
                  r.mass_balance_rel_error, r.n_dofs, r.solver.c_str(), r.iterations, r.wall_time_s);
    }
  } // namespace

  void register_stokes_commands(CLI::App &app)
  {
    auto  o   = std::make_shared<StokesOptions>();
    auto *cmd = app.add_subcommand(
      "stokes", "Stokes flow through the valve at one tip opening: R, force on the reed, VTU.\n"
                "Example: mpirun -np 2 rectify stokes --opening 100um --out runs/flow100");
    add_case_and_out(*cmd, o->case_path, o->out_dir);
    cmd->add_option("--opening", o->opening, "tip opening: metres, or with a unit (2e-6, 100um, 1.21mm)")
      ->required();
    cmd->add_flag("--no-vtu", o->no_vtu, "no VTU of velocity and pressure");
    cmd->callback([o]() { stokes_command(*o); });
  }
} // namespace rectify::app
