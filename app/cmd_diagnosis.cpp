// `rectify synth` and `rectify diagnose`: measured runs against the system
// model, the missing effect found, named and added (diagnosis/).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "app/commands.h"
#include "common/io.h"
#include "common/output_lock.h"
#include "common/version.h"
#include <fstream>
#include <sstream>

#include "common/plot.h"
#include "common/case_edit.h"
#include "diagnosis/diagnose.h"
#include "diagnosis/sensors.h"
#include "diagnosis/effect.h"
#include "diagnosis/synth.h"
#include "system/model.h"

namespace rectify::app
{
  namespace
  {
    // ------------------------------------------------------------------ synth
    struct SynthCommandOptions
    {
      std::string              case_path, out_dir, scenario = "no-flow";
      std::vector<std::string> params;
      diagnosis::SynthOptions  synth;
      double                   current_pp_A = std::nan(""), current_bias_A = std::nan("");
    };

    void synth(SynthCommandOptions o)
    {
      const CaseFile file = load_case(o.case_path);
      const auto     p    = system::SystemParameters::from_case(file);
      o.synth.scenario    = system::parse_scenario(o.scenario);
      o.synth.current_pp_A   = std::isnan(o.current_pp_A) ? p.drive.current_pp_A : o.current_pp_A;
      o.synth.current_bias_A = std::isnan(o.current_bias_A) ? p.drive.current_bias_A : o.current_bias_A;
      system::DriveParameters::check_currents(o.synth.current_pp_A, o.synth.current_bias_A, "--current-pp",
                                              "--current-bias");
      for (const auto &kv : o.params)
        {
          const auto eq = kv.find('=');
          if (eq == std::string::npos || eq == 0)
            throw InputError("--param '" + kv + "': expected KEY=VALUE");
          const std::string key = kv.substr(0, eq), text = kv.substr(eq + 1);
          std::size_t       used = 0;
          double            value = 0;
          try
            {
              value = std::stod(text, &used);
            }
          catch (const std::exception &)
            {
              used = 0;
            }
          if (used != text.size() || text.empty() || !std::isfinite(value))
            throw InputError("--param " + key + ": '" + text + "' is not a finite number");
          o.synth.parameters[key] = value;
        }
      if (o.synth.effect != "none")
        diagnosis::find_effect(o.synth.effect); // a clear error before the run
      echo_settings("synth", {{"case", o.case_path},
                              {"effect", o.synth.effect},
                              {"scenario", o.scenario},
                              {"frequency [Hz]", format_number(o.synth.frequency_Hz)},
                              {"cycles", std::to_string(o.synth.cycles)},
                              {"noise", format_number(o.synth.noise)},
                              {"seed", std::to_string(o.synth.seed)},
                              {"out", o.out_dir}});
      const std::filesystem::path out(o.out_dir);
      OutputLock                  lock;
      lock.acquire_if_exists(out);
      const auto result = diagnosis::synthesise(p, system::load_valve_maps(p), o.synth);
      lock.acquire(out);
      result.data.write(out / "data.csv");
      auto answer    = result.answer;
      answer["case"]  = o.case_path;
      answer["build"] = build_info();
      write_json(out / "answer.json", answer);
      std::printf("wrote %s (%zu rows) and %s\n", (out / "data.csv").c_str(), result.data.n_rows(),
                  (out / "answer.json").c_str());
    }
    // --------------------------------------------------------------- diagnose
    struct DiagnoseCommandOptions
    {
      std::string                case_path, out_dir, scenario = "no-flow", harmonics = "auto";
      std::string                reed_second_mode = "auto";
      std::vector<std::string>   data;
      double                     frequency_Hz = 0;
      bool                       second       = false;
      bool                       ideal_sensors = false;
      diagnosis::DiagnoseOptions options;
      std::string                settings; ///< every option's value but --out's, as CLI11 writes a config file
    };

    std::string sci(double v)
    {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.4g", v);
      return buf;
    }

    std::string pretty_signal(const std::string &s)
    {
      return s == "outlet_pressure_Pa" ? "outlet pressure [MPa]" :
             s == "chamber_pressure_Pa" ? "chamber pressure [MPa]" :
             s == "outlet_valve_m" ? "outlet valve opening [um]" :
             s == "actuator_position_m" ? "actuator position [mm]" :
             s == "actuator_velocity_m_per_s" ? "actuator velocity [mm/s]" : s;
    }

    double display_scale(const std::string &s)
    {
      return s.ends_with("_Pa") ? 1e-6 : s == "outlet_valve_m" ? 1e6 : s.ends_with("_m") || s.ends_with("_m_per_s") ? 1e3 : 1.0;
    }

