// `rectify diagnose`: measured runs against the system model, the missing
// effect found, named and added (diagnosis/). This command reads and checks
// its options, echoes them, runs the diagnosis and prints its answer; the
// report (diagnosis/report.h) writes the folder.
#include <cmath>
#include <cstdio>

#include "app/commands.h"
#include "common/output_lock.h"
#include "diagnosis/diagnose.h"
#include "diagnosis/effect.h"
#include "diagnosis/kept_fits.h"
#include "diagnosis/report.h"
#include "diagnosis/sensors.h"
#include "diagnosis/words.h"
#include "system/model.h"

namespace rectify::app
{
  namespace
  {
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

    /// The options checked, and those the case sets (the sensors' limits)
    void check_options(DiagnoseCommandOptions &o, const CaseFile &file)
    {
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
    }

    std::string joined(const std::vector<std::string> &items, const char *separator)
    {
      std::string s;
      for (const auto &item : items)
        s += (s.empty() ? "" : separator) + item;
      return s;
    }

    std::string sensors_text(const diagnosis::DiagnoseOptions &o)
    {
      if (o.sensor_lowest_bandwidth_Hz.empty())
        return "ideal";
      std::string s = "a first-order lag per signal, fitted to the final model down to:";
      for (const auto &[signal, f] : o.sensor_lowest_bandwidth_Hz)
        s += " " + signal + " " + format_number(f) + " Hz";
      return s;
    }

