// `rectify stiffness` and `rectify map-stiffness`: the reed's structure
// (stiffness_solver/).
#include <cmath>
#include <cstdio>
#include <sstream>

#include "app/commands.h"
#include "common/io.h"
#include "common/plot.h"
#include "common/progress.h"
#include "stiffness_solver/analytic.h"
#include "stiffness_solver/elasticity.h"

namespace rectify::app
{
  namespace
  {
    using namespace rectify::stiffness;

    /// Beam (E) and plate (E') values for the reed under its load, and the
    /// thesis's added mass: the bounds the FE results are read against.
    struct Bounds
    {
      double k_beam, k_plate, f1_beam, f1_plate;
      double added_mass_kg; ///< eq. 3.20
    };

    Bounds bounds(const StiffnessParameters &p)
    {
      const auto  &g  = p.geometry;
      const double I  = analytic::second_moment(g.reed_width_m, g.reed_thickness_m);
      const double E  = p.material.youngs_modulus_Pa;
      const double Ep = analytic::plate_modulus(E, p.material.poisson_ratio);
      const auto compliance = [&](double EI) {
        switch (p.settings.load)
          {
            case Load::tip_line:
              return analytic::tip_load_compliance(EI, g.reed_length_m);
            case Load::uniform_pressure:
              return analytic::uniform_load_compliance(EI, g.reed_length_m);
            default:
              return analytic::port_load_compliance(EI, g.reed_length_m, g.port_center_x_m,
                                                    0.5 * g.port_diameter_m);
          }
      };
      const double m_per_length = p.material.density_kg_per_m3 * g.reed_width_m * g.reed_thickness_m;
      return {1.0 / compliance(E * I), 1.0 / compliance(Ep * I),
              analytic::first_frequency_Hz(E * I, m_per_length, g.reed_length_m),
              analytic::first_frequency_Hz(Ep * I, m_per_length, g.reed_length_m),
              analytic::added_mass_kg(p.fluid.density_kg_per_m3, g.reed_length_m, g.reed_width_m)};
    }

    /// The mass and frequency of the first mode in oil. The added mass of
    /// eq. 3.20 is spread like the plate's own mass, so it scales the modal
    /// mass by (m_plate + m_added) / m_plate.
    struct InFluid
    {
      double modal_mass_kg, frequency_Hz;       // FE mode + eq. 3.20
      double eq321_mass_kg, eq321_frequency_Hz; // the thesis's eq. 3.21 with its factor
    };

    InFluid in_fluid(const StiffnessResult &r, const Bounds &b, double factor)
    {
      InFluid out{0, 0, 0, 0};
      if (!r.modes.empty() && r.modes[0].modal_mass_kg > 0)
        {
          const double scale = (r.plate_mass_kg + b.added_mass_kg) / r.plate_mass_kg;
          out.modal_mass_kg  = r.modes[0].modal_mass_kg * scale;
          out.frequency_Hz   = r.modes[0].frequency_Hz / std::sqrt(scale);
        }
      out.eq321_mass_kg      = factor * (r.plate_mass_kg + b.added_mass_kg);
      out.eq321_frequency_Hz = std::sqrt(r.k_N_per_m / out.eq321_mass_kg) / (2 * M_PI);
      return out;
    }

    std::string shape_csv(const StiffnessResult &r, const StiffnessParameters &p)
    {
      const nlohmann::json meta = {
        {"quantity", "reed underside deflection / mean tip deflection"},
        {"load", to_string(p.settings.load)},
        {"reed_length_m", p.geometry.reed_length_m},
        {"reed_width_m", p.geometry.reed_width_m},
        {"reed_thickness_m", p.geometry.reed_thickness_m},
        {"columns", "s_m: distance from the clamp line; phi: mean across the width; phi_centerline: at y = 0"},
        {"written_by", std::string("rectify ") + RECTIFY_VERSION}};
      std::ostringstream s;
      s << "# rectify reed shape (\"fe\"): z = tip_opening * phi(s)\n# meta: " << meta.dump()
        << "\ns_m,phi,phi_centerline\n";
      char buf[96];
      for (std::size_t i = 0; i < r.shape_s_m.size(); ++i)
        {
          std::snprintf(buf, sizeof(buf), "%.9g,%.9g,%.9g\n", r.shape_s_m[i], r.shape_phi[i],
                        r.shape_phi_centerline[i]);
          s << buf;
        }
      return s.str();
    }

