// `rectify stiffness` and `rectify map-stiffness`: the reed's structure
// (stiffness_solver/).
#include <cmath>
#include <cstdio>
#include <sstream>

#include "app/commands.h"
#include "common/io.h"
#include "common/output_lock.h"
#include "common/version.h"
#include "common/plot.h"
#include "stiffness_solver/elasticity.h"
#include "stiffness_solver/reed_analysis.h"
#include "stiffness_solver/reed_sweep.h"

namespace rectify::app
{
  namespace
  {
    using namespace rectify::stiffness;

    struct StiffnessOptions
    {
      std::string case_path;
      std::string out_dir;
    };

    /// The geometrically nonlinear check at the stop's lift, as summary.json
    /// holds it (null where the lift is within small-deflection theory).
    nlohmann::json large_deflection_json(const StiffnessResult &r, const StiffnessParameters &p)
    {
      if (!r.large_deflection)
        return nullptr;
      const auto &c = *r.large_deflection;
      if (!c.failure.empty())
        return {{"opening_m", c.opening_m}, {"failure", c.failure}};
      return {{"opening_m", c.opening_m},
              {"opening_over_length", c.opening_m / p.geometry.reed_length_m},
              {"force_N", c.force_N},
              {"secant_stiffness_N_per_m", c.secant_stiffness_N_per_m},
              {"stiffness_ratio", c.stiffness_ratio},
              {"root_stress_Pa", c.root_stress_Pa},
              {"root_stress_ratio", c.root_stress_ratio},
              {"tip_shortening_m", c.tip_shortening_m},
              {"load_steps", c.load_steps},
              {"newton_iterations", c.newton_iterations},
              {"definitions",
               {{"stiffness_ratio", "force / opening of the geometrically nonlinear solve (St Venant-Kirchhoff, "
                                    "the same dead load) over the linear k_N_per_m"},
                {"root_stress_ratio", "its root bending stress (Green-Lagrange strain) over the linear "
                                      "root_stress_per_opening_Pa_per_m x opening_m"}}}};
    }

    void print_large_deflection(const StiffnessResult &r, const StiffnessParameters &p)
    {
      if (!r.large_deflection)
        return;
      const auto &c = *r.large_deflection;
      if (!c.failure.empty())
        {
          std::printf("at the stop's lift %.4g mm, beyond small-deflection theory: no large-deflection check (%s); "
                      "the linear results there are unchecked\n",
                      c.opening_m * 1e3, c.failure.c_str());
          return;
        }
      std::printf("at the stop's lift %.4g mm (%.2f of L), beyond small-deflection theory: the geometrically "
                  "nonlinear solve needs %.4f x the linear force (secant k %.5g N/m), root stress %.4f x the "
                  "linear, the tip %.3g mm nearer the clamp\n",
                  c.opening_m * 1e3, c.opening_m / p.geometry.reed_length_m, c.stiffness_ratio,
                  c.secant_stiffness_N_per_m, c.root_stress_ratio, c.tip_shortening_m * 1e3);
    }

    void echo_stiffness(const StiffnessOptions &o, const StiffnessParameters &p)
    {
      const auto &s = p.settings;
      echo_settings("stiffness",
                    {{"case", o.case_path},
                     {"reed [m]", format_number(p.geometry.reed_length_m) + " x " +
                                    format_number(p.geometry.reed_width_m) + " x " +
                                    format_number(p.geometry.reed_thickness_m) +
                                    (p.geometry.is_shorthand() ? std::string()
                                                               : " (outline of " + std::to_string(p.geometry.reed_corners().size()) +
                                                                   " corners: its length, width and thickness)")},
                     {"material", "E " + format_number(p.material.youngs_modulus_Pa) + " Pa, nu " +
                                    format_number(p.material.poisson_ratio)},
                     {"load", to_string(s.load)},
                     {"mesh", std::to_string(s.cells_along_length) + " x " +
                                std::to_string(s.cells_across_width) + " x " +
                                std::to_string(s.cells_through_thickness) + " cells, Q" +
                                std::to_string(s.fe_degree)},
                     {"out", o.out_dir}});
    }