    void diagnose(DiagnoseCommandOptions o)
    {
      const auto     start = std::chrono::steady_clock::now();
      const CaseFile file  = load_case(o.case_path);
      auto           p     = system::SystemParameters::from_case(file);
      const auto     scenario = system::parse_scenario(o.scenario);
      const double file_second_mode_Hz = p.reed.second_mode_frequency_Hz;
      const auto   second_mode = diagnosis::baseline_second_mode(p, scenario, o.reed_second_mode);
      p.reed.second_mode_frequency_Hz = second_mode.frequency_Hz;
      if (o.data.empty())
        throw InputError("--data: give at least one measured run (CSV)");
      if (!(o.options.training_fraction >= 0.3 && o.options.training_fraction <= 0.95))
        throw InputError("--training-fraction " + format_number(o.options.training_fraction) +
                         ": must be in [0.3, 0.95]");
      if (o.frequency_Hz < 0 || !std::isfinite(o.frequency_Hz))
        throw InputError("--frequency " + format_number(o.frequency_Hz) + ": must be > 0 (or 0: from the data)");
      for (const auto &e : o.options.effects)
        diagnosis::find_effect(e);
      o.options.rounds = o.second ? 2 : 1;
      if (!o.ideal_sensors)
        o.options.sensor_lowest_bandwidth_Hz = diagnosis::SensorLimits::from_case(file).per_signal();

      o.options.harmonics_auto = o.harmonics == "auto";
      if (!o.options.harmonics_auto)
        o.options.harmonics = std::stod(o.harmonics); // checked by the option's validator
      const double reed_Hz = diagnosis::band_reed_frequency_Hz(p, scenario, o.options);

      std::vector<diagnosis::RunCase> runs;
      for (const auto &path : o.data)
        {
          auto run = diagnosis::MeasuredRun::read(path, o.frequency_Hz);
          for (const auto &c : run.ignored_columns)
            std::fprintf(stderr, "notice: '%s': column '%s' ignored (not a quantity the model predicts)\n",
                         path.c_str(), c.c_str());
          runs.push_back(diagnosis::make_run_case(std::move(run), scenario, o.frequency_Hz,
                                                  o.options.training_fraction, o.options.repair_outliers,
                                                  o.options.harmonics, reed_Hz));
          for (const auto &x : runs.back().outliers)
            std::fprintf(stderr, "notice: '%s': row %zu, %s: an isolated spike of %.3g (%.0f noise sd) replaced "
                         "by its neighbours' mean\n", path.c_str(), x.row, x.column.c_str(), x.size, x.noise_units);
          const auto &rc = runs.back();
          if (scenario == system::Scenario::no_flow && rc.run.has("actuator_position_m"))
            {
              const auto &x = rc.run.signal("actuator_position_m");
              if (*std::max_element(x.begin(), x.end()) - *std::min_element(x.begin(), x.end()) > 1e-4)
                std::fprintf(stderr, "warning: '%s': the actuator moves %.3g mm, but the scenario is no-flow "
                             "(--scenario loaded?)\n", path.c_str(),
                             1e3 * (*std::max_element(x.begin(), x.end()) - *std::min_element(x.begin(), x.end())));
            }
        }
      std::string data_list;
      for (const auto &rc : runs)
        data_list += (data_list.empty() ? "" : ", ") + rc.run.source + " (" +
                     format_number(std::round(rc.setup.frequency_Hz * 100) / 100) + " Hz, " +
                     std::to_string(rc.run.time_s.size()) + " samples, " +
                     (rc.band_Hz > 0 ? "compared within " + format_number(rc.harmonics) + " harmonics, to " +
                                         format_number(std::round(rc.band_Hz)) + " Hz" :
                                       std::string("every sample compared")) +
                     ")";
      echo_settings("diagnose", {{"case", o.case_path},
                                 {"data", data_list},
                                 {"scenario", o.scenario},
                                 {"candidates", o.options.effects.empty() ? "all: " + diagnosis::effect_names() : [&] {
                                    std::string s;
                                    for (const auto &e : o.options.effects)
                                      s += (s.empty() ? "" : ", ") + e;
                                    return s;
                                  }()},
                                 {"nuisance", "force gain in 1 +- " + format_number(o.options.gain_range) +
                                                (p.uncertain.empty() ? std::string() : [&] {
                                                  std::string s = "; [uncertain]:";
                                                  for (const auto &q : p.uncertain)
                                                    s += " " + q.name() + " in [" + format_number(q.lower) + ", " +
                                                         format_number(q.upper) + "]";
                                                  return s;
                                                }())},
                                 {"reed second mode", second_mode.text()},
                                 {"start", o.options.start},
                                 {"training", format_number(o.options.training_fraction) + " of each run; the rest held out; "
                                                "candidates compared on at most " +
                                                (o.options.compared_cycles > 0 ? format_number(o.options.compared_cycles) +
                                                                                   " training cycles in all" :
                                                                                 std::string("every training cycle"))},
                                 {"rounds", std::to_string(o.options.rounds)},
                                 {"sensors", [&] {
                                    if (o.options.sensor_lowest_bandwidth_Hz.empty())
                                      return std::string("ideal");
                                    std::string s = "a first-order lag per signal, fitted to the final model down to:";
                                    for (const auto &[signal, f] : o.options.sensor_lowest_bandwidth_Hz)
                                      s += " " + signal + " " + format_number(f) + " Hz";
                                    return s;
                                  }()},
                                 {"out", o.out_dir}});
      o.options.progress = [](const std::string &line) { std::fprintf(stderr, "  %s\n", line.c_str()); };
      const std::filesystem::path out(o.out_dir);
      const bool                  made_out = !std::filesystem::exists(out);
      OutputLock                  lock; // a folder in use is refused now, not after minutes of fits
      lock.acquire_if_exists(out);
      const auto map = system::load_valve_maps(p);
      // Each candidate's fit is kept in the folder as it ends: the same
      // command, interrupted, takes them up again (DiagnoseOptions).
      lock.acquire(out); // made now (the maps read: bad input leaves none)
      o.options.checkpoint_dir = out;
      {
        nlohmann::json data_hashes = nlohmann::json::array();
        for (const auto &d : o.data)
          data_hashes.push_back(file_hash(d));
        o.options.checkpoint_fingerprint = {{"revision", source_revision()},
                                            {"version", RECTIFY_VERSION},
                                            {"settings", o.settings},
                                            {"case", file_hash(o.case_path)},
                                            {"data", data_hashes}};
      }
      const auto result = [&] {
        try
          {
            return diagnosis::diagnose(p, map, runs, o.options);
          }
        catch (...)
          {
            // a failure before any fit was kept leaves nothing behind
            if (diagnosis::kept_fits(out) == 0)
              {
                diagnosis::remove_checkpoint(out);
                std::error_code ec;
                if (made_out && std::filesystem::is_empty(out, ec))
                  std::filesystem::remove(out, ec);
              }
            throw;
          }
      }();
      auto summary = diagnosis::to_json(result, runs);
      summary["command"]         = "diagnose";
      summary["rectify_version"] = RECTIFY_VERSION;
      summary["build"]           = build_info();
      summary["case"]            = o.case_path;
      summary["scenario"]        = o.scenario;
      summary["baseline_second_mode"] = {{"frequency_Hz", second_mode.frequency_Hz}, {"reason", second_mode.reason}};
      summary["data"]            = o.data;

      // The new case file with the named effects (and the fitted gain).
      std::vector<CaseEntry> entries;
      std::string                       effects_named;
      for (const auto &rr : result.rounds)
        if (rr.effect != "none")
          {
            const auto e = diagnosis::find_effect(rr.effect);
            effects_named += (effects_named.empty() ? "" : "+") + rr.effect;
            for (std::size_t i = 0; i < rr.values.size(); ++i) // as applied (a range's end can mean off)
              {
                const auto &spec = e->parameters()[i];
                entries.push_back({spec.table, spec.key,
                                   format_number(result.final_parameters.real_value(spec.table, spec.key)),
                                   "rectify diagnose: " + rr.effect + " (fitted)"});
              }
            for (const auto &k : e->fixed_keys())
              entries.push_back({k.table, k.key, k.value, "rectify diagnose: " + rr.effect});
            // a key the case declares [uncertain] that the effect now sets
            // (a second mode): its range no longer holds the effect's value
            for (const auto &q : p.uncertain)
              if (e->sets(q.table, q.key))
                entries.push_back({"uncertain", q.name(), "",
                                   "rectify diagnose: set by " + rr.effect + " (fitted), no longer a baseline parameter"});
          }
      const bool second_mode_named = std::any_of(entries.begin(), entries.end(), [](const auto &e) {
        return e.table == "reed" && e.key == "second_mode_frequency_Hz";
      });
      if (!second_mode_named && second_mode.frequency_Hz != file_second_mode_Hz)
        entries.push_back({"reed", "second_mode_frequency_Hz", format_number(second_mode.frequency_Hz),
                           "rectify diagnose: the baseline's second mode, " + second_mode.reason});
      for (const auto &q : result.final_parameters.uncertain)
        entries.push_back({q.table, q.key, format_number(result.final_parameters.real_value(q.table, q.key)),
                           "rectify diagnose: uncertain baseline parameter, fitted"});
      entries.push_back({"transducer", "piezomagnetic_coefficient_m_per_A",
                         format_number(result.final_parameters.transducer.piezomagnetic_coefficient_m_per_A),
                         "rectify diagnose: nuisance force gain fitted"});
      std::string text;
      {
        std::ifstream in(file.name());
        std::stringstream ss;
        ss << in.rdbuf();
        text = ss.str();
      }
      const std::string case_name = "case-with-" + (effects_named.empty() ? std::string("none") : effects_named) + ".toml";
      const std::string edited =
        "# Written by rectify diagnose from " + std::filesystem::absolute(file.name()).string() +
        "\n# with the named effect(s) and the fitted force gain; see summary.json.\n" +
        edit_case_text(text, std::filesystem::path(file.name()).parent_path(), entries);
      write_file_atomic(out / case_name, edited);
      // Check: the new case file reproduces the refitted model (a case
      // file that cannot be read back or simulated is not left behind),
      // as it is: with ideal sensors (their fitted lags are no key of it).
      double check = 0;
      try
        {
          const CaseFile new_file = load_case(out / case_name);
          const auto     new_p    = system::SystemParameters::from_case(new_file);
          double         check_sq = 0;
          for (std::size_t r = 0; r < runs.size(); ++r)
            {
              const auto so    = result.runs[r].simulation(o.options.relative_tolerance);
              const auto model = diagnosis::simulate_run(new_p, map, result.runs[r].run, runs[r].setup, so);
              const auto norms = diagnosis::residual_norms(result.runs[r].run, model, result.runs[r].scales,
                                                           result.runs[r].n_skip);
              check_sq += norms.at("overall") * norms.at("overall");
            }
          check = std::sqrt(check_sq / static_cast<double>(runs.size()));
        }
      catch (...)
        {
          std::filesystem::remove(out / case_name);
          std::error_code ec; // a folder made for this run and left empty goes too
          if (made_out && std::filesystem::is_empty(out, ec))
            std::filesystem::remove(out, ec);
          throw;
        }
      summary["new_case"] = {{"file", case_name},
                             {"residual_overall_from_file", check},
                             {"matches_refit", std::abs(check - result.residual_after_ideal.at("overall")) <=
                                                 2e-3 * result.residual_after_ideal.at("overall") + 1e-9}};

      // Overlays: data, old model, new model, per run.
      std::vector<std::string> files{"summary.json", "report.md", "candidates.csv", case_name};
      for (std::size_t r = 0; r < runs.size(); ++r)
        {
          const auto &rc = runs[r];
          std::vector<std::string> cols{"time_s"};
          std::vector<std::string> sigs;
          for (const auto &[name, v] : result.before[r])
            {
              sigs.push_back(name);
              cols.push_back("data_" + name);
              cols.push_back("before_" + name);
              cols.push_back("after_" + name);
            }
          CsvTable table(cols);
          std::vector<double> row(cols.size());
          for (std::size_t i = 0; i < rc.run.time_s.size(); ++i)
            {
              row[0] = rc.run.time_s[i];
              std::size_t c = 1;
              for (const auto &s : sigs)
                {
                  row[c++] = rc.run.signal(s)[i];
                  row[c++] = result.before[r].at(s)[i];
                  row[c++] = result.after[r].at(s)[i];
                }
              table.add_row(row);
            }
          const std::string base = "overlay-" + std::to_string(r + 1);
          table.write(out / (base + ".csv"));
          files.push_back(base + ".csv");
          // the data as compared: within the band (diagnose.h, `harmonics`)
          const std::string data_label =
            result.runs[r].band_Hz > 0 ? "data (to " + format_number(std::round(result.runs[r].band_Hz)) + " Hz)" : "data";
          std::vector<PlotPanel> panels;
          const std::size_t stride = std::max<std::size_t>(1, rc.run.time_s.size() / 8000);
          for (const auto &s : sigs)
            panels.push_back({pretty_signal(s) + " - " + rc.run.source, "time [s]", pretty_signal(s), false, false,
                              {{out / (base + ".csv"), "time_s", "data_" + s, data_label, "points pt 7 ps 0.3", 1, display_scale(s), stride},
                               {out / (base + ".csv"), "time_s", "before_" + s, "model before", "lines", 1, display_scale(s), stride},
                               {out / (base + ".csv"), "time_s", "after_" + s, "model with " + (effects_named.empty() ? std::string("no effect (refit)") : effects_named), "lines", 1, display_scale(s), stride}}});
          if (render_plot(out / base, panels))
            files.push_back(base + ".png");
        }
      summary["files"] = files;
      summary["total_wall_time_s"] =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

      // candidates.csv (first round)
      {
        std::string csv = "effect,k,bic,delta_bic_vs_none,aic,rms_train,rms_heldout,force_gain,parameters,evaluations,wall_time_s,note\n";
        const auto &cands = result.rounds.front().candidates;
        double      none_bic = 0;
        for (const auto &c : cands)
          if (c.effect == "none")
            none_bic = c.bic;
        for (const auto &c : cands)
          {
            std::string params;
            if (c.effect != "none" && c.not_testable.empty())
              {
                const auto e = diagnosis::find_effect(c.effect);
                for (std::size_t i = 0; i < c.values.size(); ++i)
                  params += (params.empty() ? "" : " ") + e->parameters()[i].key + "=" + sci(c.values[i]);
              }
            if (!c.not_testable.empty())
              csv += c.effect + ",,,,,,,,,,,\"not testable: " + c.not_testable + "\"\n";
            else
              csv += c.effect + "," + std::to_string(c.k) + "," + sci(c.bic) + "," + sci(none_bic - c.bic) + "," +
                     sci(c.aic) + "," + sci(c.rms_train) + "," + sci(c.rms_heldout) + "," + sci(c.force_gain) +
                     "," + params + "," + std::to_string(c.evaluations) + "," + sci(c.wall_time_s) + "," +
                     (c.failed                ? "failed: " + c.message :
                      c.search_note.empty() ? std::string() :
                                              "\"" + c.search_note + "\"") + "\n";
          }
        write_file_atomic(out / "candidates.csv", csv);
      }

      // report.md
      {
        std::string md = "# rectify diagnose\n\nCase: `" + o.case_path + "`, scenario " + o.scenario + ".\n\n";
        md += "The reeds' second mode in the baseline: " + second_mode.text() + ".\n\n";
        md += "**Verdict: " + result.verdict + ".** " + result.verdict_sentence + ".\n\n";
        if (!result.rounds.front().uncertainty_sentence.empty())
          md += "Parameters: " + result.rounds.front().uncertainty_sentence + ".\n\n";
        md += "## The records\n\n| run | start | residual of each start (first 2 cycles, swing units; with the "
              "model that chose it) | "
              "settling samples left out | outliers replaced | compared |\n|---|---|---|---|---|---|\n";
        for (const auto &rc : result.runs)
          {
            std::string scores, spikes;
            for (const auto &[name, v] : rc.start_scores.items())
              scores += (scores.empty() ? "" : ", ") + name + " " + sci(v.get<double>());
            for (const auto &x : rc.outliers)
              spikes += (spikes.empty() ? "" : "; ") + x.column + " row " + std::to_string(x.row) + " (" +
                        sci(x.noise_units) + " sd)";
            md += "| `" + rc.run.source + "` | " + diagnosis::to_string(rc.start) +
                  (rc.start_revised.empty() ? "" : " (" + rc.start_revised + ")") + " | " +
                  (scores.empty() ? "-" : scores) + " | " + std::to_string(rc.n_skip) +
                  (rc.settling_reason.empty() ? "" : " (" + rc.settling_reason + ")") + " | " +
                  (spikes.empty() ? "none" : spikes) + " | " +
                  (rc.band_Hz > 0 ? "within " + format_number(rc.harmonics) + " harmonics (to " +
                                      format_number(std::round(rc.band_Hz)) + " Hz; " + rc.band_reason + ")" :
                                    std::string("every sample")) +
                  " |\n";
          }
        if (result.compared_cycles_per_run > 0)
          md += "\nThe candidates (none too) were fitted and compared on the first " +
                sci(result.compared_cycles_per_run) +
                " training cycles of each run after its settling (the whole training part of a shorter run; "
                "at most " + sci(o.options.compared_cycles) +
                " in all, `--compared-cycles`); the named effect was then refitted on every training cycle.\n";
        if (!result.rounds.front().baseline_check.empty())
          {
            md += "\n## The baseline, calibrated before naming anything\n\nFitted with `none` (every [uncertain] "
                  "parameter and the force gain); a parameter the data do not determine (standard error above " +
                  sci(o.options.identifiability_sd) +
                  " of its range) is held at this fit for every candidate. The standard error counts every compared "
                  "sample as independent; counted per independent value of the band, as the named parameter's is, it "
                  "would be about sqrt(n / independent values) larger (here " +
                  sci(result.baseline_sd_factor) + "x).\n\n"
                  "| parameter | case | fitted | bounds | standard error / range (samples as independent) | identifiable "
                  "| note |\n"
                  "|---|---|---|---|---|---|---|\n";
            for (const auto &b : result.rounds.front().baseline_check)
              md += "| " + b.name + " | " + sci(b.nominal) + " | " + sci(b.value) + " | " + sci(b.lower) + " .. " +
                    sci(b.upper) + " | " + sci(b.sd_unit) + " | " + (b.identifiable ? "yes" : "no: held") + " | " +
                    b.note + " |\n";
          }
        md += "\n## Where the model disagrees with the data (before)\n\nThe case's model as given: each signal's "
              "residual in units of its noise (from the run's settling on), the most first; then how it lies, in "
              "the terms of its swing.\n\n";
        for (std::size_t r = 0; r < result.remaining_before.size() && r < runs.size(); ++r)
          {
            md += "Run `" + runs[r].run.source + "` (" + sci(runs[r].setup.frequency_Hz) + " Hz):\n\n";
            for (const auto &s : result.remaining_before[r])
              md += "- " + s.description + "\n";
            md += "\n";
          }
        for (const auto &s : result.trend_sentences)
          md += "- " + s + "\n";
        for (std::size_t k = 0; k < result.rounds.size(); ++k)
          {
            const auto &rr = result.rounds[k];
            md += "\n## Round " + std::to_string(k + 1) + ": " +
                  (rr.effect == "none" ? std::string("no significant missing effect") : "**" + rr.effect + "**") + "\n\n";
            if (rr.effect != "none")
              {
                const auto e = diagnosis::find_effect(rr.effect);
                md += e->physics() + ".\n\nExpected signature: " + e->signature() + ".\n\n";
                for (std::size_t i = 0; i < rr.values.size(); ++i)
                  md += "- " + e->parameters()[i].meaning + ": `" + e->parameters()[i].key + " = " + sci(rr.values[i]) +
                        "` (bounds " + sci(e->parameters()[i].lower) + " .. " + sci(e->parameters()[i].upper) + ")\n";
                for (const auto &q : rr.uncertainty)
                  md += "- `" + q.key + "`: standard error " +
                        (std::isinf(q.relative_sd) ? std::string("more than ") + sci(100 * o.options.determined_relative_sd)
                                                   : sci(100 * q.relative_sd)) +
                        " % from its profile (held at " + sci(q.profile_value[0]) + " and " + sci(q.profile_value[1]) +
                        " with the baseline refitted: training residual " + sci(q.profile_rms[0]) + " and " +
                        sci(q.profile_rms[1]) + " noise units against the fit's " + sci(q.rms_at_fit) +
                        "), one standard error " +
                        (std::isnan(q.lower) ? "below " + sci(q.profile_value[0]) : sci(q.lower)) + " .. " +
                        (std::isnan(q.upper) ? "above " + sci(q.profile_value[1]) : sci(q.upper)) + "; locally " +
                        sci(100 * q.local_relative_sd) + " % (" + sci(100 * q.local_relative_sd_given_baseline) +
                        " % with the baseline known), most correlated with `" + q.correlated_with + "` (" +
                        sci(q.correlation) + ")" + (q.determined ? "" : ": **not determined by the record**") + "\n";
                if (rr.combined)
                  md += "- " + rr.combined->meaning + ": `" + rr.combined->name + " = " + sci(rr.combined->value) +
                        "`, standard error " + sci(100 * rr.combined->relative_sd) + " %" +
                        (rr.combined->determined ? "" : " (not determined either)") + "\n";
                md += "- confidence (BIC weight): " + sci(rr.confidence) + "\n";
                if (rr.refine_passes > 0)
                  md += "- refitted " + std::to_string(rr.refine_passes) +
                        " time(s) with the residual's noise scales recomputed from the fitted model (the "
                        "candidates' table below shows the first fit, on which the choice was made)\n";
                for (const auto &m : rr.profile_moves)
                  md += "- moved along its profile to `" + sci(m["value"].get<double>()) +
                        "`: that side of the profile, with the baseline refitted, fitted better (training residual " +
                        sci(m["training_residual"].get<double>()) + " noise units, evidence " +
                        sci(m["evidence"].get<double>()) + "); refitted from there\n";
                for (const auto &b : rr.freed)
                  md += "- `" + b.name + "` freed for the refits: " +
                        (b.effect_shape ? "the effect's own shape, held at the case's value while the model had "
                                          "no such effect, determined at this effect's settled fit"
                                        : "held at the baseline fit, determined at this effect's fit") +
                        " (standard error " + sci(b.sd_unit) + " of its range" +
                        (b.note.empty() ? "" : "; " + b.note) + "); refitted from the case's " + sci(b.nominal) +
                        " to " + sci(rr.baseline.count(b.name) ? rr.baseline.at(b.name) : b.value) + "\n";
                for (const auto &b : rr.left_out)
                  md += "- `" + b.name + "`, which the case leaves out (0), tried on at this effect's settled fit: " +
                        (b.value != 0.0 ? "on, refitted to " +
                                            sci(rr.baseline.count(b.name) ? rr.baseline.at(b.name) : b.value)
                                        : std::string("off")) +
                        " (" + b.note + ")\n";
              }
            md += "- force gain (nuisance): " + sci(rr.force_gain) + "\n- evidence: " + rr.decision + "\n\n";
            md += "| candidate | k | BIC - BIC(none) | AIC | RMS train | RMS held-out | parameters |\n|---|---|---|---|---|---|---|\n";
            double none_bic = 0;
            for (const auto &c : rr.candidates)
              if (c.effect == "none")
                none_bic = c.bic;
            for (const auto &c : rr.candidates)
              {
                if (!c.not_testable.empty())
                  {
                    md += "| " + c.effect + " | | not testable: " + c.not_testable + " | | | | |\n";
                    continue;
                  }
                std::string params;
                if (c.effect != "none")
                  {
                    const auto e = diagnosis::find_effect(c.effect);
                    for (std::size_t i = 0; i < c.values.size(); ++i)
                      params += e->parameters()[i].key + " = " + sci(c.values[i]);
                  }
                md += "| " + c.effect + " | " + std::to_string(c.k) + " | " + sci(c.bic - none_bic) + " | " + sci(c.aic) +
                      " | " + sci(c.rms_train) + " | " + sci(c.rms_heldout) + " | " + params + " |\n";
              }
          }
        md += "\n## Gap before and after\n\nRMS residual in units of each signal's noise (about 1: explained to within the noise), "
              "and as a fraction of the signal's swing (RMS about its mean).\n\n"
              "| signal | before [noise] | after [noise] | before [swing] | after [swing] |\n|---|---|---|---|---|\n";
        for (const auto &[name, v] : result.residual_before)
          md += "| " + name + " | " + sci(v) + " | " + sci(result.residual_after.at(name)) + " | " +
                sci(result.swing_before.at(name)) + " | " + sci(result.swing_after.at(name)) + " |\n";
        if (!result.sensor_lags.empty())
          {
            md += "\n## The sensors' lags\n\nEach signal's sensor as a first-order lag, fitted to the final model on "
                  "the training samples (between the case's lowest bandwidth and an ideal sensor) once everything "
                  "else was decided, and kept where the held-out samples (which its fit did not see) fit at "
                  "least as well with it; \"after\" is the model seen through the kept lags. Residual in noise "
                  "units.\n\n"
                  "| signal | fitted bandwidth [kHz] | lowest [kHz] | training: ideal sensor | with the lag "
                  "| held out: ideal | with the lag | kept |\n|---|---|---|---|---|---|---|---|\n";
            for (const auto &l : result.sensor_lags)
              md += "| " + l.signal + " | " +
                    (std::isinf(l.fitted_Hz) ? std::string("ideal") :
                                               sci(1e-3 * l.fitted_Hz) + (l.at_lowest() ? " (its lowest)" : "")) +
                    " | " + sci(1e-3 * l.lowest_Hz) + " | " + sci(l.residual_ideal) + " | " + sci(l.residual_lagged) +
                    " | " + sci(l.heldout_ideal) + " | " + sci(l.heldout_lagged) + " | " + (l.kept ? "yes" : "no") +
                    " |\n";
            md += "\nOverall after, with ideal sensors: " + sci(result.residual_after_ideal.at("overall")) +
                  " noise units; through the lags: " + sci(result.residual_after.at("overall")) + ".\n";
          }
        md += "\n## Where the final model still disagrees (after)\n\nEach signal's residual in units of its noise "
              "(from the run's settling on), the most first; then how it lies, in the terms of its swing.\n\n";
        for (std::size_t r = 0; r < result.remaining.size() && r < runs.size(); ++r)
          {
            md += "Run `" + runs[r].run.source + "`:\n\n";
            for (const auto &s : result.remaining[r])
              md += "- " + s.description + "\n";
            md += "\n";
          }
        md += "New case file: `" + case_name + "`. Overlays: `overlay-N.png`.\n";
        write_file_atomic(out / "report.md", md);
      }
      write_json(out / "summary.json", summary);

      std::printf("effect: %s", result.rounds.front().effect.c_str());
      for (std::size_t k = 1; k < result.rounds.size(); ++k)
        std::printf(", then %s", result.rounds[k].effect.c_str());
      std::printf("\n%s\n", result.rounds.front().decision.c_str());
      std::printf("verdict: %s. %s\n", result.verdict.c_str(), result.verdict_sentence.c_str());
      if (!result.rounds.front().uncertainty_sentence.empty())
        std::printf("parameters: %s\n", result.rounds.front().uncertainty_sentence.c_str());
      for (const auto &rc : result.runs)
        std::printf("  %s: start %s, %zu outlier(s) replaced\n", rc.run.source.c_str(),
                    diagnosis::to_string(rc.start).c_str(), rc.outliers.size());
      for (const auto &run : result.remaining_before)
        for (const auto &s : run)
          std::printf("  before: %s\n", s.description.c_str());
      std::printf("residual (RMS in units of each signal's noise, all signals): %.4g before, %.4g after (%.1f %% smaller)\n",
                  result.residual_before.at("overall"), result.residual_after.at("overall"),
                  100 * (1 - result.residual_after.at("overall") / result.residual_before.at("overall")));
      std::printf("wrote %s, %s\n", (out / "summary.json").c_str(), (out / case_name).c_str());
      diagnosis::remove_checkpoint(out); // complete: nothing left to resume
    }
  } // namespace

