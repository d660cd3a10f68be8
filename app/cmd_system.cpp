// `rectify simulate` and `rectify sweep`: the lumped EHA model (system/).
#include <cmath>
#include <cstdio>
#include <map>
#include <span>
#include <sstream>

#include "app/commands.h"
#include "common/io.h"
#include "common/output_lock.h"
#include "common/version.h"
#include "common/plot.h"
#include "common/progress.h"
#include "system/simulation.h"
#include "system/sweep.h"

namespace rectify::app
{
  namespace
  {
    constexpr double psi = 6894.757;

    /// Options shared by simulate and sweep.
    struct CommonOptions
    {
      std::string case_path;
      std::string out_dir;
      std::string scenario  = "no-flow";
      bool        ideal_valves = false;
      double      current_pp_A   = std::nan("");
      double      current_bias_A = std::nan("");
      double      rtol           = std::nan("");
      bool        fd_jacobian    = false;
      std::string map_set;
      std::string fluid_loading;
      double      seat_film_m = std::nan("");
      std::string film_suction_limit;
      bool        thesis_model = false;

      void add_to(CLI::App &cmd)
      {
        add_case_and_out(cmd, case_path, out_dir);
        cmd.add_option("--scenario", scenario, "no-flow (output mass 1e12 kg) or loaded")
          ->check(CLI::IsMember({"no-flow", "loaded"}))
          ->capture_default_str();
        cmd.add_flag("--ideal-valves", ideal_valves,
                     "binary valves without dynamics (thesis Figs. 5.3, 5.4)");
        cmd.add_option("--current-pp", current_pp_A,
                       "coil current peak-to-peak [A] (default: case [drive])");
        cmd.add_option("--current-bias", current_bias_A,
                       "coil current bias [A] (default: case [drive])");
        cmd.add_option("--rtol", rtol, "CVODE relative tolerance (default: case [solver])");
        cmd.add_flag("--fd-jacobian", fd_jacobian,
                     "finite-difference Jacobian instead of the analytic one (cross-check)");
        cmd.add_option("--map-set", map_set,
                       "both valves from this map set (`rectify design`): R(x), A_eff(x), k_r, m_r; "
                       "wins over the case's [valves] and [reed] values");
        cmd.add_option("--fluid-loading", fluid_loading,
                       "the reed's fluid loading: thesis (constant damping ratio, eq. 3.21's mass) or map (squeeze "
                       "film, added mass and displaced flow from the map sets; docs/fluid-loading.md); default: "
                       "case [reed] fluid_loading")
          ->check(CLI::IsMember({"thesis", "map"}));
        cmd.add_option("--seat-film-m", seat_film_m,
                       "with the map's fluid loading: the thinnest film under a seated reed [m] (the seat's "
                       "roughness; the loading is read at x + this); default: case [reed] seat_film_m, 0");
        cmd.add_option("--film-suction-limit", film_suction_limit,
                       "with the map's fluid loading: cavitation (the film's suction on a lifting reed stops at "
                       "[reed] film_cavitation_pressure_Pa) or none; default: case [reed] film_suction_limit")
          ->check(CLI::IsMember({"cavitation", "none"}));
        cmd.add_flag("--thesis-model", thesis_model,
                     "the thesis's model: no stop and no cavitation ([reed] stop = \"off\", [fluid] cavitation = "
                     "\"none\"); its numbers to the bit, states the hardware cannot reach included");
      }

      /// Parameters with the command-line overrides applied.
      system::SystemParameters parameters(const CaseFile &file) const
      {
        auto p = system::SystemParameters::from_case(file);
        if (!fluid_loading.empty())
          system::use_fluid_loading(p, file, fluid_loading);
        if (!map_set.empty())
          system::use_map_set(p, file, map_set);
        system::use_seat_film(p, seat_film_m, film_suction_limit);
        if (thesis_model)
          system::use_thesis_model(p);
        if (!std::isnan(current_pp_A))
          p.drive.current_pp_A = current_pp_A;
        if (!std::isnan(current_bias_A))
          p.drive.current_bias_A = current_bias_A;
        if (!std::isnan(rtol))
          {
            if (!(rtol >= 1e-12 && rtol <= 1e-2))
              throw InputError("--rtol " + format_number(rtol) + ": must be in [1e-12, 1e-2]");
            p.solver.relative_tolerance = rtol;
          }
        if (fd_jacobian)
          p.solver.jacobian = "finite-difference";
        system::DriveParameters::check_currents(p.drive.current_pp_A, p.drive.current_bias_A, "--current-pp",
                                                "--current-bias");
        return p;
      }

      system::RunOptions run_options(const system::SystemParameters &p) const { return system::run_options(p.solver); }
    };

