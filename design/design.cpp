#include "design/design.h"

#include <algorithm>
#include <chrono>
#include <dlfcn.h>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "common/io.h"
#include "common/plot.h"
#include "common/version.h"
#include "maps/map_set.h"
#include "mesher/parameters.h"
#include "stiffness_solver/elasticity.h"
#include "stiffness_solver/reed_analysis.h"

namespace rectify::design
{
  namespace
  {
    using Clock = std::chrono::steady_clock;
    double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

    /// OpenBLAS's thread count, set to one while it lives (if the BLAS is
    /// OpenBLAS). The reed's solve sums in another order with more BLAS
    /// threads (mpirun binds each process to one core, a plain run uses
    /// all): its shape then moves by 1e-11, enough to change TetGen's
    /// decisions and so R by 1e-5. One thread makes the map set the same
    /// for any number of processes.
    class SingleThreadedBlas
    {
    public:
      SingleThreadedBlas()
        : set_(reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads")))
        , get_(reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads")))
      {
        if (set_ != nullptr && get_ != nullptr)
          {
            previous_ = get_();
            set_(1);
          }
      }
      ~SingleThreadedBlas()
      {
        if (set_ != nullptr && get_ != nullptr)
          set_(previous_);
      }
      SingleThreadedBlas(const SingleThreadedBlas &)            = delete;
      SingleThreadedBlas &operator=(const SingleThreadedBlas &) = delete;

    private:
      void (*set_)(int);
      int (*get_)();
      int previous_ = 1;
    };

    DesignResult design_result(const ReedStage &rs, const stokes::SweepResult &sweep, double wall_time_s)
    {
      DesignResult r;
      r.sweep            = sweep;
      r.k_N_per_m        = rs.k_N_per_m;
      r.f1_in_fluid_Hz   = rs.fluid.frequency_Hz;
      r.stiffness_time_s = rs.wall_time_s;
      r.wall_time_s      = wall_time_s;
      return r;
    }

    std::string fmt(const char *format, double v)
    {
      char buf[64];
      std::snprintf(buf, sizeof(buf), format, v);
      return buf;
    }
  } // namespace

  nlohmann::json map_set_provenance(const CaseFile &file)
  {
    const auto sp = stiffness::StiffnessParameters::from_case(file);
    const auto mp = mesher::MeshParameters::from_case(file);
    const auto fp = stokes::FlowParameters::from_case(file);
    nlohmann::json tables = maps::physical_tables(sp.geometry, fp.fluid, sp.material);
    tables["mesh"] = mp.settings.to_json();
    tables["mesh"].erase("shape"); // the design meshes the FE shape, whatever the case's
    tables["mesh"].erase("shape_table");
    tables["flow"]      = fp.settings.to_json();
    tables["stiffness"] = sp.settings.to_json();
    return maps::hashed_tables(tables);
  }

