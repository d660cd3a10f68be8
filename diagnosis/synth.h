// Synthetic measured runs: the system model with one hidden effect on, plus
// measurement noise, written as a MeasuredRun CSV (`rectify synth`). The
// answer (effect, parameters, noise) goes to a separate file, so that the
// diagnosis workflow can be scored on data whose truth is known.
#pragma once

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "common/io.h"
#include "maps/resistance_map.h"
#include "system/model.h"
#include "system/parameters.h"

namespace rectify::diagnosis
{
  struct SynthOptions
  {
    std::string                   effect = "none";
    std::map<std::string, double> parameters; ///< by key; missing keys: the bounds' middle
    double                        noise = 0.01; ///< Gaussian, sd = noise x each column's RMS about its mean
    double                        drive_noise = std::nan(""); ///< the same for the drive column; NaN (not given): `noise`
    unsigned long                 seed  = 1;
    system::Scenario              scenario = system::Scenario::no_flow;
    double                        frequency_Hz = 100;
    std::size_t                   cycles = 20;
    std::size_t                   samples_per_cycle = 200;
    double                        current_pp_A = 20, current_bias_A = 10;
    /// Drive column: "current" or "voltage" (V = R_coil I of the same sine);
    /// "auto": voltage for coil_dynamics, else current.
    std::string                   drive = "auto";
    double                        relative_tolerance = 1e-7;
  };

  struct SynthResult
  {
    CsvTable       data;
    nlohmann::json answer;
  };

  /// Throws InputError for an unknown effect or parameter key, or a value
  /// outside the effect's bounds.
  SynthResult synthesise(const system::SystemParameters &base, const system::ValveMaps &map,
                         const SynthOptions &options);
} // namespace rectify::diagnosis
