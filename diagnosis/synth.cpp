#include "diagnosis/synth.h"

#include <cmath>
#include <random>

#include "common/case_file.h"
#include "diagnosis/effect.h"
#include "diagnosis/observation.h"

namespace rectify::diagnosis
{
  namespace
  {
    /// The options in range (an error naming the option and its value).
    void check_options(const SynthOptions &o)
    {
      if (!(o.noise >= 0 && o.noise < 1))
        throw InputError("--noise " + format_number(o.noise) + ": must be in [0, 1)");
      if (!std::isnan(o.drive_noise) && !(o.drive_noise >= 0 && o.drive_noise < 1))
        throw InputError("--drive-noise " + format_number(o.drive_noise) + ": must be in [0, 1)");
      if (!(o.frequency_Hz > 0) || !std::isfinite(o.frequency_Hz))
        throw InputError("--frequency " + format_number(o.frequency_Hz) + ": must be > 0");
      if (o.cycles < 2)
        throw InputError("--cycles " + std::to_string(o.cycles) + ": must be >= 2");
      if (o.samples_per_cycle < 8)
        throw InputError("--samples-per-cycle " + std::to_string(o.samples_per_cycle) + ": must be >= 8");
      // About 200 bytes a sample (the record's columns, the model's series):
      // 10^7 samples is 2 GB; more is refused rather than failing mid-run.
      if (o.samples_per_cycle > 10000000 || o.cycles > 10000000 || o.samples_per_cycle * o.cycles > 10000000)
        throw InputError("--cycles " + std::to_string(o.cycles) + " x --samples-per-cycle " +
                         std::to_string(o.samples_per_cycle) + ": at most 10^7 samples in a record");
      if (o.drive != "auto" && o.drive != "current" && o.drive != "voltage")
        throw InputError("--drive '" + o.drive + "': current, voltage or auto");
    }

    /// The hidden effect applied to p with its --param values (its bounds'
    /// middle by default); returns them by key.
    nlohmann::json apply_hidden_effect(const SynthOptions &o, bool voltage, system::SystemParameters &p)
    {
      nlohmann::json parameters = nlohmann::json::object();
      if (o.effect == "none")
        {
          if (!o.parameters.empty())
            throw InputError("--param " + o.parameters.begin()->first + ": effect 'none' has no parameters");
          return parameters;
        }
      const auto effect = find_effect(o.effect);
      // An effect that cannot act in this run would leave it unchanged:
      // the "answer" would name an effect the data cannot show.
      if (const std::string why = effect->not_testable({o.scenario, voltage}); !why.empty())
        throw InputError("--effect " + o.effect + " in a " + system::to_string(o.scenario) + " run: " + why);
      std::vector<double> values;
      for (const auto &spec : effect->parameters())
        {
          const auto   it = o.parameters.find(spec.key);
          const double v  = it == o.parameters.end() ? spec.mid() : it->second;
          if (!(v >= spec.lower && v <= spec.upper))
            throw InputError("--param " + spec.key + "=" + format_number(v) + ": outside " + o.effect +
                             "'s bounds [" + format_number(spec.lower) + ", " + format_number(spec.upper) + "]");
          values.push_back(v);
          parameters[spec.key] = v;
        }
      for (const auto &[key, value] : o.parameters)
        if (!parameters.contains(key))
          {
            std::string keys;
            for (const auto &spec : effect->parameters())
              keys += (keys.empty() ? "" : ", ") + spec.key;
            throw InputError("--param " + key + ": not a parameter of " + o.effect + " (" + keys + ")");
          }
      effect->apply(values, p);
      return parameters;
    }

    /// The record: each column with Gaussian noise of `noise` (the drive's
    /// `drive_noise`) times its RMS about its mean; `sd` gets those.
    CsvTable noisy_record(const SynthOptions &o, const std::vector<std::string> &columns, Signals &signals,
                          const std::vector<double> &times, std::map<std::string, double> &sd)
    {
      const std::size_t                n = times.size();
      std::mt19937_64                  rng(o.seed);
      std::normal_distribution<double> normal(0.0, 1.0);
      for (std::size_t c = 1; c < columns.size(); ++c)
        {
          const auto &v    = signals[columns[c]];
          double      mean = 0, var = 0;
          for (double x : v)
            mean += x / static_cast<double>(n);
          for (double x : v)
            var += (x - mean) * (x - mean) / static_cast<double>(n);
          sd[columns[c]] = (c == 1 && !std::isnan(o.drive_noise) ? o.drive_noise : o.noise) * std::sqrt(var);
        }
      CsvTable            data(columns);
      std::vector<double> row(columns.size());
      for (std::size_t i = 0; i < n; ++i)
        {
          row[0] = times[i];
          for (std::size_t c = 1; c < columns.size(); ++c)
            row[c] = signals[columns[c]][i] + sd[columns[c]] * normal(rng);
          data.add_row(row);
        }
      return data;
    }
  } // namespace

  SynthResult synthesise(const system::SystemParameters &base, const system::ValveMaps &map,
                         const SynthOptions &o)
  {
    check_options(o);
    const bool voltage = o.drive == "voltage" || (o.drive == "auto" && o.effect == "coil_dynamics");
    system::SystemParameters p          = base;
    const nlohmann::json     parameters = apply_hidden_effect(o, voltage, p);

    const double R     = p.transducer.coil_resistance_ohm;
    const std::size_t n = o.cycles * o.samples_per_cycle + 1;
    std::vector<double> times(n), drive(n);
    const auto          sine = system::Drive::sine(o.frequency_Hz, o.current_pp_A, o.current_bias_A);
    for (std::size_t i = 0; i < n; ++i)
      {
        times[i] = static_cast<double>(i) / (o.frequency_Hz * static_cast<double>(o.samples_per_cycle));
        drive[i] = (voltage ? R : 1.0) * sine.current_A(times[i]);
      }
    const auto model_drive = voltage ?
                               system::Drive::from_samples(times, drive, o.frequency_Hz, true, "synth") :
                               sine;
    Signals signals = simulate_drive(p, map, model_drive, o.scenario, times, o.relative_tolerance);
    const std::string drive_column = voltage ? "voltage_V" : "current_A";
    signals[drive_column] = drive;

    std::vector<std::string> columns{"time_s", drive_column};
    for (const auto &c : signal_columns())
      if (signals.count(c))
        columns.push_back(c);
    std::map<std::string, double> sd;
    SynthResult result{noisy_record(o, columns, signals, times, sd), {}};
    result.answer = {{"effect", o.effect},
                     {"parameters", parameters},
                     {"noise", o.noise},
                     {"drive_noise", !std::isnan(o.drive_noise) ? o.drive_noise : o.noise},
                     {"noise_sd", sd},
                     {"seed", o.seed},
                     {"scenario", system::to_string(o.scenario)},
                     {"frequency_Hz", o.frequency_Hz},
                     {"cycles", o.cycles},
                     {"samples_per_cycle", o.samples_per_cycle},
                     {"drive", drive_column},
                     {"current_pp_A", o.current_pp_A},
                     {"current_bias_A", o.current_bias_A}};
    return result;
  }
} // namespace rectify::diagnosis