    /// loads.csv and the load levels as JSON.
    nlohmann::json write_loads(const StiffnessResult &r, const std::filesystem::path &out)
    {
      CsvTable loads({"level", "force_N", "tip_deflection_m", "tip_center_deflection_m",
                      "deflection_ratio", "root_stress_beam_Pa", "small_deflection"});
      nlohmann::json levels = nlohmann::json::array();
      for (const auto &l : r.levels)
        {
          const double row[7] = {l.level, l.force_N, l.tip_deflection_m, l.tip_center_deflection_m,
                                 l.deflection_ratio, l.root_stress_beam_Pa, l.small_deflection ? 1.0 : 0.0};
          loads.add_row(row);
          levels.push_back({{"level", l.level},
                            {"force_N", l.force_N},
                            {"tip_deflection_m", l.tip_deflection_m},
                            {"deflection_ratio", l.deflection_ratio},
                            {"root_stress_beam_Pa", l.root_stress_beam_Pa},
                            {"small_deflection", l.small_deflection}});
        }
      loads.write(out / "loads.csv");
      return levels;
    }

    /// The FE shape beside the beam's (shape-beam.csv, shape.png); whether it was plotted.
    bool plot_shape(const StiffnessParameters &p, const std::filesystem::path &out)
    {
      const auto &s = p.settings;
      // The "beam" shape of the reference case, to plot beside ours.
      CsvTable beam({"s_m", "phi_beam"});
      {
        const double L = p.geometry.reed_length_m, a = p.geometry.port_center_x_m;
        for (int i = 0; i <= 60; ++i)
          {
            const double x      = L * i / 60.0;
            const double row[2] = {x, beam_shape(x, L, a)};
            beam.add_row(row);
          }
        beam.write(out / "shape-beam.csv");
      }
      return render_plot(
        out / "shape",
        {{"Reed underside under the " + to_string(s.load) + " load, unit tip deflection",
          "distance from the clamp [mm]", "phi", false, false,
          {{out / "shape.csv", "s_m", "phi", "FE, mean across the width", "lines", 1e3, 1},
           {out / "shape.csv", "s_m", "phi_centerline", "FE, centre line", "lines", 1e3, 1},
           {out / "shape-beam.csv", "s_m", "phi_beam", "beam, point load at the port centre", "lines", 1e3, 1}}}});

    }