  void register_diagnosis_commands(CLI::App &app)
  {
    {
      auto o   = std::make_shared<DiagnoseCommandOptions>();
      auto cmd = app.add_subcommand(
        "diagnose", "compare measured runs with the model, name the missing effect, add it, refit");
      add_case_and_out(*cmd, o->case_path, o->out_dir);
      // the folder is not one of the settings a resumed run must share (its fits are kept there)
      cmd->get_option("--out")->configurable(false);
      cmd->add_option("--data", o->data, "measured runs (CSV: time_s, current_A or voltage_V, outlet_pressure_Pa, ...)")
        ->required();
      cmd->add_option("--scenario", o->scenario, "no-flow or loaded (all runs)")
        ->check(CLI::IsMember({"no-flow", "loaded"}))
        ->capture_default_str();
      cmd->add_option("--frequency", o->frequency_Hz, "pumping frequency [Hz] (default: from each run's drive)");
      cmd->add_option("--effects", o->options.effects, "candidate effects (default: all)");
      cmd->add_flag("--second-effect", o->second, "after naming one effect, look for a second");
      cmd->add_option("--training-fraction", o->options.training_fraction,
                      "part of each run the fit sees; the rest is held out")->capture_default_str();
      cmd->add_option("--compared-cycles", o->options.compared_cycles,
                      "the candidates are fitted and compared on at most this many training cycles in all, "
                      "the same number from each run; the named effect is then refitted on all (0: all)")
        ->check(CLI::Range(0.0, 1e6))
        ->capture_default_str();
      cmd->add_option("--max-evaluations", o->options.max_evaluations, "optimiser evaluations per candidate")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
      cmd->add_option("--profile-moves", o->options.max_profile_moves,
                      "times a named effect's fit moves to a side of its profile that fits better (0: never)")
        ->check(CLI::Range(0, 10))
        ->capture_default_str();
      cmd->add_option("--threads", o->options.threads, "candidates fitted at once (0: all cores)");
      cmd->add_option("--rtol", o->options.relative_tolerance, "CVODE relative tolerance")
        ->check(CLI::Range(1e-12, 1e-2))
        ->capture_default_str();
      cmd->add_option("--start", o->options.start,
                      "where each record starts: auto (the best over its first two cycles), rest, record "
                      "(the state its first samples show), record-mean (as record, the high side at the "
                      "outlet pressure's mean over the first cycle; auto tries it in no-flow runs), steady "
                      "(static state under its first drive value) or periodic (a run-in of its first cycle)")
        ->check(CLI::IsMember({"auto", "rest", "record", "record-mean", "steady", "periodic"}))
        ->capture_default_str();
      cmd->add_option("--lead-cycles", o->options.lead_cycles, "cycles of run-in before a periodic start")
        ->check(CLI::Range(1.0, 1000.0))
        ->capture_default_str();
      cmd->add_option("--settling-cycles", o->options.settling_cycles,
                      "cycles at each record's start left out of the residual (default: 0 from rest, else 1, and "
                      "from the named fit on the named model's memory of its start, at least 1)")
        ->check(CLI::Range(0.0, 100.0));
      cmd->add_option("--harmonics", o->harmonics,
                      "compare data and model within this many harmonics of the pumping frequency (0: every "
                      "sample as measured); auto: 10, and in a loaded run only those at or below half the reed's "
                      "natural frequency (where the valves flutter)")
        ->check(CLI::Validator(
          [](std::string &text) -> std::string {
            if (text == "auto")
              return {};
            char        *end = nullptr;
            const double v   = std::strtod(text.c_str(), &end);
            if (text.empty() || *end != '\0' || !(v >= 0 && v <= 1000))
              return "'" + text + "' is neither 'auto' nor a number in [0, 1000]";
            return {};
          },
          "auto|0..1000", "harmonics"))
        ->capture_default_str();
      cmd->add_option("--reed-second-mode", o->reed_second_mode,
                      "the reeds' second bending mode in the baseline: auto (the case's; if it gives none, a "
                      "loaded run gets a uniform cantilever's at 6.267 x the first mode), case, or a frequency [Hz]")
        ->capture_default_str();
      cmd->add_flag("--ideal-sensors", o->ideal_sensors,
                    "do not fit the sensors' lags (the case's [sensors]) to the final model: compare it as it is");
      cmd->add_flag("!--keep-outliers", o->options.repair_outliers,
                    "do not look for isolated spikes in the records (default: found, reported, replaced)");
      cmd->add_option("--gain-range", o->options.gain_range, "nuisance force gain fitted in 1 +- this")
        ->check(CLI::Range(0.0, 0.5))
        ->capture_default_str();
      cmd->add_option("--identifiability-sd", o->options.identifiability_sd,
                      "a baseline parameter whose standard error (every compared sample counted as "
                      "independent) exceeds this share of its range is held")
        ->check(CLI::Range(0.001, 1.0))
        ->capture_default_str();
      cmd->add_option("--determined-sd", o->options.determined_relative_sd,
                      "the named effect's parameter is reported as determined when moving it this share either "
                      "way (the baseline refitted) fits worse by the naming's evidence, and its standard error is "
                      "at most this share")
        ->check(CLI::Range(0.001, 2.0))
        ->capture_default_str();
      cmd->add_option("--beyond-library", o->options.beyond_library_noise_units,
                      "residual [noise units] above which the verdict says: model error beyond the library")
        ->check(CLI::Range(1.0, 1000.0))
        ->capture_default_str();
      cmd->callback([o, cmd] {
        o->settings = cmd->config_to_str(true, false);
        diagnose(*o);
      });
    }

    auto o   = std::make_shared<SynthCommandOptions>();
    auto cmd = app.add_subcommand(
      "synth", "synthetic measured run: the model with one hidden effect, plus noise "
               "(DIR/data.csv; the answer in DIR/answer.json)");
    add_case_and_out(*cmd, o->case_path, o->out_dir);
    cmd->add_option("--effect", o->synth.effect,
                    "hidden effect: none or one of " + diagnosis::effect_names())
      ->capture_default_str();
    cmd->add_option("--param", o->params,
                    "effect parameter KEY=VALUE (repeatable; default: the middle of its bounds)");
    cmd->add_option("--noise", o->synth.noise,
                    "Gaussian noise, standard deviation as a fraction of each column's RMS")
      ->capture_default_str();
    cmd->add_option("--drive-noise", o->synth.drive_noise,
                    "noise on the drive column (default: --noise)");
    cmd->add_option("--seed", o->synth.seed, "random seed of the noise")->capture_default_str();
    cmd->add_option("--scenario", o->scenario, "no-flow or loaded")
      ->check(CLI::IsMember({"no-flow", "loaded"}))
      ->capture_default_str();
    cmd->add_option("--frequency", o->synth.frequency_Hz, "pumping frequency [Hz]")
      ->capture_default_str();
    cmd->add_option("--cycles", o->synth.cycles, "pumping cycles recorded from rest")
      ->capture_default_str();
    cmd->add_option("--samples-per-cycle", o->synth.samples_per_cycle, "samples per pumping cycle")
      ->capture_default_str();
    cmd->add_option("--current-pp", o->current_pp_A, "coil current peak-to-peak [A] (default: case [drive])");
    cmd->add_option("--current-bias", o->current_bias_A, "coil current bias [A] (default: case [drive])");
    cmd->add_option("--drive", o->synth.drive,
                    "drive column: current, voltage (R_coil x the current sine) or auto "
                    "(voltage for coil_dynamics)")
      ->check(CLI::IsMember({"auto", "current", "voltage"}))
      ->capture_default_str();
    cmd->callback([o] { synth(*o); });
  }
} // namespace rectify::app