  ReedStage solve_reed_stage(const CaseFile &file, const std::filesystem::path &reed_dir, bool write_files)
  {
    const auto t  = Clock::now();
    const auto sp = stiffness::StiffnessParameters::from_case(file);
    stiffness::SolveOptions so;
    if (write_files)
      {
        ensure_directory(reed_dir);
        so.vtu_file = reed_dir / "reed.vtu";
      }
    const auto r      = [&]() {
      const SingleThreadedBlas one_thread;
      return stiffness::solve_reed(sp, so);
    }();
    ReedStage rs;
    rs.bounds = stiffness::reed_bounds(sp);
    rs.fluid  = stiffness::in_fluid(r, rs.bounds, sp.settings.added_mass_factor);
    for (const auto &m : r.modes)
      rs.modes.push_back({m.frequency_Hz, m.kind, m.modal_mass_kg});
    rs.k_N_per_m     = r.k_N_per_m;
    rs.plate_mass_kg = r.plate_mass_kg;
    auto &reed = rs.reed;
    reed.stiffness_N_per_m       = r.k_N_per_m;
    reed.modal_mass_kg           = r.modes.empty() ? 0.0 : r.modes[0].modal_mass_kg;
    reed.modal_mass_in_fluid_kg  = rs.fluid.modal_mass_kg;
    reed.effective_mass_eq321_kg = rs.fluid.eq321_mass_kg;
    reed.frequency_Hz            = r.modes.empty() ? 0.0 : r.modes[0].frequency_Hz;
    reed.frequency_in_fluid_Hz   = rs.fluid.frequency_Hz;
    reed.plate_mass_kg           = r.plate_mass_kg;
    reed.added_mass_kg           = rs.bounds.added_mass_kg;
    reed.root_stress_per_opening_Pa_per_m             = r.root_stress_per_opening_Pa_per_m;
    reed.root_stress_beam_per_opening_Pa_per_m        = r.root_stress_beam_per_opening_Pa_per_m;
    reed.root_stress_concentration                    = r.root_stress_concentration;
    reed.second_mode_root_stress_per_opening_Pa_per_m = r.second_mode_root_stress_per_opening_Pa_per_m;
    rs.shape_csv   = stiffness::shape_csv(r, sp);
    rs.wall_time_s = seconds_since(t);
    if (write_files)
      {
        write_file_atomic(reed_dir / "shape.csv", rs.shape_csv);
        CsvTable beam({"s_m", "phi_beam"});
        const double L = sp.geometry.reed_length_m, a = sp.geometry.port_center_x_m;
        for (int i = 0; i <= 60; ++i)
          {
            const double row[2] = {L * i / 60.0, stiffness::beam_shape(L * i / 60.0, L, a)};
            beam.add_row(row);
          }
        beam.write(reed_dir / "shape-beam.csv");
        render_plot(reed_dir / "shape",
                    {{"Reed underside under the port load, unit tip opening: the shape the flow mesh uses",
                      "distance from the clamp [mm]", "phi", false, false,
                      {{reed_dir / "shape.csv", "s_m", "phi", "FE, mean across the width", "lines", 1e3, 1},
                       {reed_dir / "shape-beam.csv", "s_m", "phi_beam", "beam (point load at the port centre)",
                        "lines", 1e3, 1}}}});
        write_json(reed_dir / "reed.json", rs.to_json());
      }
    return rs;
  }

  nlohmann::json ReedStage::to_json() const
  {
    nlohmann::json modes_json = nlohmann::json::array();
    for (const auto &m : modes)
      modes_json.push_back({{"frequency_Hz", m.frequency_Hz}, {"kind", m.kind}, {"modal_mass_kg", m.modal_mass_kg}});
    return {{"reed", reed.to_json()},
            {"k_N_per_m", k_N_per_m},
            {"plate_mass_kg", plate_mass_kg},
            {"modes", modes_json},
            {"bounds",
             {{"k_beam_N_per_m", bounds.k_beam},
              {"k_plate_N_per_m", bounds.k_plate},
              {"f1_beam_Hz", bounds.f1_beam},
              {"f1_plate_Hz", bounds.f1_plate},
              {"added_mass_eq320_kg", bounds.added_mass_kg}}},
            {"in_fluid",
             {{"modal_mass_kg", fluid.modal_mass_kg},
              {"frequency_Hz", fluid.frequency_Hz},
              {"eq321_mass_kg", fluid.eq321_mass_kg},
              {"eq321_frequency_Hz", fluid.eq321_frequency_Hz}}},
            {"shape_hash", content_hash(shape_csv)},
            {"wall_time_s", wall_time_s}};
  }