    /// Where each valve's R(x) and force area come from, for the echo.
    std::string valve_maps_text(const system::SystemParameters &p)
    {
      const auto one = [&](std::size_t v) {
        return p.valves.map_set[v].empty() ? "R(x) " + p.valves.resistance_map + " with A_r" :
                                             "map set " + p.valves.map_set[v];
      };
      return one(0) == one(1) ? one(0) : "outlet: " + one(0) + "; inlet: " + one(1);
    }

    std::string reed_text(const system::SystemParameters &p)
    {
      char buf[96];
      std::snprintf(buf, sizeof(buf), "k_r %.6g N/m, m_r %.6g kg", p.reed.stiffness_N_per_m, p.reed.effective_mass_kg);
      return std::string(buf) + " (" + p.reed.source + "); fluid loading: " +
             (p.reed.fluid_loading == "map" ?
                "squeeze film, added mass, displaced flow from the map sets (seat film " +
                  format_number(p.reed.seat_film_m) + " m, suction limit " +
                  (p.reed.film_suction_limit == "cavitation" ?
                     "cavitation at " + format_number(p.reed.film_cavitation_pressure_Pa) + " Pa abs" :
                     std::string("none")) +
                  ")" :
                "the thesis's (damping ratio, eq. 3.21's mass)");
    }

    /// The stop, cavitation and the stress's source and limits, for the echo.
    std::string limits_text(const system::SystemParameters &p)
    {
      char buf[160];
      std::snprintf(buf, sizeof(buf), "stop %s at %.4g mm (restitution %g); ", p.reed.stop == "on" ? "on" : "OFF",
                    p.reed.stop_lift_m * 1e3, p.reed.stop_restitution);
      std::string text = buf;
      text += p.fluid.cavitates() ? "cavitation at " + format_number(p.fluid.cavitation_pressure_Pa) + " Pa abs; " :
                                    std::string("cavitation OFF; ");
      std::snprintf(buf, sizeof(buf), "root stress %.4g MPa per mm of opening (",
                    p.reed.root_stress_per_opening_Pa_per_m * 1e-9);
      return text + buf + p.reed.stress_source + "), endurance limit " +
             format_number(p.material.endurance_limit_Pa) + " Pa, ultimate " +
             format_number(p.material.ultimate_strength_Pa) + " Pa";
    }

    system::Drive make_drive(const system::SystemParameters &p, double frequency)
    {
      if (p.drive.waveform == "sine")
        return system::Drive::sine(frequency, p.drive.current_pp_A, p.drive.current_bias_A);
      return system::Drive::from_csv(p.drive.waveform, frequency);
    }

    // ---------------------------------------------------------------- simulate
    /// The time series' plot: pressures (with the cavitation pressure),
    /// reed openings (with the stop, the map's end and linear elasticity's
    /// range), root stresses (with the material's limits), piston and load.
    std::vector<PlotPanel> timeseries_panels(const std::filesystem::path &ts, std::size_t n,
                                             const system::Model &model, const system::SystemParameters &p)
    {
      const auto &lim = model.limits();
      PlotPanel pressures{"Pressures (gauge, about the bias)", "time [s]", "pressure [psi]", false, false,
                          {{ts, "time_s", "chamber_pressure_Pa", "chamber p_ch", "lines", 1, 1 / psi, n},
                           {ts, "time_s", "outlet_pressure_Pa", "outlet p_o", "lines", 1, 1 / psi, n},
                           {ts, "time_s", "high_pressure_Pa", "high side p_h", "lines", 1, 1 / psi, n},
                           {ts, "time_s", "low_pressure_Pa", "low side p_l", "lines", 1, 1 / psi, n}}};
      pressures.levels.push_back({(lim.cavitation_pressure_Pa - p.fluid.bias_pressure_Pa) / psi,
                                  std::string("cavitation pressure") + (lim.cavitation_on ? "" : " (cavitation off)")});
      PlotPanel openings{"Reed tip openings", "time [s]", "opening [um]", false, false,
                         {{ts, "time_s", "outlet_reed_m", "outlet reed x_ro", "lines", 1, 1e6, n},
                          {ts, "time_s", "inlet_reed_m", "inlet reed x_ri", "lines", 1, 1e6, n}}};
      openings.levels.push_back({lim.geometric_stop_lift_m * 1e6, lim.stop_on ? "stop" : "stop (off: passed freely)"});
      const double map_end = std::min(model.valve_map(0).resistance().max_opening(),
                                      model.valve_map(1).resistance().max_opening());
      if (map_end < 2 * lim.geometric_stop_lift_m)
        openings.levels.push_back({map_end * 1e6, "the map's last opening"});
      openings.levels.push_back({lim.large_deflection_opening_m * 1e6, "linear elasticity's limit"});
      PlotPanel stresses{"Reed root bending stress (underside at the clamp)", "time [s]", "stress [MPa]", false, false,
                         {{ts, "time_s", "outlet_root_stress_Pa", "outlet reed", "lines", 1, 1e-6, n},
                          {ts, "time_s", "inlet_root_stress_Pa", "inlet reed", "lines", 1, 1e-6, n}}};
      stresses.levels = {{lim.material.endurance_limit_Pa * 1e-6, "endurance limit"},
                         {lim.material.ultimate_strength_Pa * 1e-6, "ultimate strength"}};
      PlotPanel motion{"Piston and actuator", "time [s]", "piston [um], actuator velocity [mm/s]", false, false,
                       {{ts, "time_s", "piston_m", "piston x_p [um]", "lines", 1, 1e6, n},
                        {ts, "time_s", "actuator_velocity_m_per_s", "actuator velocity [mm/s]", "lines", 1, 1e3, n}}};
      return {pressures, openings, stresses, motion};
    }

