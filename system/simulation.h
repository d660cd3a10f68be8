// One run of the model under a scenario: integrate, record, and reduce to the
// thesis's metrics (stored pressure, eq. 5.1; mean actuator velocity, eq. 5.2).
#pragma once

#include <nlohmann/json.hpp>
#include <array>
#include <functional>
#include <optional>

#include "common/io.h"
#include "system/model.h"
#include "system/validity.h"

namespace rectify::system
{
  struct RunOptions
  {
    std::size_t n_cycles = 10; ///< fixed-length run: cycles simulated (no settling)
    /// Adaptive start-up: run until the cycle-mean metric is settled, then
    /// measure `n_cycles` more. Off: the metrics are means over the whole run,
    /// as eqs. 5.1 and 5.2 define them.
    bool        settle             = false;
    std::size_t max_startup_cycles = 1000;
    double      settle_tolerance   = 2e-3; ///< relative, see docs/system-model.md
    bool        record             = false; ///< keep a time series
    std::size_t samples_per_cycle  = 200;
    double      relative_tolerance = 1e-6;
    /// CVODE's relative tolerance while settling (0: relative_tolerance):
    /// a looser one reaches the settled response in fewer steps; the measured
    /// cycles always use relative_tolerance (docs/benchmarks.md).
    double      startup_relative_tolerance = 0;
    double      absolute_tolerance_factor = 10.0;
    bool        finite_difference_jacobian = false;
    long        max_steps_per_cycle        = 1000000;
    /// Called after every finished cycle with (cycles done, cycles planned;
    /// 0 while settling). For progress displays.
    std::function<void(std::size_t, std::size_t)> on_cycle;
  };

  /// The case's [solver] settings as run options (the rest at their defaults).
  RunOptions run_options(const SolverParameters &solver);

  /// Where a run starts when not from rest: the continuous state and each
  /// valve's discrete state (closed on its seat). A state taken at the end of
  /// a whole cycle of a sine drive is at the drive's phase 0, where a run
  /// starts: what a sweep's continuation uses (the next frequency starts
  /// where the last one settled).
  struct StartState
  {
    std::vector<double> y;
    std::array<bool, 2> closed{true, true};
    std::array<bool, 2> at_stop{false, false}; ///< each reed held at its stop
  };

  struct RunResult
  {
    double      frequency_Hz = 0;
    double      stored_pressure_Pa    = 0; ///< mean p_o over the measured window (eq. 5.1)
    double      mean_velocity_m_per_s = 0; ///< mean dx_act/dt over the measured window (eq. 5.2)
    double      start_time_s = 0, end_time_s = 0; ///< the measured window
    std::size_t n_startup_cycles = 0, n_measured_cycles = 0;
    bool        settled = true;
    /// Standard error of the metric's mean over the window, from the means of
    /// ten batches of cycles: about 0 for a periodic response, the sampling
    /// uncertainty of the mean for a non-periodic one (valve flutter).
    double      metric_stderr = 0;
    /// "periodic" (period 1), "period-k" (k = 2..4 cycles) or "non-periodic",
    /// from the states at the ends of the last cycles.
    std::string regime = "periodic";
    double      wall_time_s = 0;
    IntegratorStats stats;
    // checks and diagnostics
    double      volume_balance_rel_error = 0; ///< max over the three balances, see .cpp
    double      max_outlet_reed_opening_m = 0, max_inlet_reed_opening_m = 0;
    double      min_reed_opening_m = 0; ///< must be >= 0 (seat), up to round-off
    double      min_absolute_chamber_pressure_Pa = 0;
    double      piston_stroke_m = 0; ///< max - min piston position over the measured window
    double      pumped_volume_m3 = 0; ///< net volume through the outlet valve, measured window
    std::size_t n_seat_impacts = 0, n_stop_impacts = 0;
    std::size_t n_samples_beyond_map = 0;
    /// The measured window: each reed's openings, root stress, Goodman
    /// factor and impacts; each volume's lowest pressure and cavity; and
    /// whether the run describes a state hardware can reach.
    std::array<ValveStatistics, 2> valves;
    std::vector<VolumeStatistics>  volumes;
    Validity                       validity;
    std::vector<std::string> warnings;
    std::optional<CsvTable> series;
    StartState  end_state; ///< the state at the end of the run (a whole number of cycles)

    nlohmann::json to_json() const;
  };

  /// Runs the model from rest (all pressures at the bias, valves closed), or
  /// from `start` if given (its state must have the model's size). Times are
  /// counted from the run's start either way; the volume balances are taken
  /// over the run. Model::reset() is called first, so one Model serves many runs.
  RunResult run(Model &model, const RunOptions &options, const StartState *start = nullptr);

  /// Integrator options from the model and the run options.
  IntegratorOptions integrator_options(const Model &model, const RunOptions &options);

  nlohmann::json to_json(const IntegratorStats &stats);
} // namespace rectify::system