  ReedStage ReedStage::from_json(const nlohmann::json &j, std::string shape_csv_text, const std::string &where)
  {
    try
      {
        ReedStage rs;
        rs.reed          = maps::ReedProperties::from_json(j.at("reed"), where);
        rs.k_N_per_m     = j.at("k_N_per_m").get<double>();
        rs.plate_mass_kg = j.at("plate_mass_kg").get<double>();
        for (const auto &m : j.at("modes"))
          rs.modes.push_back({m.at("frequency_Hz").get<double>(), m.at("kind").get<std::string>(),
                              m.at("modal_mass_kg").get<double>()});
        const auto &b = j.at("bounds");
        rs.bounds = {b.at("k_beam_N_per_m").get<double>(), b.at("k_plate_N_per_m").get<double>(),
                     b.at("f1_beam_Hz").get<double>(), b.at("f1_plate_Hz").get<double>(),
                     b.at("added_mass_eq320_kg").get<double>()};
        const auto &f = j.at("in_fluid");
        rs.fluid = {f.at("modal_mass_kg").get<double>(), f.at("frequency_Hz").get<double>(),
                    f.at("eq321_mass_kg").get<double>(), f.at("eq321_frequency_Hz").get<double>()};
        rs.shape_csv   = std::move(shape_csv_text);
        rs.wall_time_s = j.at("wall_time_s").get<double>();
        if (j.at("shape_hash").get<std::string>() != content_hash(rs.shape_csv))
          throw InputError(where + ": the reed's shape.csv is not the one this record was made with");
        return rs;
      }
    catch (const nlohmann::json::exception &e)
      {
        throw InputError(where + ": not a reed record (" + e.what() + ")");
      }
  }

  mesher::MeshParameters flow_mesh_parameters(const CaseFile &file, const std::filesystem::path &reed_dir)
  {
    auto mp                 = mesher::MeshParameters::from_case(file);
    mp.settings.shape       = "table";
    mp.settings.shape_table = reed_dir / "shape.csv";
    return mp;
  }

  nlohmann::json flow_fingerprint(const CaseFile &file, const std::string &shape_csv)
  {
    nlohmann::json fingerprint = {{"depends_on", map_set_provenance(file)},
                                  {"reed_shape_hash", content_hash(shape_csv)},
                                  {"rectify_version", RECTIFY_VERSION}};
    fingerprint["depends_on"].erase("stiffness"); // the shape's hash stands for it
    return fingerprint;
  }

  namespace
  {
    /// The map set's manifest.json: provenance, settings, the reed's modes,
    /// how far the openings reach, every solved opening and the
    /// interpolation checks.
    nlohmann::json map_set_manifest(const CaseFile &file, const stiffness::StiffnessParameters &sp,
                                    const stokes::SweepSettings &ss, const ReedStage &rs,
                                    const stokes::SweepResult &sweep, unsigned n_processes, double wall_time_s)
    {
      const auto  deps = map_set_provenance(file);
      const auto &pts  = sweep.points;
    nlohmann::json checks = nlohmann::json::array(), points = nlohmann::json::array(),
                     modes  = nlohmann::json::array();
      for (const auto &m : rs.modes)
        modes.push_back({{"frequency_Hz", m.frequency_Hz}, {"kind", m.kind}, {"modal_mass_kg", m.modal_mass_kg}});
      for (const auto &c : sweep.checks)
        checks.push_back({{"from_m", c.from_m}, {"to_m", c.to_m}, {"midpoint_m", c.midpoint_m},
                          {"R_error", c.R_error}, {"A_eff_error", c.A_error}, {"passed", c.passed},
                          {"limited", c.limited}});
      for (const auto &p : pts)
        points.push_back({{"opening_m", p.opening_m},
                          {"n_dofs", p.n_dofs},
                          {"iterations", p.iterations},
                          {"mass_balance_rel_error", p.mass_balance_rel_error},
                          {"wall_time_s", p.wall_time_s},
                          {"mesh_time_s", p.mesh_time_s},
                          {"setup_time_s", p.setup_time_s},
                          {"assembly_time_s", p.assembly_time_s},
                          {"solve_time_s", p.solve_time_s},
                          {"loading_time_s", p.loading_time_s}});
      return {
        {"source", "rectify design: Stokes flow (deal.II, P2-P1) on meshes of the FE reed shape; 3D elasticity"},
        {"rectify_version", RECTIFY_VERSION},
        {"code_revision", source_revision()},
        {"build", build_info()},
        {"created", utc_now()},
        {"case", file.name()},
        {"depends_on", deps},
        {"settings",
         {{"design", ss.to_json()},
          {"reed_shape", "fe: the stiffness solver's deflection under the " + stiffness::to_string(sp.settings.load) +
                           " load, scaled to the tip opening (reed/shape.csv)"},
          {"reed_shape_hash", content_hash(rs.shape_csv)},
          {"closed_R_Pa_s_per_m3", 1e17},
          {"n_processes", n_processes}}},
        {"reed_modes", modes},
        {"reach", {{"stop_lift_m", ss.stop_lift_m},
                   {"last_opening_m", ss.to_m},
                   {"short_of_stop_m", std::max(0.0, ss.stop_lift_m - ss.to_m)},
                   {"why", ss.short_of_stop().empty() ? std::string("the openings reach the reed's stop")
                                                      : ss.short_of_stop()}}},
        {"points", points},
        {"interpolation_error",
         {{"tolerance", ss.tolerance},
          {"R_max_rel", sweep.max_R_error},
          {"A_eff_max_rel", sweep.max_A_error},
          {"converged", sweep.converged},
          {"meaning", "largest miss of the interpolant without a midpoint at that midpoint, over the checks "
                      "that passed: the final map, which includes the midpoints, is at least this close"},
          {"checks", checks}}},
        {"wall_time_s", wall_time_s},
        {"stiffness_wall_time_s", rs.wall_time_s}};
    }