    nlohmann::json stiffness_summary(const StiffnessOptions &o, const StiffnessParameters &p, const StiffnessResult &r,
                                     const ReedBounds &b, const InFluid &fluid, const nlohmann::json &levels,
                                     bool plotted)
    {
      const auto &s = p.settings;
      nlohmann::json freqs = nlohmann::json::array(), kinds = nlohmann::json::array();
      for (const auto &m : r.modes)
        {
          freqs.push_back(m.frequency_Hz);
          kinds.push_back(m.kind);
        }

      double last_small_level = 0;
      for (const auto &l : r.levels)
        if (l.small_deflection)
          {
            last_small_level = std::max(last_small_level, l.level);
          }

      nlohmann::json summary = {
        {"command", "stiffness"},
        {"rectify_version", RECTIFY_VERSION},
        {"build", build_info()},
        {"case", o.case_path},
        {"load", to_string(s.load)},
        {"k_N_per_m", r.k_N_per_m},
        {"k_center_N_per_m", r.k_center_N_per_m},
        {"tip_deflection_m", r.levels.front().tip_deflection_m},
        {"tip_deflection_per_unit_load_m", r.levels.front().tip_deflection_m / r.levels.front().level},
        {"force_per_unit_load", r.force_per_level},
        {"frequencies_Hz", freqs},
        {"mode_kinds", kinds},
        {"modal_mass_kg", r.modes.empty() ? 0.0 : r.modes[0].modal_mass_kg},
        {"plate_mass_kg", r.plate_mass_kg},
        {"root_stress_per_opening_Pa_per_m", r.root_stress_per_opening_Pa_per_m},
        {"root_stress_beam_per_opening_Pa_per_m", r.root_stress_beam_per_opening_Pa_per_m},
        {"root_stress_concentration", r.root_stress_concentration},
        {"second_mode_root_stress_per_opening_Pa_per_m", r.second_mode_root_stress_per_opening_Pa_per_m},
        {"added_mass_kg", b.added_mass_kg},
        {"modal_mass_in_fluid_kg", fluid.modal_mass_kg},
        {"frequency_in_fluid_Hz", fluid.frequency_Hz},
        {"effective_mass_eq321_kg", fluid.eq321_mass_kg},
        {"frequency_eq321_Hz", fluid.eq321_frequency_Hz},
        {"added_mass_factor_eq321", s.added_mass_factor},
        {"load_levels", levels},
        {"small_deflection_up_to_level", last_small_level},
        {"small_deflection_criterion", "tip deflection / length <= " + format_number(s.max_linear_deflection_ratio)},
        {"bounds",
         {{"k_beam_N_per_m", b.k_beam},
          {"k_plate_N_per_m", b.k_plate},
          {"f1_beam_Hz", b.f1_beam},
          {"f1_plate_Hz", b.f1_plate},
          {"k_position_between_beam_and_plate", (r.k_N_per_m - b.k_beam) / (b.k_plate - b.k_beam)},
          {"of", p.geometry.is_shorthand() ? "the rectangular reed"
                                           : "a rectangle of the outline's length and mean width (area / length)"}}},
        {"geometry", p.geometry.to_json()},
        {"thesis_k_N_per_m", 6650.0},
        {"n_dofs", r.n_dofs},
        {"n_cells", r.n_cells},
        {"wall_time_s", r.wall_time_s},
        {"phase_times_s", r.phase_times},
        {"definitions",
         {{"k_N_per_m", "total load / tip deflection averaged over the tip face"},
          {"modal_mass_kg", "first mode, phi^T M phi with the mean tip deflection 1"},
          {"frequency_in_fluid_Hz", "first mode with the added mass of eq. 3.20 spread like the plate's mass"},
          {"frequency_eq321_Hz", "sqrt(k / (2.75 (m_plate + m_added))) / 2 pi: the thesis's eq. 3.21"}}},
        {"files", {"reed.vtu", "shape.csv", "loads.csv", plotted ? "shape.png" : ""}}};
      summary["large_deflection_at_stop"] = large_deflection_json(r, p);
      return summary;
    }

    void print_stiffness(const StiffnessParameters &p, const StiffnessResult &r, const ReedBounds &b,
                         const InFluid &fluid)
    {
      const auto &s = p.settings;
      std::printf("k = %.6g N/m (tip face mean; tip centre %.6g); beam %.6g, plate %.6g; thesis 6650\n",
                  r.k_N_per_m, r.k_center_N_per_m, b.k_beam, b.k_plate);
      for (std::size_t i = 0; i < r.modes.size(); ++i)
        std::printf("mode %zu: %.6g Hz (%s)\n", i + 1, r.modes[i].frequency_Hz, r.modes[i].kind.c_str());
      std::printf("modal mass %.4g kg (plate %.4g kg), added mass (eq. 3.20) %.4g kg: %.5g Hz in oil\n",
                  r.modes.empty() ? 0.0 : r.modes[0].modal_mass_kg, r.plate_mass_kg, b.added_mass_kg,
                  fluid.frequency_Hz);
      std::printf("thesis eq. 3.21 (x%.3g): %.4g kg, %.5g Hz\n", s.added_mass_factor, fluid.eq321_mass_kg,
                  fluid.eq321_frequency_Hz);
      for (const auto &l : r.levels)
        std::printf("load %.4g: tip %.4g m (%.3g of L), root stress %.3g Pa: %s\n", l.level,
                    l.tip_deflection_m, l.deflection_ratio, l.root_stress_beam_Pa,
                    l.small_deflection ? "small deflection" : "beyond small-deflection theory");
      std::printf("root stress per tip opening %.4g MPa/um (FE, width mean; beam theory %.4g), corners %.3g x that "
                  "four thicknesses off the clamp; second bending mode %.4g MPa/um\n",
                  r.root_stress_per_opening_Pa_per_m * 1e-12, r.root_stress_beam_per_opening_Pa_per_m * 1e-12,
                  r.root_stress_concentration, r.second_mode_root_stress_per_opening_Pa_per_m * 1e-12);
      print_large_deflection(r, p);
    }