    struct StiffnessOptions
    {
      std::string case_path = reference_case_path().string();
      std::string out_dir;
    };

    void stiffness_command(const StiffnessOptions &o)
    {
      const CaseFile file = load_case(o.case_path);
      const auto     p    = StiffnessParameters::from_case(file);
      const auto    &s    = p.settings;
      std::fprintf(stderr,
                   "rectify stiffness\n  case                   %s\n  reed                   %g x %g x %g m, E %g Pa, nu %g\n"
                   "  load                   %s\n  mesh                   %u x %u x %u cells, Q%u\n  out                    %s\n",
                   o.case_path.c_str(), p.geometry.reed_length_m, p.geometry.reed_width_m,
                   p.geometry.reed_thickness_m, p.material.youngs_modulus_Pa, p.material.poisson_ratio,
                   to_string(s.load).c_str(), s.cells_along_length, s.cells_across_width,
                   s.cells_through_thickness, s.fe_degree, o.out_dir.c_str());
      const std::filesystem::path out(o.out_dir);
      ensure_directory(out);
      SolveOptions so;
      so.vtu_file          = out / "reed.vtu";
      const auto    r      = solve_reed(p, so);
      const Bounds  b      = bounds(p);
      const InFluid fluid  = in_fluid(r, b, s.added_mass_factor);

      write_file_atomic(out / "shape.csv", shape_csv(r, p));
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
      nlohmann::json freqs = nlohmann::json::array(), kinds = nlohmann::json::array();
      for (const auto &m : r.modes)
        {
          freqs.push_back(m.frequency_Hz);
          kinds.push_back(m.kind);
        }

      // The "beam" shape of the reference case, to plot beside ours.
      CsvTable beam({"s_m", "phi_beam"});
      {
        const double L = p.geometry.reed_length_m, a = p.geometry.port_center_x_m;
        for (int i = 0; i <= 60; ++i)
          {
            const double x   = L * i / 60.0;
            const double phi = x <= a ? x * x * (3 * a - x) / (a * a * (3 * L - a)) : (3 * x - a) / (3 * L - a);
            const double row[2] = {x, phi};
            beam.add_row(row);
          }
        beam.write(out / "shape-beam.csv");
      }
      const bool plotted = render_plot(
        out / "shape",
        {{"Reed underside under the " + to_string(s.load) + " load, unit tip deflection",
          "distance from the clamp [mm]", "phi", false, false,
          {{out / "shape.csv", "s_m", "phi", "FE, mean across the width", "lines", 1e3, 1},
           {out / "shape.csv", "s_m", "phi_centerline", "FE, centre line", "lines", 1e3, 1},
           {out / "shape-beam.csv", "s_m", "phi_beam", "beam, point load at the port centre", "lines", 1e3, 1}}}});

      std::size_t n_small = 0;
      double      last_small_level = 0;
      for (const auto &l : r.levels)
        if (l.small_deflection)
          {
            ++n_small;
            last_small_level = std::max(last_small_level, l.level);
          }

      nlohmann::json summary = {
        {"command", "stiffness"},
        {"rectify_version", RECTIFY_VERSION},
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
          {"k_position_between_beam_and_plate", (r.k_N_per_m - b.k_beam) / (b.k_plate - b.k_beam)}}},
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
      write_json(out / "summary.json", summary);

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
      std::printf("%zu dofs, %.2f s; wrote %s\n", r.n_dofs, r.wall_time_s, (out / "summary.json").c_str());
    }
  } // namespace

  void register_stiffness_commands(CLI::App &app)
  {
    auto  o   = std::make_shared<StiffnessOptions>();
    auto *cmd = app.add_subcommand(
      "stiffness",
      "Reed stiffness, deflected shape and modes: 3D linear elasticity (deal.II, Q2 hexahedra).\n"
      "Example: rectify stiffness --out runs/stiffness");
    cmd->add_option("--case", o->case_path, "case file (TOML)")->capture_default_str();
    cmd->add_option("--out", o->out_dir, "output folder")->required();
    cmd->callback([o]() { stiffness_command(*o); });
  }
} // namespace rectify::app