    /// The map set: R(x) from the closed value through every solved
    /// opening, A_eff(x), the seated area, the reed, and the fluid's
    /// loading where every opening has it (its largest asymmetry in
    /// max_asymmetry).
    maps::MapSet assemble_map_set(const CaseFile &file, const stiffness::StiffnessParameters &sp,
                                  const std::filesystem::path &out, const ReedStage &rs,
                                  const stokes::SweepResult &sweep, nlohmann::json manifest, double &max_asymmetry)
    {
      const auto  mp  = flow_mesh_parameters(file, out / "reed");
      const auto &pts = sweep.points;
      std::vector<double> x{0.0}, R{1e17}, xa, A;
      for (const auto &p : pts)
        {
          x.push_back(p.opening_m), R.push_back(p.R_Pa_s_per_m3);
          xa.push_back(p.opening_m), A.push_back(p.A_eff_m2);
        }
      const double seated = sp.geometry.ports_area_m2(); // every port's mouth
    nlohmann::json r_meta = {{"source", "rectify design"}, {"closed", "1e17 Pa s/m^3 at x = 0 (the thesis's)"},
                               {"below_first_open_node", "the first interval's power law, capped at the closed value"}};
      maps::MapSet set(maps::ResistanceMap(x, R, (out / "resistance.csv").string(), r_meta,
                                           maps::Interpolation::log_log),
                       maps::AreaMap(xa, A, (out / "area.csv").string(), {{"source", "rectify design"}}), seated, rs.reed,
                       std::move(manifest));
      const bool with_loading = !pts.empty() && std::all_of(pts.begin(), pts.end(), [](const auto &p) {
        return p.has_loading();
      });
      max_asymmetry = 0;
      if (with_loading)
        {
          std::vector<maps::LoadingMap::Row> rows;
          const auto   shape     = mp.sampled_shape();
          const double film_area = mesher::seat_film_modal_area_m2(mp.geometry, [&](double s) { return shape(s); });
          for (const auto &p : pts)
            {
              rows.push_back({p.opening_m, p.damping_fixed_dp_N_s_per_m, p.A_modal_m2, p.added_mass_kg,
                              p.damping_N_s_per_m, p.loading_asymmetry});
              max_asymmetry = std::max(max_asymmetry, p.loading_asymmetry);
            }
          set.set_loading(maps::LoadingMap(std::move(rows), (out / "loading.csv").string(),
                                           {{"source", "rectify design: two Stokes solves per opening on one matrix, "
                                                       "and the potential flow"},
                                            {"film_modal_area_m2", film_area},
                                            {"film_modal_area_meaning",
                                             "the reed's shape (1 at the tip) integrated over its footprint less "
                                             "the port: the seat film's suction limit per unit pressure "
                                             "(docs/fluid-loading.md)"}}));
        }

      return set;
    }

