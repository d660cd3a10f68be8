// Frequency sweeps (thesis Figs. 5.3, 5.4, 5.6): one settled run per
// frequency and series, in parallel, with progress, resumable. Every finished
// run is appended at once to DIR/sweep-partial.csv; a killed sweep started
// again with the same settings continues where it stopped and never repeats
// or loses a finished run.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "system/simulation.h"

namespace rectify::system
{
  /// One curve of a sweep: a valve model and, for the what-if, reed scalings.
  struct SweepSeries
  {
    std::string name;
    ValveModel  valves           = ValveModel::dynamic;
    double      stiffness_factor = 1.0;
    double      mass_factor      = 1.0;
  };

  /// "dynamic", "ideal", "reed-whatif" (k_r x3, m_r x0.5: thesis sec. 5.2.2).
  SweepSeries parse_sweep_series(const std::string &name);

  struct SweepOptions
  {
    Scenario                 scenario = Scenario::loaded;
    std::vector<double>      frequencies_Hz;
    std::vector<SweepSeries> series;
    double                   current_pp_A = 20, current_bias_A = 10;
    RunOptions               run; ///< settle, n_cycles (measured), tolerances
    unsigned                 jobs  = 0; ///< 0: all cores
    /// Continuation: each series' frequencies run in this many chains, each
    /// frequency starting where its lower neighbour settled (0: every
    /// frequency from rest). A result depends on it (not on `jobs`).
    std::size_t              chains = 0;
    bool                     quiet = false;
  };

  struct SweepPoint
  {
    std::string series;
    double      frequency_Hz, stored_pressure_Pa, mean_velocity_m_per_s;
    bool        settled;
    double      metric_stderr; ///< standard error of the metric's mean (batch means)
    std::string regime;        ///< periodic, period-k, non-periodic; "failed: <why>" (numbers NaN)
    bool        failed() const { return regime.rfind("failed", 0) == 0; }
    std::size_t startup_cycles, measured_cycles;
    double      wall_time_s, volume_balance_rel_error;
    long        steps, rhs_evaluations, jacobian_evaluations, events;
    std::size_t warnings;
    /// The run's validity (system/validity.h) and what decides it, over
    /// both valves and every volume: the valid flag and the seven flags,
    /// then the numbers behind them (NaN for a failed run).
    bool   valid = false, beyond_map = false, beyond_stop = false, below_cavitation_pressure = false,
           goodman_below_1 = false, at_stop = false, cavitating = false, large_deflection = false;
    double max_outlet_opening_m = 0, max_inlet_opening_m = 0;
    double goodman_factor = 0;      ///< the worse valve's (infinity: no stress)
    double max_root_stress_Pa = 0;  ///< the larger of the two reeds' peak root stress
    double max_seat_impact_m_per_s = 0, max_stop_impact_m_per_s = 0;
    double max_cavity_volume_m3 = 0;     ///< the largest volume's cavity
    double min_absolute_pressure_Pa = 0; ///< the lowest pressure of any volume
    /// Fills the validity columns from a run.
    void set_validity(const RunResult &r);
  };

  /// The CSV header and one row of a SweepPoint: the checkpoint file
  /// (sweep-partial.csv) and the sweep's table of runs (sweep-runs.csv) share
  /// them. Numbers are written to round-trip exactly.
  std::string sweep_point_csv_header();
  std::string to_csv_row(const SweepPoint &point);

  struct SweepResult
  {
    std::vector<SweepPoint> points; ///< ordered by series, then frequency
    std::size_t             n_resumed = 0;
    double                  wall_time_s = 0;
  };

  /// A sweep as `rectify sweep` runs it by default, without its series: the
  /// case's drive currents and [solver] settings, a settled start-up
  /// (tolerance 2e-3, at most 1000 cycles), then `n_cycles` measured, 16
  /// samples a cycle (a sweep keeps no time series).
  SweepOptions default_sweep_options(const SystemParameters &parameters, Scenario scenario,
                                     std::vector<double> frequencies_Hz, std::size_t n_cycles);

  /// Runs the sweep, checkpointing into `out_dir` (which must exist).
  SweepResult run_sweep(const SystemParameters &parameters, const SweepOptions &options,
                        const std::filesystem::path &out_dir);

  /// `n` frequencies from `from` to `to`, log- or linearly spaced.
  std::vector<double> frequency_grid(double from_Hz, double to_Hz, std::size_t n, bool log_spacing);
} // namespace rectify::system