    void echo(const DiagnoseCommandOptions &o, const std::vector<diagnosis::RunCase> &runs,
              const system::SystemParameters &p, const diagnosis::BaselineSecondMode &second_mode)
    {
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
                                 {"candidates", o.options.effects.empty() ? "all: " + diagnosis::effect_names() :
                                                                            joined(o.options.effects, ", ")},
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
                                 {"sensors", sensors_text(o.options)},
                                 {"out", o.out_dir}});
    }

    void print_answer(const diagnosis::DiagnosisResult &result, const std::filesystem::path &out,
                      const std::string &case_name)
    {
      std::printf("effect: %s", result.rounds.front().effect.value_or("none").c_str());
      for (std::size_t k = 1; k < result.rounds.size(); ++k)
        std::printf(", then %s", result.rounds[k].effect.value_or("none").c_str());
      std::printf("\n%s\n", diagnosis::decision_words(result.rounds.front()).c_str());
      std::printf("verdict: %s. %s\n", diagnosis::to_string(result.verdict).c_str(),
                  diagnosis::verdict_words(result).c_str());
      if (const auto words = diagnosis::uncertainty_words(result.rounds.front()); !words.empty())
        std::printf("parameters: %s\n", words.c_str());
      for (const auto &rc : result.runs)
        std::printf("  %s: start %s, %zu outlier(s) replaced\n", rc.run.source.c_str(),
                    diagnosis::to_string(rc.start).c_str(), rc.outliers.size());
      for (const auto &run : result.remaining_before)
        for (const auto &s : run)
          std::printf("  before: %s\n", diagnosis::residual_words(s).c_str());
      std::printf("residual (RMS in units of each signal's noise, all signals): %.4g before, %.4g after (%.1f %% "
                  "smaller)\n",
                  result.residual_before.at("overall"), result.residual_after.at("overall"),
                  100 * (1 - result.residual_after.at("overall") / result.residual_before.at("overall")));
      std::printf("wrote %s, %s\n", (out / "summary.json").c_str(), (out / case_name).c_str());
    }

    void diagnose(DiagnoseCommandOptions o)
    {
      diagnosis::ReportInputs in;
      const CaseFile          file = load_case(o.case_path);
      auto                    p    = system::SystemParameters::from_case(file);
      const auto              scenario = system::parse_scenario(o.scenario);
      in.file_second_mode_Hz          = p.reed.second_mode_frequency_Hz;
      in.second_mode                  = diagnosis::baseline_second_mode(p, scenario, o.reed_second_mode);
      p.reed.second_mode_frequency_Hz = in.second_mode.frequency_Hz;
      check_options(o, file);
      const auto runs = diagnosis::read_run_cases(o.data, scenario, o.frequency_Hz, o.options,
                                                  diagnosis::band_reed_frequency_Hz(p, scenario, o.options),
                                                  [](const std::string &line) { std::fprintf(stderr, "%s\n", line.c_str()); });
      echo(o, runs, p, in.second_mode);
      o.options.progress = [](const std::string &line) { std::fprintf(stderr, "  %s\n", line.c_str()); };
      const std::filesystem::path out(o.out_dir);
      const bool                  made_out = !std::filesystem::exists(out);
      OutputLock                  lock; // a folder in use is refused now, not after minutes of fits
      lock.acquire_if_exists(out);
      const auto map = system::load_valve_maps(p);
      // Each candidate's fit is kept in the folder as it ends: the same
      // command, interrupted, takes them up again (DiagnoseOptions).
      lock.acquire(out); // made now (the maps read: bad input leaves none)
      o.options.checkpoint_dir         = out;
      o.options.checkpoint_fingerprint = diagnosis::checkpoint_fingerprint(o.settings, o.case_path, o.data);
      o.options.checkpoint_dir_made    = made_out;
      const auto result                = diagnosis::diagnose(p, map, runs, o.options);
      in.case_path       = o.case_path;
      in.case_file       = file.name();
      in.scenario        = o.scenario;
      in.data            = o.data;
      in.case_parameters = p;
      in.options         = o.options;
      in.load_case       = [](const std::filesystem::path &path) { return load_case(path); };
      const auto case_name = diagnosis::write_report(result, runs, map, in, out, made_out);
      print_answer(result, out, case_name);
      diagnosis::remove_checkpoint(out); // complete: nothing left to resume
    }

    /// How each candidate is fitted and compared.
    void add_fit_options(CLI::App &cmd, DiagnoseCommandOptions &o)
    {
      cmd.add_option("--training-fraction", o.options.training_fraction,
                     "part of each run the fit sees; the rest is held out")->capture_default_str();
      cmd.add_option("--compared-cycles", o.options.compared_cycles,
                     "the candidates are fitted and compared on at most this many training cycles in all, "
                     "the same number from each run; the named effect is then refitted on all (0: all)")
        ->check(CLI::Range(0.0, 1e6))
        ->capture_default_str();
      cmd.add_option("--max-evaluations", o.options.max_evaluations, "optimiser evaluations per candidate")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
      cmd.add_option("--profile-moves", o.options.max_profile_moves,
                     "times a named effect's fit moves to a side of its profile that fits better (0: never)")
        ->check(CLI::Range(0, 10))
        ->capture_default_str();
      cmd.add_option("--threads", o.options.threads, "candidates fitted at once (0: all cores)");
      cmd.add_option("--rtol", o.options.relative_tolerance, "CVODE relative tolerance")
        ->check(CLI::Range(1e-12, 1e-2))
        ->capture_default_str();
      cmd.add_option("--start", o.options.start,
                     "where each record starts: auto (the best over its first two cycles), rest, record "
                     "(the state its first samples show), record-mean (as record, the high side at the "
                     "outlet pressure's mean over the first cycle; auto tries it in no-flow runs), steady "
                     "(static state under its first drive value) or periodic (a run-in of its first cycle)")
        ->check(CLI::IsMember({"auto", "rest", "record", "record-mean", "steady", "periodic"}))
        ->capture_default_str();
      cmd.add_option("--lead-cycles", o.options.lead_cycles, "cycles of run-in before a periodic start")
        ->check(CLI::Range(1.0, 1000.0))
        ->capture_default_str();
      cmd.add_option("--settling-cycles", o.options.settling_cycles,
                     "cycles at each record's start left out of the residual (default: 0 from rest, else 1, and "
                     "from the named fit on the named model's memory of its start, at least 1)")
        ->check(CLI::Range(0.0, 100.0));
      cmd.add_option("--harmonics", o.harmonics,
                     "compare data and model within this many harmonics of the pumping frequency (0: every "
                     "sample as measured); auto: 10, and in a loaded run only those at or below half the reed's "
                     "natural frequency (where the valves flutter)")
        ->check(auto_or_range(0, 1000, "harmonics"))
        ->capture_default_str();
    }

    /// The baseline's second mode, the sensors, the records' outliers, the judgement's thresholds.
    void add_judging_options(CLI::App &cmd, DiagnoseCommandOptions &o)
    {
      cmd.add_option("--reed-second-mode", o.reed_second_mode,
                     "the reeds' second bending mode in the baseline: auto (the case's; if it gives none, a "
                     "loaded run gets a uniform cantilever's at 6.267 x the first mode), case, or a frequency [Hz]")
        ->capture_default_str();
      cmd.add_flag("--ideal-sensors", o.ideal_sensors,
                   "do not fit the sensors' lags (the case's [sensors]) to the final model: compare it as it is");
      cmd.add_flag("!--keep-outliers", o.options.repair_outliers,
                   "do not look for isolated spikes in the records (default: found, reported, replaced)");
      cmd.add_option("--gain-range", o.options.gain_range, "nuisance force gain fitted in 1 +- this")
        ->check(CLI::Range(0.0, 0.5))
        ->capture_default_str();
      cmd.add_option("--identifiability-sd", o.options.identifiability_sd,
                     "a baseline parameter whose standard error (every compared sample counted as "
                     "independent) exceeds this share of its range is held")
        ->check(CLI::Range(0.001, 1.0))
        ->capture_default_str();
      cmd.add_option("--determined-sd", o.options.determined_relative_sd,
                     "the named effect's parameter is reported as determined when moving it this share either "
                     "way (the baseline refitted) fits worse by the naming's evidence, and its standard error is "
                     "at most this share")
        ->check(CLI::Range(0.001, 2.0))
        ->capture_default_str();
      cmd.add_option("--beyond-library", o.options.beyond_library_noise_units,
                     "residual [noise units] above which the verdict says: model error beyond the library")
        ->check(CLI::Range(1.0, 1000.0))
        ->capture_default_str();
    }

    void register_diagnose_command(CLI::App &app)
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
      add_fit_options(*cmd, *o);
      add_judging_options(*cmd, *o);
      cmd->callback([o, cmd] {
        o->settings = cmd->config_to_str(true, false);
        diagnose(*o);
      });
    }
  } // namespace

  void register_diagnosis_commands(CLI::App &app)
  {
    register_diagnose_command(app);
    register_synth_command(app);
  }
} // namespace rectify::app