    /// points.csv, map-curve.csv (and loading-curve.csv) and their plots
    /// beside the map set.
    void write_map_tables(const std::filesystem::path &out, const maps::MapSet &set, const ReedStage &rs,
                          const stokes::SweepResult &sweep, const stokes::SweepSettings &ss)
    {
      const auto  &pts          = sweep.points;
      const double seated       = set.seated_area_m2();
      const bool   with_loading = set.loading().has_value();
    CsvTable table(stokes::OpeningPoint::columns());
      for (const auto &p : pts)
        table.add_row(p.row());
      table.write(out / "points.csv");
      CsvTable curve({"opening_m", "R_Pa_s_per_m3", "A_eff_m2", "R_thesis_Pa_s_per_m3", "port_area_m2"});
      const auto thesis = maps::thesis_resistance_map(25);
      for (int k = 0; k <= 240; ++k)
        {
          const double xi  = ss.from_m * std::pow(ss.to_m / ss.from_m, k / 240.0);
          const double row[5] = {xi, set.resistance().evaluate(xi).resistance, set.area().evaluate(xi).area,
                                 thesis.evaluate(xi).resistance, seated};
          curve.add_row(row);
        }
      curve.write(out / "map-curve.csv");
      if (with_loading)
        {
          CsvTable lc({"opening_m", "damping_fixed_dp_N_s_per_m", "A_modal_m2", "added_mass_kg", "eq320_added_mass_kg",
                       "eq321_mass_kg", "modal_mass_kg"});
          for (int k = 0; k <= 240; ++k)
            {
              const double xi = ss.from_m * std::pow(ss.to_m / ss.from_m, k / 240.0);
              const auto   v  = set.loading()->evaluate(xi);
              const double row[7] = {xi, v.damping, v.A_modal, v.added_mass, rs.bounds.added_mass_kg, rs.fluid.eq321_mass_kg,
                                     rs.reed.modal_mass_kg};
              lc.add_row(row);
            }
          lc.write(out / "loading-curve.csv");
          render_plot(out / "loading",
                      {{"Squeeze-film damping of the reed (at a fixed pressure drop, referred to the tip)",
                        "tip opening [um]", "c [N s/m]", true, true,
                        {{out / "points.csv", "opening_m", "damping_fixed_dp_N_s_per_m", "Stokes, fixed dp", "points", 1e6, 1},
                         {out / "points.csv", "opening_m", "damping_N_s_per_m", "Stokes, port shut (Q = 0)", "points", 1e6, 1},
                         {out / "loading-curve.csv", "opening_m", "damping_fixed_dp_N_s_per_m", "map", "lines", 1e6, 1}}},
                       {"Added mass on the reed (potential flow, referred to the tip)", "tip opening [um]", "mass [mg]", true,
                        true,
                        {{out / "points.csv", "opening_m", "added_mass_kg", "potential flow, solved", "points", 1e6, 1e6},
                         {out / "loading-curve.csv", "opening_m", "added_mass_kg", "map", "lines", 1e6, 1e6},
                         {out / "loading-curve.csv", "opening_m", "eq320_added_mass_kg", "eq. 3.20 (unconfined)", "lines", 1e6, 1e6},
                         {out / "loading-curve.csv", "opening_m", "eq321_mass_kg", "eq. 3.21: 2.75 (m_plate + m_added)", "lines", 1e6, 1e6},
                         {out / "loading-curve.csv", "opening_m", "modal_mass_kg", "first mode's mass in vacuum", "lines", 1e6, 1e6}}}});
        }
      render_plot(out / "resistance",
                  {{"Valve resistance R(x): Stokes on the FE reed shape", "tip opening [um]", "R [Pa s/m^3]", true, true,
                    {{out / "points.csv", "opening_m", "R_Pa_s_per_m3", "Stokes (mean pressures), solved", "points", 1e6, 1},
                     {out / "map-curve.csv", "opening_m", "R_Pa_s_per_m3", "map (log-log monotone cubic)", "lines", 1e6, 1},
                     {out / "points.csv", "opening_m", "R_dissipation_Pa_s_per_m3", "Stokes (dissipation)", "points", 1e6, 1},
                     {out / "points.csv", "opening_m", "R_thin_gap_Pa_s_per_m3", "thin-gap theory", "linespoints", 1e6, 1},
                     {out / "map-curve.csv", "opening_m", "R_thesis_Pa_s_per_m3", "thesis fit (Fig. 3.7)", "lines", 1e6, 1}}},
                   {"Effective force area A_eff = F_z / dp of the open reed", "tip opening [um]", "area [mm^2]", true, false,
                    {{out / "points.csv", "opening_m", "A_eff_m2", "Stokes, solved", "points", 1e6, 1e6},
                     {out / "map-curve.csv", "opening_m", "A_eff_m2", "map", "lines", 1e6, 1e6},
                     {out / "map-curve.csv", "opening_m", "port_area_m2", "port area (seated reed; ~ the thesis's A_r)",
                      "lines", 1e6, 1e6}}}});

    }