    void stiffness_command(const StiffnessOptions &o)
    {
      const CaseFile file = load_case(o.case_path);
      const auto     p    = StiffnessParameters::from_case(file);
      const auto    &s    = p.settings;
      echo_stiffness(o, p);
      const std::filesystem::path out(o.out_dir);
      OutputLock                  lock;
      lock.acquire(out);
      SolveOptions so;
      so.vtu_file          = out / "reed.vtu";
      // Beyond small-deflection theory at the stop's lift: checked there.
      const double lift = p.geometry.stop_lift_m();
      if (lift > s.max_linear_deflection_ratio * p.geometry.reed_length_m)
        so.large_deflection_opening_m = lift;
      const auto       r     = solve_reed(p, so);
      const ReedBounds b     = reed_bounds(p);
      const InFluid    fluid = in_fluid(r, b, s.added_mass_factor);
      write_file_atomic(out / "shape.csv", shape_csv(r, p));
      const auto levels  = write_loads(r, out);
      const bool plotted = plot_shape(p, out);
      write_json(out / "summary.json", stiffness_summary(o, p, r, b, fluid, levels, plotted));
      print_stiffness(p, r, b, fluid);
      std::printf("%zu dofs, %.2f s; wrote %s\n", r.n_dofs, r.wall_time_s, (out / "summary.json").c_str());
    }
    // ---------------------------------------------------------- map-stiffness
    struct MapStiffnessOptions
    {
      std::string case_path;
      std::string out_dir;
      std::string thickness; ///< FROM:TO:N [m]
    };

    std::vector<double> parse_range(const std::string &text, const std::string &option)
    {
      std::vector<std::string> parts;
      std::stringstream        in(text);
      for (std::string part; std::getline(in, part, ':');)
        parts.push_back(part);
      double      from = 0, to = 0;
      std::size_t n    = 0;
      try
        {
          if (parts.size() != 3)
            throw std::invalid_argument("parts");
          std::size_t used = 0;
          from             = std::stod(parts[0], &used);
          if (used != parts[0].size())
            throw std::invalid_argument("from");
          to = std::stod(parts[1], &used);
          if (used != parts[1].size())
            throw std::invalid_argument("to");
          const long count = std::stol(parts[2], &used);
          if (used != parts[2].size() || count < 1)
            throw std::invalid_argument("n");
          n = static_cast<std::size_t>(count);
        }
      catch (const std::exception &)
        {
          throw InputError(option + " '" + text + "': expected FROM:TO:N, e.g. 0.1e-3:0.2e-3:10");
        }
      if (!(from > 0) || !(to >= from) || !std::isfinite(to) || (n == 1 && to != from))
        throw InputError(option + " '" + text + "': need 0 < FROM <= TO, and N >= 2 for a range");
      std::vector<double> v(n);
      for (std::size_t i = 0; i < n; ++i)
        v[i] = n == 1 ? from : from + (to - from) * static_cast<double>(i) / static_cast<double>(n - 1);
      return v;
    }

