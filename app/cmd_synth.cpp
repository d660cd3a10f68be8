// `rectify synth`: a synthetic measured run, the model with one hidden effect
// plus noise (diagnosis/synth.h), for trying the diagnosis on a known answer.
#include <cmath>
#include <cstdio>

#include "app/commands.h"
#include "common/io.h"
#include "common/output_lock.h"
#include "common/version.h"
#include "diagnosis/effect.h"
#include "diagnosis/synth.h"

namespace rectify::app
{
  namespace
  {
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
  } // namespace

  void register_synth_command(CLI::App &app)
  {
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