    /// report.md: the reed, R(x) and A_eff(x) per opening, the fluid's loading.
    std::string map_set_report(const CaseFile &file, const stiffness::StiffnessParameters &sp,
                               const stokes::SweepSettings &ss, const std::string &made_by, const ReedStage &rs,
                               const stokes::SweepResult &sweep, const maps::MapSet &set, double max_asymmetry)
    {
      const auto  &pts          = sweep.points;
      const double seated       = set.seated_area_m2();
      const bool   with_loading = set.loading().has_value();
    std::ostringstream md;
      md << "# Map set: " << file.name() << "\n\n"
         << "Made by " << made_by << " (rectify " << RECTIFY_VERSION << ", " << source_revision() << ") on "
         << utc_now() << ".\n\n## The reed (stiffness solver)\n\n"
         << "| quantity | FE | beam (E) | plate (E') | thesis |\n|---|---:|---:|---:|---:|\n"
         << "| k_r [N/m] | " << fmt("%.5g", rs.k_N_per_m) << " | " << fmt("%.5g", rs.bounds.k_beam) << " | "
         << fmt("%.5g", rs.bounds.k_plate) << " | 6650 |\n"
         << "| f1 in vacuum [Hz] | " << fmt("%.5g", rs.reed.frequency_Hz) << " | " << fmt("%.5g", rs.bounds.f1_beam) << " | "
         << fmt("%.5g", rs.bounds.f1_plate) << " | |\n"
         << "| f1 in oil, eq. 3.20's added mass [Hz] | " << fmt("%.5g", rs.fluid.frequency_Hz) << " | | | |\n"
         << "| m_r, eq. 3.21 (x" << sp.settings.added_mass_factor << ") [kg] | " << fmt("%.4g", rs.fluid.eq321_mass_kg)
         << " | | | 3.643e-4 |\n"
         << "| f1 with eq. 3.21's mass [Hz] | " << fmt("%.5g", rs.fluid.eq321_frequency_Hz) << " | | | 680 |\n\n"
         << "Modes in vacuum:";
      for (std::size_t i = 0; i < rs.modes.size(); ++i)
        md << (i ? "," : "") << " " << fmt("%.5g", rs.modes[i].frequency_Hz) << " Hz (" << rs.modes[i].kind << ")";
      md << ". Plate mass " << fmt("%.4g", rs.plate_mass_kg) << " kg, first-mode mass at the tip "
         << fmt("%.4g", rs.reed.modal_mass_kg) << " kg, added mass (eq. 3.20) " << fmt("%.4g", rs.bounds.added_mass_kg)
         << " kg.\n\n"
         << "The flow meshes use the reed's FE shape under the port load (reed/shape.png), not the beam shape.\n\n"
         << "## R(x) and A_eff(x)\n\n"
         << "Openings chosen by accuracy: " << ss.initial_openings << " log-spaced from "
         << format_number(ss.from_m * 1e6) << " to " << format_number(ss.to_m * 1e6)
         << " um (" << (ss.short_of_stop().empty() ? std::string("the reed's stop") : ss.short_of_stop())
         << "), then geometric midpoints wherever the map's interpolant (log R and A_eff, monotone cubic in log x) "
            "missed the solved midpoint by more than "
         << format_number(ss.tolerance * 100) << " %. " << pts.size() << " openings solved ("
         << sweep.n_resumed << " from a checkpoint); interpolation error achieved: R "
         << fmt("%.3f", 100 * sweep.max_R_error) << " %, A_eff " << fmt("%.3f", 100 * sweep.max_A_error)
         << " %" << (sweep.converged ? "" : " (NOT converged: some intervals hit min_ratio or max_openings)")
         << ".\n\n| opening [um] | R [Pa s/m^3] | R (dissipation) | thin-gap | Stokes / thin-gap | A_eff [mm^2] | "
            "mass balance | DoFs | iterations | wall [s] |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
      for (const auto &p : pts)
        md << "| " << fmt("%.4g", p.opening_m * 1e6) << " | " << fmt("%.5g", p.R_Pa_s_per_m3) << " | "
           << fmt("%.5g", p.R_dissipation_Pa_s_per_m3) << " | " << fmt("%.5g", p.R_thin_gap_Pa_s_per_m3) << " | "
           << fmt("%.3f", p.R_Pa_s_per_m3 / p.R_thin_gap_Pa_s_per_m3) << " | " << fmt("%.3f", p.A_eff_m2 * 1e6)
           << " | " << fmt("%.0e", p.mass_balance_rel_error) << " | " << fmt("%.0f", p.n_dofs) << " | "
           << fmt("%.0f", p.iterations) << " | " << fmt("%.1f", p.wall_time_s) << " |\n";
      md << "\nSeated reed: the force acts on the port area, " << fmt("%.4g", seated * 1e6)
         << " mm^2; open, on A_eff(x). Reynolds number in the port "
         << fmt("%.3g", pts.empty() ? 0.0 : pts.front().reynolds_port) << ", at the gap's exit "
         << fmt("%.3g", pts.empty() ? 0.0 : pts.front().reynolds_gap_exit)
         << " (at the map's flow rate).\n\n"
            "Files: manifest.json (provenance), resistance.csv, area.csv (the map set), points.csv (every "
            "solved opening), resistance.png, reed/ (shape.csv, shape.png, reed.vtu).\n";
      if (with_loading)
        {
          md << "\n## The reed's fluid loading (docs/fluid-loading.md)\n\n"
                "Per opening, a second solve on the same matrix (the reed moving at unit tip velocity with its FE "
                "shape, the port shut) and the potential flow. Referred to the tip. The 2x2 map's largest "
                "asymmetry: "
             << fmt("%.1e", max_asymmetry)
             << " (reciprocity). Eq. 3.20's added mass " << fmt("%.4g", rs.bounds.added_mass_kg)
             << " kg; eq. 3.21's mass, 2.75 (m_plate + m_added), " << fmt("%.4g", rs.fluid.eq321_mass_kg)
             << " kg; first mode's mass in vacuum " << fmt("%.4g", rs.reed.modal_mass_kg)
             << " kg.\n\n| opening [um] | c, port shut [N s/m] | c, fixed dp [N s/m] | A_modal [mm^2] | added mass "
                "[mg] | asymmetry | loading [s] |\n|---:|---:|---:|---:|---:|---:|---:|\n";
          for (const auto &p : pts)
            md << "| " << fmt("%.4g", p.opening_m * 1e6) << " | " << fmt("%.4g", p.damping_N_s_per_m) << " | "
               << fmt("%.4g", p.damping_fixed_dp_N_s_per_m) << " | " << fmt("%.3f", p.A_modal_m2 * 1e6) << " | "
               << fmt("%.4g", p.added_mass_kg * 1e6) << " | " << fmt("%.0e", p.loading_asymmetry) << " | "
               << fmt("%.1f", p.loading_time_s) << " |\n";
          md << "\nFiles: loading.csv (in the map set), loading-curve.csv, loading.png.\n";
        }
      return md.str();
    }
  } // namespace