    void map_stiffness_command(const MapStiffnessOptions &o)
    {
      const CaseFile              file        = load_case(o.case_path);
      const auto                  base        = StiffnessParameters::from_case(file);
      const auto                  thicknesses = parse_range(o.thickness, "--thickness");
      const std::filesystem::path out(o.out_dir);
      for (double t : thicknesses)
        if (t >= 0.5 * std::min(base.geometry.reed_length_m, base.geometry.reed_width_m))
          throw InputError("--thickness " + format_number(t) + " m: a reed must be a thin plate");
      echo_settings("map-stiffness",
                    {{"case", o.case_path},
                     {"thickness [m]", o.thickness + " (" + std::to_string(thicknesses.size()) + " values)"},
                     {"out", o.out_dir}});
      OutputLock lock;
      lock.acquire(out);
      const auto r = reed_thickness_sweep(base, thicknesses, out);
      r.map.write(out / "reed-map.csv");
      const double slope   = r.k_loglog_slope;
      const bool   plotted = render_plot(
        out / "reed-map",
        {{"Reed stiffness vs thickness (log-log slope " + format_number(std::round(slope * 1000) / 1000) + ")",
          "thickness [mm]", "k_r [N/m]", true, true,
          {{out / "reed-map.csv", "thickness_m", "stiffness_N_per_m", "k_r (FE)", "linespoints", 1e3, 1}}},
         {"First natural frequency vs thickness", "thickness [mm]", "f1 [Hz]", true, true,
          {{out / "reed-map.csv", "thickness_m", "frequency_Hz", "in vacuum", "linespoints", 1e3, 1},
           {out / "reed-map.csv", "thickness_m", "frequency_in_fluid_Hz", "in oil (eq. 3.20)", "linespoints", 1e3, 1},
           {out / "reed-map.csv", "thickness_m", "frequency_eq321_Hz", "thesis eq. 3.21", "linespoints", 1e3, 1}}},
         {"Root bending stress per unit tip opening (the clamp's underside)", "thickness [mm]", "stress [MPa/um]",
          false, false,
          {{out / "reed-map.csv", "thickness_m", "root_stress_per_opening_Pa_per_m", "FE, width mean", "linespoints",
            1e3, 1e-12},
           {out / "reed-map.csv", "thickness_m", "root_stress_beam_per_opening_Pa_per_m", "beam theory",
            "linespoints", 1e3, 1e-12}}}});
      nlohmann::json summary = {{"command", "map-stiffness"},
                                {"rectify_version", RECTIFY_VERSION},
                                {"build", build_info()},
                                {"case", o.case_path},
                                {"thickness_m", r.map.column("thickness_m")},
                                {"k_N_per_m", r.map.column("stiffness_N_per_m")},
                                {"frequency_Hz", r.map.column("frequency_Hz")},
                                {"modal_mass_kg", r.map.column("modal_mass_kg")},
                                {"frequency_in_fluid_Hz", r.map.column("frequency_in_fluid_Hz")},
                                {"effective_mass_eq321_kg", r.map.column("effective_mass_eq321_kg")},
                                {"root_stress_per_opening_Pa_per_m", r.map.column("root_stress_per_opening_Pa_per_m")},
                                {"root_stress_beam_per_opening_Pa_per_m",
                                 r.map.column("root_stress_beam_per_opening_Pa_per_m")},
                                {"root_stress_concentration", r.map.column("root_stress_concentration")},
                                {"wall_time_s", r.map.column("wall_time_s")},
                                {"k_loglog_slope", slope},
                                {"runs_resumed", r.n_resumed},
                                {"files", {"reed-map.csv", plotted ? "reed-map.png" : ""}}};
      write_json(out / "summary.json", summary);
      std::printf("k ~ t^%.4f over %zu thicknesses; wrote %s\n", slope, thicknesses.size(),
                  (out / "reed-map.csv").c_str());
    }
  } // namespace

  void register_stiffness_commands(CLI::App &app)
  {
    auto  o   = std::make_shared<StiffnessOptions>();
    auto *cmd = app.add_subcommand(
      "stiffness",
      "Reed stiffness, deflected shape and modes: 3D linear elasticity (deal.II, Q2 hexahedra).\n"
      "Example: rectify stiffness --out runs/stiffness");
    add_case_and_out(*cmd, o->case_path, o->out_dir);
    cmd->callback([o]() { stiffness_command(*o); });

    auto  m    = std::make_shared<MapStiffnessOptions>();
    auto *mcmd = app.add_subcommand(
      "map-stiffness",
      "Reed stiffness, first mode and masses vs thickness (design what-if), as a map.\n"
      "Example: rectify map-stiffness --thickness 0.1e-3:0.2e-3:10 --out runs/reed-map");
    add_case_and_out(*mcmd, m->case_path, m->out_dir);
    mcmd->add_option("--thickness", m->thickness, "reed thicknesses FROM:TO:N [m]")->required();
    mcmd->callback([m]() { map_stiffness_command(*m); });
  }
} // namespace rectify::app
