// `rectify stokes` (one opening) and `rectify map-resistance` (R(x)):
// stokes_solver/. Run with `mpirun -np N rectify stokes ...` for N processes.
#include <cmath>
#include <cstdio>
#include <memory>

#include "app/commands.h"
#include "app/fe_lock.h"
#include "common/io.h"
#include "common/version.h"
#include "common/plot.h"
#include "maps/resistance_map.h"
#include "mesher/mesher.h"
#include "stokes_solver/stokes.h"
#include "stokes_solver/resistance_sweep.h"
#include "stokes_solver/thin_gap.h"

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
      bool        navier_stokes = false;
      double      flow_rate     = std::nan(""); ///< not given: the case's (NaN cannot be typed: app/command_helpers.cpp)
    };

    nlohmann::json result_json(const stokes::StokesResult &r)
    {
      return {{"R_Pa_s_per_m3", r.R_pressure_Pa_s_per_m3},
              {"R_dissipation_Pa_s_per_m3", r.R_dissipation_Pa_s_per_m3},
              {"R_gradient_dissipation_Pa_s_per_m3", r.R_gradient_dissipation_Pa_s_per_m3},
              {"inlet_pressure_Pa", r.inlet_pressure_Pa},
              {"outlet_pressure_Pa", r.outlet_pressure_Pa},
              {"inlet_flux_m3_per_s", r.inlet_flux_m3_per_s},
              {"outlet_flux_m3_per_s", r.outlet_flux_m3_per_s},
              {"mass_balance_rel_error", r.mass_balance_rel_error},
              {"reed_force_N", r.reed_force_N},
              {"A_eff_m2", r.A_eff_m2},
              {"kinetic_energy_flux_W", r.kinetic_energy_flux_W},
              {"inlet_area_m2", r.inlet_area_m2},
              {"outlet_area_m2", r.outlet_area_m2},
              {"n_dofs", r.n_dofs},
              {"n_velocity_dofs", r.n_velocity_dofs},
              {"n_pressure_dofs", r.n_pressure_dofs},
              {"n_cells", r.n_cells},
              {"solver", r.solver},
              {"iterations", r.iterations},
              {"newton_iterations", r.newton_iterations},
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
      auto           fp      = stokes::FlowParameters::from_case(file);
      const double   opening = mesher::parse_length(o.opening, "--opening");
      if (!std::isnan(o.flow_rate))
        {
          if (!(o.flow_rate > 0) || !std::isfinite(o.flow_rate))
            throw InputError("--flow-rate = " + format_number(o.flow_rate) + ": must be positive (m^3/s)");
          fp.settings.flow_rate_m3_per_s = o.flow_rate;
        }
      fp.settings.navier_stokes = o.navier_stokes;
      stokes::MpiSession mpi;
      const bool         root = mpi.rank() == 0;
      if (root)
        echo_settings("stokes", {{"case", o.case_path},
                                 {"tip opening [m]", format_number(opening)},
                                 {"flow rate [m^3/s]", format_number(fp.settings.flow_rate_m3_per_s)},
                                 {"viscosity [Pa s]", format_number(fp.fluid.viscosity_Pa_s)},
                                 {"solver", fp.settings.solver},
                                 {"equations", o.navier_stokes ? "Stokes, then steady Navier-Stokes (Newton)" : "Stokes"},
                                 {"processes", std::to_string(mpi.size())},
                                 {"output", o.out_dir}});
      const std::filesystem::path out(o.out_dir);
      OutputLock                  lock;
      lock_on_root(lock, out, mpi, false);
      const auto valve = mesher::mesh_valve(mp, opening, root);
      // The folder appears with the results: the solver makes it for its VTU
      // output after solving, or here (no VTU); an interrupted solve leaves none.
      const auto motion  = stokes::reed_motion(mp);
      const bool loading = fp.settings.reed_loading == "solve";
      const auto r = stokes::solve_stokes(valve.mesh, fp, o.no_vtu ? std::filesystem::path{} : out, true,
                                          loading ? &motion : nullptr);
      if (!root)
        return;
      lock.acquire(out);
      const double mu = fp.fluid.viscosity_Pa_s, Q = fp.settings.flow_rate_m3_per_s;
      nlohmann::json summary = result_json(r);
      summary["command"]         = "stokes";
      summary["rectify_version"] = RECTIFY_VERSION;
      summary["build"] = build_info();
      summary["case"]            = o.case_path;
      summary["opening_m"]       = opening;
      summary["flow_rate_m3_per_s"] = Q;
      const auto re                  = stokes::reynolds_numbers(mp.geometry, fp.fluid, Q);
      summary["reynolds"]          = re.port;
      summary["reynolds_gap_exit"] = re.gap_exit;
      summary["mesh"] = mesher::to_json(valve.info);
      summary["equations"] = o.navier_stokes ? "navier-stokes" : "stokes";
      summary["R_thin_gap_Pa_s_per_m3"] = stokes::thin_gap_R(mp, valve.info.closed_to_m, opening, mu);
      summary["stokes_R_Pa_s_per_m3"] = r.stokes_R_Pa_s_per_m3;
      const double shift = r.R_pressure_Pa_s_per_m3 / r.stokes_R_Pa_s_per_m3 - 1;
      if (o.navier_stokes)
        summary["inertia_shift_rel"] = shift;
      if (loading)
        summary["reed_loading"] = stokes::to_json(r.loading);
      nlohmann::json ports = nlohmann::json::array();
      for (const auto &p : r.ports)
        ports.push_back({{"centre_m", p.centre_m},
                         {"area_m2", p.area_m2},
                         {"inflow", p.round ? "parabola (round)" : "developed duct profile"},
                         {"flow_m3_per_s", p.flow_m3_per_s},
                         {"flow_share", p.flow_m3_per_s / Q},
                         {"pressure_drop_Pa", p.pressure_drop_Pa}});
      summary["ports"] = ports;
      write_json(out / "summary.json", summary);
      if (r.ports.size() > 1)
        for (std::size_t k = 0; k < r.ports.size(); ++k)
          std::printf("port %zu at (%.4g, %.4g) mm: %.4f of the flow, pressure drop %.6g Pa\n", k + 1,
                      1e3 * r.ports[k].centre_m[0], 1e3 * r.ports[k].centre_m[1], r.ports[k].flow_m3_per_s / Q,
                      r.ports[k].pressure_drop_Pa);
      if (loading)
        std::printf("reed's fluid loading: squeeze-film damping %.6g N s/m (port shut), %.6g N s/m (fixed dp); "
                    "flow drawn per unit tip velocity %.6g m^2; added mass %.6g kg; asymmetry %.1e; %.1f s\n",
                    r.loading.K_vv_N_s_per_m, r.loading.damping_fixed_dp_N_s_per_m, r.loading.A_modal_m2,
                    r.loading.added_mass_kg, r.loading.asymmetry, r.loading.solve_time_s);
      if (o.navier_stokes)
        std::printf("inertia (steady Navier-Stokes, Re %.3g in the port, %.3g at the gap's exit): R = %.6e "
                    "against Stokes %.6e Pa s/m^3 (%+.3f %%), %u Newton steps\n",
                    summary["reynolds"].get<double>(), summary["reynolds_gap_exit"].get<double>(),
                    r.R_pressure_Pa_s_per_m3, r.stokes_R_Pa_s_per_m3, 100 * shift, r.newton_iterations);
      std::printf("opening %s m: R = %.6e Pa s/m^3 (dissipation %.6e; thin-gap theory %.6e), dp = %.6g Pa, "
                  "reed force %.6g N, A_eff = %.6g m^2, mass balance %.1e, %zu DoFs, %s, %u iterations, %.1f s\n",
                  format_number(opening).c_str(), r.R_pressure_Pa_s_per_m3, r.R_dissipation_Pa_s_per_m3,
                  summary["R_thin_gap_Pa_s_per_m3"].get<double>(),
                  r.inlet_pressure_Pa - r.outlet_pressure_Pa, r.reed_force_N[2], r.A_eff_m2,
                  r.mass_balance_rel_error, r.n_dofs, r.solver.c_str(), r.iterations, r.wall_time_s);
    }
    struct MapOptions
    {
      std::string case_path;
      std::string out_dir;
      std::string openings = "2e-6:1210e-6:25";
    };

    /// "FROM:TO:N" -> N openings, log-spaced.
    std::vector<double> log_range(const std::string &text)
    {
      double      from = 0, to = 0;
      long        n    = 0;
      char        tail = 0;
      if (std::sscanf(text.c_str(), "%lf:%lf:%ld%c", &from, &to, &n, &tail) != 3 || !(from > 0) ||
          !(to > from) || n < 2 || !std::isfinite(to))
        throw InputError("--openings = \"" + text + "\": expected FROM:TO:N in metres, 0 < FROM < TO, N >= 2");
      std::vector<double> x;
      for (long k = 0; k < n; ++k)
        x.push_back(k == n - 1 ? to : from * std::pow(to / from, static_cast<double>(k) / static_cast<double>(n - 1)));
      return x;
    }

    void map_resistance_command(const MapOptions &o)
    {
      const CaseFile file     = load_case(o.case_path);
      const auto     mp       = mesher::MeshParameters::from_case(file);
      const auto     fp       = stokes::FlowParameters::from_case(file);
      const auto     openings = log_range(o.openings);
      stokes::MpiSession mpi;
      const bool         root = mpi.rank() == 0;
      const std::filesystem::path out(o.out_dir);
      if (root)
        echo_settings("map-resistance", {{"case", o.case_path},
                                         {"openings [m]", o.openings + " (log-spaced)"},
                                         {"processes", std::to_string(mpi.size())},
                                         {"output", o.out_dir}});
      const auto &g = mp.geometry;
      const auto &s = mp.settings;
      nlohmann::json fingerprint = {
        {"openings_m", openings},
        {"geometry", {g.reed_length_m, g.reed_width_m, g.reed_thickness_m, g.port_diameter_m, g.port_center_x_m,
                      g.port_length_m, g.pocket_length_m, g.pocket_width_m, g.pocket_height_m, g.outlet_face}},
        {"mesh", {s.shape, s.shape_table.string(), s.size_reed_m, s.size_far_m, s.size_growth, s.station_spacing_m,
                  s.port_segments, s.gap_layers, s.reed_layers, s.above_layers, s.slab_margin_m, s.blend_distance_m,
                  s.port_layer_m, s.gap_cutoff_ratio}},
        {"fluid", {fp.fluid.viscosity_Pa_s, fp.fluid.density_kg_per_m3}},
        {"flow", {fp.settings.flow_rate_m3_per_s, fp.settings.outlet_pressure_Pa, fp.settings.solver,
                  fp.settings.tolerance}}};
      // An outline's description: two outlines may share the numbers above
      // (their bounding box and first port). The shorthand's fingerprint is kept.
      if (!g.is_shorthand())
        fingerprint["outline"] = g.to_json();
      OutputLock lock;
      lock_on_root(lock, out, mpi, true);
      std::size_t n_resumed = 0;
      const auto  solved    = stokes::fixed_resistance_sweep(mp, fp, openings, out, fingerprint, mpi, &n_resumed);
      if (!root)
        return;

      CsvTable points(stokes::OpeningPoint::columns()), thesis({"opening_m", "R_Pa_s_per_m3"});
      std::vector<double> map_x{0.0}, map_R{1e17}; // closed valve: the thesis's value (sec. 3.2.4)
      for (const auto &p : solved)
        {
          points.add_row(p.row());
          map_x.push_back(p.opening_m);
          map_R.push_back(p.R_Pa_s_per_m3);
        }
      for (int k = 0; k <= 200; ++k) // the thesis's fit, drawn finely over the same range
        {
          const double x    = openings.front() * std::pow(openings.back() / openings.front(), k / 200.0);
          const double t[2] = {x, std::max(2.34e11 * std::exp(-0.025 * x * 1e6), 4.5e8)};
          thesis.add_row(t);
        }
      points.write(out / "map-points.csv");
      thesis.write(out / "thesis-fit.csv");
      nlohmann::json meta = fingerprint;
      meta["source"]      = "rectify map-resistance: Stokes flow, R = (mean inlet p - mean outlet p) / Q";
      meta["closed_R"]    = "1e17 Pa s/m^3 at x = 0, the thesis's closed-valve value";
      meta["written_by"]  = std::string("rectify ") + RECTIFY_VERSION;
      const maps::ResistanceMap map(map_x, map_R, (out / "resistance-map.csv").string(), meta);
      map.write(out / "resistance-map.csv");
      render_plot(out / "resistance-map",
                  {{"Valve resistance R(x): Stokes flow vs the thesis's fit (Fig. 3.7)", "tip opening [um]",
                    "R [Pa s/m^3]", true, true,
                    {{out / "map-points.csv", "opening_m", "R_Pa_s_per_m3", "Stokes (pressures)", "linespoints", 1e6, 1},
                     {out / "map-points.csv", "opening_m", "R_dissipation_Pa_s_per_m3", "Stokes (dissipation)", "points", 1e6, 1},
                     {out / "map-points.csv", "opening_m", "R_thin_gap_Pa_s_per_m3", "thin-gap theory", "lines", 1e6, 1},
                     {out / "thesis-fit.csv", "opening_m", "R_Pa_s_per_m3", "thesis fit (Fig. 3.7)", "lines", 1e6, 1}}}});
      write_json(out / "summary.json", {{"command", "map-resistance"},
                                        {"rectify_version", RECTIFY_VERSION},
                                        {"build", build_info()},
                                        {"case", o.case_path},
                                        {"opening_m", points.column("opening_m")},
                                        {"R_Pa_s_per_m3", points.column("R_Pa_s_per_m3")},
                                        {"R_dissipation_Pa_s_per_m3", points.column("R_dissipation_Pa_s_per_m3")},
                                        {"A_eff_m2", points.column("A_eff_m2")},
                                        {"R_thin_gap_Pa_s_per_m3", points.column("R_thin_gap_Pa_s_per_m3")},
                                        {"mass_balance_rel_error", points.column("mass_balance_rel_error")},
                                        {"n_processes", mpi.size()},
                                        {"runs_resumed", n_resumed},
                                        {"settings", fingerprint}});
      std::printf("R(x) at %zu openings in %s (resistance-map.csv, resistance-map.png)\n", openings.size(),
                  out.c_str());
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
    cmd->add_flag("--navier-stokes", o->navier_stokes,
                  "then solve steady Navier-Stokes (Newton) and report how far inertia moves R");
    cmd->add_option("--flow-rate", o->flow_rate, "flow rate [m^3/s] (default: the case's [flow] flow_rate_m3_per_s)");
    cmd->callback([o]() { stokes_command(*o); });

    auto  m    = std::make_shared<MapOptions>();
    auto *mcmd = app.add_subcommand(
      "map-resistance", "R(x) over log-spaced tip openings, as a map the system model reads; resumable.\n"
                        "Example: mpirun -np 2 rectify map-resistance --out runs/R-map");
    add_case_and_out(*mcmd, m->case_path, m->out_dir);
    mcmd->add_option("--openings", m->openings, "FROM:TO:N tip openings [m], log-spaced")->capture_default_str();
    mcmd->callback([m]() { map_resistance_command(*m); });
  }
} // namespace rectify::app