  DesignResult write_map_set(const CaseFile &file, const std::filesystem::path &out, const ReedStage &rs,
                             const stokes::SweepResult &sweep, unsigned n_processes, double wall_time_s,
                             const std::string &made_by)
  {
    const auto sp            = stiffness::StiffnessParameters::from_case(file);
    const auto ss            = stokes::SweepSettings::from_case(file);
    double     max_asymmetry = 0;
    const auto set = assemble_map_set(file, sp, out, rs, sweep,
                                      map_set_manifest(file, sp, ss, rs, sweep, n_processes, wall_time_s), max_asymmetry);
    write_map_tables(out, set, rs, sweep, ss);
    const std::string report = map_set_report(file, sp, ss, made_by, rs, sweep, set, max_asymmetry);
    set.write(out);
    write_file_atomic(out / "report.md", report);
    DesignResult result = design_result(rs, sweep, wall_time_s);
    result.manifest     = set.manifest();
    return result;
  }

  DesignResult run_design(const CaseFile &file, const std::filesystem::path &out, const stokes::MpiSession &mpi)
  {
    const auto start = Clock::now();
    const bool root  = mpi.rank() == 0;
    const auto fp    = stokes::FlowParameters::from_case(file);
    const auto ss    = stokes::SweepSettings::from_case(file);
    const auto deps  = map_set_provenance(file);
    const auto reed_dir = out / "reed", partial = out / "partial";
    // A finished map set of another case in the folder is not overwritten.
    if (std::filesystem::exists(out / "manifest.json"))
      {
        std::ifstream  in(out / "manifest.json");
        nlohmann::json old;
        try
          {
            old = nlohmann::json::parse(in);
          }
        catch (const nlohmann::json::exception &)
          {
          }
        if (!old.contains("depends_on") || old["depends_on"] != deps)
          throw InputError("'" + out.string() + "' holds a map set made for another case (or not a map set): "
                           "choose another --out, or remove it");
      }
    if (root)
      {
        ensure_directory(reed_dir);
        ensure_directory(partial);
      }

    // 1. The reed: stiffness, modes, the deflected shape under the port load.
    const ReedStage rs = solve_reed_stage(file, reed_dir, root);
    if (root)
      std::fprintf(stderr, "design: reed k = %.6g N/m, f1 %.6g Hz in vacuum, %.6g Hz in oil (%.1f s)\n",
                   rs.k_N_per_m, rs.reed.frequency_Hz, rs.fluid.frequency_Hz, rs.wall_time_s);
    (void)mpi.broadcast({}); // the shape file exists for every process

    // 2. The flow over openings, on meshes of the FE shape.
    const auto mp    = flow_mesh_parameters(file, reed_dir);
    const auto sweep = stokes::resistance_sweep(mp, fp, ss, partial, flow_fingerprint(file, rs.shape_csv), mpi);
    if (!root)
      return design_result(rs, sweep, seconds_since(start));
    // 3. The map set.
    const double wall = seconds_since(start);
    return write_map_set(file, out, rs, sweep, mpi.size(), wall,
                         "`rectify design`, " + std::to_string(mpi.size()) + " process(es), " + fmt("%.0f", wall) +
                           " s wall");
  }
} // namespace rectify::design