    /// The console's lines on what the reeds and the volumes reached.
    void print_reeds_and_volumes(const system::RunResult &r, const system::Model &model)
    {
      for (std::size_t v = 0; v < 2; ++v)
        {
          const auto &s = r.valves[v];
          if (model.valve_model() == system::ValveModel::ideal)
            break;
          std::printf("%s reed: opening up to %.4g um, root stress %.4g to %.4g MPa, Goodman factor %.3g; "
                      "%zu seat impacts (up to %.3g m/s), %zu stop impacts (up to %.3g m/s)\n",
                      v == 0 ? "outlet" : "inlet", s.max_opening_m * 1e6, s.min_root_stress_Pa * 1e-6,
                      s.max_root_stress_Pa * 1e-6, s.goodman_factor, s.seat_impacts, s.max_seat_impact_m_per_s,
                      s.stop_impacts, s.max_stop_impact_m_per_s);
        }
      std::string low;
      for (const auto &vol : r.volumes)
        {
          char buf[160];
          std::snprintf(buf, sizeof(buf), "%s%s %.4g MPa", low.empty() ? "" : ", ", vol.name.c_str(),
                        vol.min_absolute_pressure_Pa * 1e-6);
          low += buf;
          if (vol.max_cavity_volume_m3 > 0)
            {
              std::snprintf(buf, sizeof(buf), " (cavity up to %.3g mm^3)", vol.max_cavity_volume_m3 * 1e9);
              low += buf;
            }
        }
      std::printf("lowest absolute pressures: %s\n", low.c_str());
    }

    struct SimulateOptions : CommonOptions
    {
      double      frequency_Hz = 10;
      std::size_t cycles       = 5;
      std::string current_csv;
    };

    void simulate(const SimulateOptions &o)
    {
      const CaseFile file = load_case(o.case_path);
      auto           p    = o.parameters(file);
      if (!o.current_csv.empty())
        p.drive.waveform = std::filesystem::absolute(o.current_csv).string();
      const auto scenario = system::parse_scenario(o.scenario);
      const auto valves   = o.ideal_valves ? system::ValveModel::ideal : system::ValveModel::dynamic;
      system::Model model(p, system::load_valve_maps(p), valves, scenario, make_drive(p, o.frequency_Hz));
      const std::string jacobian = p.solver.jacobian == "analytic" && model.needs_difference_jacobian() ?
                                     "finite-difference (the model's optional terms in use need it)" :
                                     p.solver.jacobian;
      echo_settings("simulate", {{"case", o.case_path},
                        {"scenario", o.scenario},
                        {"valves", system::to_string(valves)},
                        {"frequency [Hz]", format_number(o.frequency_Hz)},
                        {"cycles", std::to_string(o.cycles)},
                        {"current", p.drive.waveform == "sine" ?
                                      format_number(p.drive.current_pp_A) + " A p-p, " +
                                        format_number(p.drive.current_bias_A) + " A bias" :
                                      p.drive.waveform},
                        {"valve maps", valve_maps_text(p)},
                        {"reed", reed_text(p)},
                        {"limits", limits_text(p)},
                        {"rtol", format_number(p.solver.relative_tolerance)},
                        {"jacobian", jacobian},
                        {"out", o.out_dir}});
      if (o.cycles == 0)
        throw InputError("--cycles 0: must be >= 1");
      const std::filesystem::path out(o.out_dir);
      OutputLock                  lock; // a folder in use is refused now, not after the run
      lock.acquire_if_exists(out);
      auto          run = o.run_options(p);
      run.n_cycles      = o.cycles;
      run.record        = true;
      const std::size_t every = std::max<std::size_t>(1, o.cycles / 10);
      Progress          progress("simulate", o.cycles / every);
      if (o.cycles >= 20)
        run.on_cycle = [&](std::size_t done, std::size_t) {
          if (done % every == 0)
            progress.step("cycle " + std::to_string(done));
        };
      const system::RunResult r = system::run(model, run);

      lock.acquire(out);
      r.series->write(out / "timeseries.csv");
      const auto ts = out / "timeseries.csv";
      // Long runs: plot at most about 20 000 rows a curve (the CSV keeps them all).
      const std::size_t n = std::max<std::size_t>(1, r.series->n_rows() / 20000 + 1);
      const bool plotted = render_plot(out / "timeseries", timeseries_panels(ts, n, model, p));

      nlohmann::json summary = {
        {"command", "simulate"},
        {"rectify_version", RECTIFY_VERSION},
        {"build", build_info()},
        {"case", o.case_path},
        {"scenario", o.scenario},
        {"valves", system::to_string(valves)},
        {"frequency_Hz", o.frequency_Hz},
        {"cycles", o.cycles},
        {"stored_pressure_Pa", r.stored_pressure_Pa},
        {"stored_pressure_psi", r.stored_pressure_Pa / psi},
        {"mean_velocity_m_per_s", r.mean_velocity_m_per_s},
        {"wall_time_s", r.wall_time_s},
        {"definitions",
         {{"stored_pressure_Pa", "eq. 5.1: mean outlet pressure p_o over the whole run, gauge about the bias pressure"},
          {"mean_velocity_m_per_s", "eq. 5.2: mean actuator velocity over the whole run"}}},
        {"validity", r.validity.to_json()},
        {"run", r.to_json()},
        {"model_constants", model.constants().to_json()},
        {"parameters", p.to_json()},
        {"files", {"timeseries.csv", plotted ? "timeseries.png" : "", plotted ? "timeseries.svg" : ""}}};
      write_json(out / "summary.json", summary);

      std::printf("stored pressure (eq. 5.1): %.6g Pa (%.4g psi)\n", r.stored_pressure_Pa,
                  r.stored_pressure_Pa / psi);
      std::printf("mean actuator velocity (eq. 5.2): %.6g m/s\n", r.mean_velocity_m_per_s);
      std::printf("piston stroke %.4g um, max outlet reed opening %.4g um, seat impacts %zu\n",
                  r.piston_stroke_m * 1e6, r.max_outlet_reed_opening_m * 1e6, r.n_seat_impacts);
      print_reeds_and_volumes(r, model);
      std::printf("volume balance error %.2e (relative), CVODE: %ld steps, %ld events, %.2f s\n",
                  r.volume_balance_rel_error, r.stats.steps, r.stats.events, r.wall_time_s);
      for (const auto &w : r.warnings)
        std::printf("warning: %s\n", w.c_str());
      std::printf("validity: %s\n", r.validity.line().c_str());
      if (!plotted)
        std::printf("notice: gnuplot not available or failed; no plot written\n");
      std::printf("wrote %s\n", (out / "summary.json").c_str());
    }

    // ------------------------------------------------------------------- sweep
    /// Each series' validity in the summary: per frequency the flag, the
    /// worse Goodman factor and the impacts; counts of each flag.
    void add_validity(nlohmann::json &series, const std::vector<system::SweepPoint> &points, std::size_t first,
                      std::size_t n)
    {
      nlohmann::json valid = nlohmann::json::array(), goodman = nlohmann::json::array(),
                     seat = nlohmann::json::array(), stop = nlohmann::json::array();
      std::map<std::string, std::size_t> count{{"not_valid", 0},      {"beyond_map", 0}, {"beyond_stop", 0},
                                               {"below_cavitation_pressure", 0}, {"goodman_below_1", 0},
                                               {"at_stop", 0},        {"cavitating", 0}, {"large_deflection", 0}};
      const auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); };
      for (std::size_t i = first; i < first + n; ++i)
        {
          const auto &pt = points[i];
          valid.push_back(!pt.failed() && pt.valid);
          goodman.push_back(number(pt.goodman_factor));
          seat.push_back(number(pt.max_seat_impact_m_per_s));
          stop.push_back(number(pt.max_stop_impact_m_per_s));
          if (pt.failed())
            continue;
          count["not_valid"] += pt.valid ? 0 : 1;
          count["beyond_map"] += pt.beyond_map;
          count["beyond_stop"] += pt.beyond_stop;
          count["below_cavitation_pressure"] += pt.below_cavitation_pressure;
          count["goodman_below_1"] += pt.goodman_below_1;
          count["at_stop"] += pt.at_stop;
          count["cavitating"] += pt.cavitating;
          count["large_deflection"] += pt.large_deflection;
        }
      series["valid"]                            = valid;
      series["goodman_factor"]                   = goodman;
      series["max_seat_impact_velocity_m_per_s"] = seat;
      series["max_stop_impact_velocity_m_per_s"] = stop;
      series["counts"]                           = count;
    }

    /// sweep.csv: per series its metric, the metric again where the run is
    /// not valid (NaN where it is: the plot's marks) and its Goodman factor.
    std::vector<std::string> write_sweep_table(const std::filesystem::path &file,
                                               const std::vector<system::SweepPoint> &points,
                                               const std::vector<std::string> &names, const std::vector<double> &f,
                                               const std::string &metric)
    {
      std::vector<std::string> columns{"frequency_Hz"};
      for (const auto &n : names)
        columns.insert(columns.end(), {n + "_" + metric, n + "_not_valid_" + metric, n + "_goodman_factor"});
      CsvTable     table(columns);
      const double nan = std::numeric_limits<double>::quiet_NaN();
      for (std::size_t i = 0; i < f.size(); ++i)
        {
          std::vector<double> row{f[i]};
          for (std::size_t si = 0; si < names.size(); ++si)
            {
              const auto  &pt = points[si * f.size() + i];
              const double y  = metric == "stored_pressure_Pa" ? pt.stored_pressure_Pa : pt.mean_velocity_m_per_s;
              row.insert(row.end(), {y, pt.valid ? nan : y, std::isfinite(pt.goodman_factor) ? pt.goodman_factor : nan});
            }
          table.add_row(row);
        }
      table.write(file);
      return columns;
    }

    /// The sweep's plot: the metric, its runs that are not valid ringed;
    /// below it each series' Goodman factor, with 1 marked.
    std::vector<PlotPanel> sweep_panels(const std::filesystem::path &csv, const std::vector<std::string> &names,
                                        const std::vector<std::string> &columns, bool pressure, bool log_x)
    {
      PlotPanel panel{pressure ? "No-flow stored pressure (eq. 5.1), cf. thesis Fig. 5.3" :
                                 "Mean actuator velocity (eq. 5.2), cf. thesis Figs. 5.4, 5.6; ringed: not valid",
                      "pumping frequency [Hz]",
                      pressure ? "stored pressure [psi]" : "mean velocity [m/s]",
                      log_x,
                      false,
                      {}};
      if (pressure)
        panel.title += "; ringed: not valid";
      PlotPanel goodman{"The reeds' Goodman factor (the worse valve's): below 1 the reed does not survive",
                        "pumping frequency [Hz]", "Goodman factor", log_x, true, {}};
      goodman.levels.push_back({1.0, "survives above"});
      const double scale = pressure ? 1 / psi : 1.0;
      for (std::size_t si = 0; si < names.size(); ++si)
        {
          panel.series.push_back({csv, "frequency_Hz", columns[3 * si + 1], names[si], "linespoints", 1.0, scale});
          panel.series.push_back({csv, "frequency_Hz", columns[3 * si + 2], names[si] + ": not valid",
                                  "points pt 6 ps 2 lc rgb 'red'", 1.0, scale});
          if (names[si] != "ideal")
            goodman.series.push_back({csv, "frequency_Hz", columns[3 * si + 3], names[si], "linespoints"});
        }
      return {panel, goodman};
    }

    /// "all 100 runs valid" or "37 of 100 runs not valid (Goodman factor below 1: 35, ...)", with the flags that hold.
    std::string validity_counts_line(const nlohmann::json &counts, std::size_t n)
    {
      const std::pair<const char *, const char *> why[] = {{"goodman_below_1", "Goodman factor below 1"},
                                                           {"beyond_map", "a reed beyond its map"},
                                                           {"beyond_stop", "a reed through its stop"},
                                                           {"below_cavitation_pressure", "a pressure below cavitation"}};
      const std::pair<const char *, const char *> also[] = {{"at_stop", "at the stop"},
                                                            {"cavitating", "cavitating"},
                                                            {"large_deflection", "large deflection"}};
      const auto list = [&](std::span<const std::pair<const char *, const char *>> items) {
        std::string text;
        for (const auto &[key, phrase] : items)
          if (const auto k = counts[key].get<std::size_t>(); k > 0)
            text += (text.empty() ? "" : ", ") + std::string(phrase) + ": " + std::to_string(k);
        return text;
      };
      const std::size_t bad  = counts["not_valid"].get<std::size_t>();
      std::string       line = bad == 0 ? "all " + std::to_string(n) + " runs valid" :
                                          std::to_string(bad) + " of " + std::to_string(n) + " runs NOT VALID (" +
                                            list(why) + ")";
      const std::string notes = list(also);
      return notes.empty() ? line : line + "; " + notes + " (sweep-runs.csv has each run's flags)";
    }

    struct SweepCommandOptions : CommonOptions
    {
      double                   from_Hz = 10, to_Hz = 3500;
      std::size_t              n       = 20;
      std::size_t              cycles  = 50;
      std::vector<std::string> series;
      std::string              spacing = "log";
      unsigned                 jobs    = 0;
      std::size_t              chains  = 0;
      bool                     quiet   = false;
      double                   settle_tolerance = 2e-3;
      std::size_t              max_startup      = 1000;
      double                   startup_rtol     = 0;
    };

    /// The sweep's options from the command's, checked; `names` gets the series.
    system::SweepOptions sweep_options(const SweepCommandOptions &o, const system::SystemParameters &p,
                                       system::Scenario scenario, std::vector<std::string> &names)
    {
      system::SweepOptions s = system::default_sweep_options(
        p, scenario, system::frequency_grid(o.from_Hz, o.to_Hz, o.n, o.spacing == "log"), o.cycles);
      names = o.series;
      if (o.ideal_valves)
        names = {"ideal"};
      if (names.empty())
        names = scenario == system::Scenario::no_flow ?
                  std::vector<std::string>{"dynamic", "ideal"} :
                  std::vector<std::string>{"dynamic", "ideal", "reed-whatif"};
      for (const auto &n : names)
        s.series.push_back(system::parse_sweep_series(n));
      s.run.settle_tolerance   = o.settle_tolerance;
      if (o.max_startup == 0)
        throw InputError("--max-startup-cycles 0: must be >= 1 (a run of fixed length is `simulate`)");
      s.run.max_startup_cycles = o.max_startup;
      if (o.startup_rtol != 0 && !(o.startup_rtol >= p.solver.relative_tolerance && o.startup_rtol <= 1e-2))
        throw InputError("--startup-rtol " + format_number(o.startup_rtol) + ": must be 0 (the rtol, " +
                         format_number(p.solver.relative_tolerance) + ") or in [rtol, 1e-2]");
      s.run.startup_relative_tolerance = o.startup_rtol;
      s.jobs                   = o.jobs;
      s.chains                 = o.chains;
      s.quiet                  = o.quiet;

      return s;
    }

    void echo_sweep(const SweepCommandOptions &o, const system::SystemParameters &p, const system::SweepOptions &s,
                    const std::vector<std::string> &names)
    {
      std::string series_list;
      for (const auto &n : names)
        series_list += (series_list.empty() ? "" : ", ") + n;
      echo_settings("sweep", {{"case", o.case_path},
                     {"scenario", o.scenario},
                     {"valve maps", valve_maps_text(p)},
                     {"reed", reed_text(p)},
                     {"limits", limits_text(p)},
                     {"series", series_list},
                     {"frequencies [Hz]", format_number(o.from_Hz) + " .. " + format_number(o.to_Hz) +
                                            ", " + std::to_string(o.n) + " " + o.spacing + "-spaced"},
                     {"current", format_number(s.current_pp_A) + " A p-p, " +
                                   format_number(s.current_bias_A) + " A bias"},
                     {"cycles", "settled start-up (tolerance " + format_number(o.settle_tolerance) +
                                  ") + " + std::to_string(o.cycles) + " measured"},
                     {"rtol", format_number(p.solver.relative_tolerance) +
                                (o.startup_rtol > 0 ? " (start-up " + format_number(o.startup_rtol) + ")" : "")},
                     {"jobs", o.jobs ? std::to_string(o.jobs) : "all cores"},
                     {"chains", o.chains ? std::to_string(o.chains) + " (continuation)" : "none (every frequency from rest)"},
                     {"out", o.out_dir}});

    }

    /// Per series its metric, standard errors, regimes, times and validity;
    /// over every run the counts and totals summary.json reports.
    struct SweepTally
    {
      nlohmann::json per_series = nlohmann::json::object();
      long           total_steps = 0;
      std::size_t    n_unsettled = 0, n_periodic = 0, n_failed = 0;
      nlohmann::json failures = nlohmann::json::array();
      double         sum_cycles = 0, sum_wall = 0;
    };

    SweepTally tally_sweep(const system::SweepResult &r, const std::vector<std::string> &names, std::size_t nf,
                           const std::string &metric, bool pressure)
    {
      SweepTally t;
      auto &[per_series, total_steps, n_unsettled, n_periodic, n_failed, failures, sum_cycles, sum_wall] = t;
      for (std::size_t si = 0; si < names.size(); ++si)
        {
          nlohmann::json values = nlohmann::json::array(), walls = nlohmann::json::array(),
                         settled = nlohmann::json::array(), stderrs = nlohmann::json::array(),
                         regimes = nlohmann::json::array();
          for (std::size_t i = 0; i < nf; ++i)
            {
              const auto &pt = r.points[si * nf + i];
              values.push_back(pressure ? pt.stored_pressure_Pa : pt.mean_velocity_m_per_s);
              walls.push_back(pt.wall_time_s);
              settled.push_back(pt.settled);
              stderrs.push_back(pt.metric_stderr);
              regimes.push_back(pt.regime);
              if (pt.failed())
                {
                  ++n_failed;
                  failures.push_back({{"series", pt.series}, {"frequency_Hz", pt.frequency_Hz}, {"why", pt.regime}});
                  continue;
                }
              n_periodic += pt.regime == "non-periodic" ? 0 : 1;
              total_steps += pt.steps;
              n_unsettled += pt.settled ? 0 : 1;
              sum_cycles += static_cast<double>(pt.startup_cycles + pt.measured_cycles);
              sum_wall += pt.wall_time_s;
            }
          per_series[names[si]] = {{metric, values},      {"stderr", stderrs},
                                   {"regime", regimes},   {"wall_time_s", walls},
                                   {"settled", settled}};
          add_validity(per_series[names[si]], r.points, si * nf, nf);
        }
      return t;
    }

    nlohmann::json sweep_summary(const SweepCommandOptions &o, const system::SystemParameters &p,
                                 const system::SweepOptions &s, const system::SweepResult &r,
                                 const std::vector<std::string> &names, const std::string &metric,
                                 const SweepTally &t, bool plotted)
    {
      const auto &[per_series, total_steps, n_unsettled, n_periodic, n_failed, failures, sum_cycles, sum_wall] = t;
      return {
        {"command", "sweep"},
        {"rectify_version", RECTIFY_VERSION},
        {"build", build_info()},
        {"case", o.case_path},
        {"scenario", o.scenario},
        {"series", names},
        {"frequency_Hz", s.frequencies_Hz},
        {metric, per_series[names[0]][metric]},
        {"wall_time_s", per_series[names[0]]["wall_time_s"]},
        {"primary_series", names[0]},
        {"by_series", per_series},
        {"sweep_wall_time_s", r.wall_time_s},
        {"runs_resumed", r.n_resumed},
        {"runs_not_settled", n_unsettled},
        {"runs_periodic", n_periodic},
        {"runs_failed", n_failed},
        {"failures", failures},
        {"mean_cycles_per_run", sum_cycles / static_cast<double>(r.points.size())},
        {"cpu_time_per_cycle_s", sum_wall / sum_cycles},
        {"cvode_steps_total", total_steps},
        {"current_pp_A", s.current_pp_A},
        {"current_bias_A", s.current_bias_A},
        {"definitions",
         {{"stored_pressure_Pa", "eq. 5.1 over the measured cycles after a settled start-up; gauge about the bias pressure"},
          {"mean_velocity_m_per_s", "eq. 5.2 over the measured cycles after a settled start-up"},
          {"wall_time_s", "per run, on one thread"},
          {"stderr", "standard error of the mean from 10 batch means: the sampling uncertainty of a non-periodic (fluttering) run"},
          {"regime", "periodic, period-k or non-periodic, from the states at the ends of the last cycles; "
                     "'failed: why' for a run the integrator could not finish (its numbers NaN; the sweep goes on, "
                     "the next frequency of its chain starting from rest)"}}},
        {"parameters", p.to_json()},
        {"files", {"sweep.csv", "sweep-runs.csv", plotted ? "sweep.png" : "", plotted ? "sweep.svg" : ""}}};
    }

    void sweep(const SweepCommandOptions &o)
    {
      const CaseFile file     = load_case(o.case_path);
      const auto     p        = o.parameters(file);
      const auto     scenario = system::parse_scenario(o.scenario);
      if (p.drive.waveform != "sine")
        throw InputError(file.where("drive", "waveform") +
                         ": a sweep needs the sine drive (a recorded waveform has one frequency)");
      if (o.cycles == 0)
        throw InputError("--cycles 0: must be >= 1");
      std::vector<std::string>   names;
      const system::SweepOptions s = sweep_options(o, p, scenario, names);
      echo_sweep(o, p, s, names);
      const std::filesystem::path out(o.out_dir);
      OutputLock                  lock;
      lock.acquire(out);
      const system::SweepResult r = system::run_sweep(p, s, out);

      // Long table: every run with its diagnostics.
      const bool  pressure = scenario == system::Scenario::no_flow;
      std::string long_csv = system::sweep_point_csv_header() + "\n";
      for (const auto &pt : r.points)
        long_csv += system::to_csv_row(pt) + "\n";
      write_file_atomic(out / "sweep-runs.csv", long_csv);

      // Wide table for plotting: one column per series.
      const std::string metric = pressure ? "stored_pressure_Pa" : "mean_velocity_m_per_s";
      const std::size_t nf     = s.frequencies_Hz.size();
      const SweepTally  t      = tally_sweep(r, names, nf, metric, pressure);
      const auto columns = write_sweep_table(out / "sweep.csv", r.points, names, s.frequencies_Hz, metric);
      const bool plotted = render_plot(out / "sweep", sweep_panels(out / "sweep.csv", names, columns, pressure,
                                                                   o.spacing == "log"));
      write_json(out / "summary.json", sweep_summary(o, p, s, r, names, metric, t, plotted));
      const auto &[per_series, total_steps, n_unsettled, n_periodic, n_failed, failures, sum_cycles, sum_wall] = t;
      std::printf("%zu runs (%zu resumed) in %.1f s; %zu periodic, %zu not settled; %.3g s CPU per cycle\n",
                  r.points.size(), r.n_resumed, r.wall_time_s, n_periodic, n_unsettled,
                  sum_wall / sum_cycles);
      for (const auto &n : names)
        std::printf("validity (%s): %s\n", n.c_str(), validity_counts_line(per_series[n]["counts"], nf).c_str());
      for (const auto &f : failures)
        std::fprintf(stderr, "warning: %s at %s Hz: %s (NaN in sweep.csv)\n", f["series"].get<std::string>().c_str(),
                     format_number(f["frequency_Hz"].get<double>()).c_str(), f["why"].get<std::string>().c_str());
      std::printf("wrote %s\n", (out / "summary.json").c_str());
    }
  } // namespace

  void register_system_commands(CLI::App &app)
  {
    auto  sim_options = std::make_shared<SimulateOptions>();
    auto *sim         = app.add_subcommand(
      "simulate",
      "One run of the lumped EHA model (thesis ch. 3): time series CSV, plot, summary.json.\n"
      "Example: rectify simulate --scenario no-flow --frequency 10 --cycles 5 --out runs/nf10");
    sim_options->add_to(*sim);
    sim->add_option("--frequency", sim_options->frequency_Hz, "pumping frequency [Hz]")
      ->capture_default_str();
    sim->add_option("--cycles", sim_options->cycles, "pumping cycles to simulate")
      ->capture_default_str();
    sim->add_option("--current-csv", sim_options->current_csv,
                    "drive current waveform: CSV with time_s,current_A");
    sim->callback([sim_options]() { simulate(*sim_options); });

    auto  sw_options = std::make_shared<SweepCommandOptions>();
    auto *sw         = app.add_subcommand(
      "sweep",
      "Frequency sweep, one settled run per frequency and series, in parallel and resumable.\n"
      "Stored pressure vs frequency (no-flow, Fig. 5.3) or mean actuator velocity (loaded,\n"
      "Figs. 5.4, 5.6). Example: rectify sweep --scenario loaded --from 10 --to 3500 --n 100 --out runs/vel");
    sw_options->add_to(*sw);
    sw->add_option("--from", sw_options->from_Hz, "first frequency [Hz]")->capture_default_str();
    sw->add_option("--to", sw_options->to_Hz, "last frequency [Hz]")->capture_default_str();
    sw->add_option("--n", sw_options->n, "number of frequencies")->capture_default_str();
    sw->add_option("--cycles", sw_options->cycles, "measured cycles after the settled start-up")
      ->capture_default_str();
    sw->add_option("--series", sw_options->series,
                   "curves: dynamic, ideal, reed-whatif (default: dynamic,ideal[,reed-whatif when loaded])")
      ->delimiter(',');
    sw->add_option("--spacing", sw_options->spacing, "log or linear frequency spacing")
      ->check(CLI::IsMember({"log", "linear"}))
      ->capture_default_str();
    sw->add_option("--jobs", sw_options->jobs, "parallel runs (0: all cores)")->capture_default_str();
    sw->add_option("--chains", sw_options->chains,
                   "continuation: each series' frequencies in this many chains, each frequency "
                   "starting where its lower neighbour settled (0: every frequency from rest)")
      ->capture_default_str();
    sw->add_option("--settle-tolerance", sw_options->settle_tolerance,
                   "relative change of the cycle mean that counts as settled")
      ->check(CLI::Range(1e-6, 0.5))
      ->capture_default_str();
    sw->add_option("--max-startup-cycles", sw_options->max_startup,
                   "give up settling after this many cycles (the run is flagged)")
      ->capture_default_str();
    sw->add_option("--startup-rtol", sw_options->startup_rtol,
                   "CVODE relative tolerance while settling (0: the rtol); the measured cycles use the rtol")
      ->capture_default_str();
    sw->add_flag("--quiet", sw_options->quiet, "no progress lines");
    sw->callback([sw_options]() { sweep(*sw_options); });
  }
} // namespace rectify::app
