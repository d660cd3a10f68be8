// Preparing the runs (the first stage of diagnose()): each measured record
// with its setup, the band it is compared in, its noise scales, its start
// state and settling window.
//
// Takes: the measured records, the case's model (its parameters and maps),
// the options.
// Gives: RunCase per record, its scales calibrated with a given model
// (calibrate_noise), its start chosen (choose_start) and its settling
// window set (settle).
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "diagnosis/measured_run.h"
#include "diagnosis/observation.h"
#include "diagnosis/options.h"
#include "maps/resistance_map.h"
#include "system/parameters.h"

namespace rectify::diagnosis
{

  /// One run with its setup and normalisation.
  struct RunCase
  {
    MeasuredRun                   run;
    RunSetup                      setup;
    std::map<std::string, double> scales; ///< residual scale per signal (noise, see above)
    std::map<std::string, double> swings; ///< RMS about the mean per signal (for words)
    double                        drive_noise_sd = 0; ///< estimated from the drive
    std::size_t                   n_train = 0; ///< samples the fit sees (end of the training part)
    std::size_t                   n_skip  = 0; ///< settling samples left out at the start
    /// The model's runs from its start and from another (its periodic
    /// orbit; a periodic start: the recorded state), RMS difference per
    /// training cycle in noise units (settle; empty where not computed)
    std::vector<double>           start_memory;
    /// Why n_skip is what it is (words.h: settling_words)
    struct Settling
    {
      enum class Why
      {
        unset,
        given,        ///< --settling-cycles
        rest_exact,   ///< none: a start at rest is exact
        one_cycle,    ///< one cycle, not measured (yet)
        few_cycles,   ///< one: fewer than two training cycles to measure the memory in
        run_failed,   ///< one: a run from one of the two starts failed
        orbits_apart, ///< one: the runs from the two starts do not meet (`last`, `largest` apart)
        meets_later,  ///< `cycles`, half the training part: still `apart` in the cycle after
        settled       ///< `cycles`: within `tolerance` from then on (`apart` in the first)
      };
      Why         why = Why::unset;
      StartState  start = StartState::rest, other = StartState::periodic; ///< the two starts compared
      std::size_t cycles = 0;
      double      apart = 0, last = 0, largest = 0, tolerance = 0; ///< noise units per cycle
    };
    Settling                      settling;
    StartState                    start   = StartState::rest;
    double                        lead_cycles = 0;   ///< simulated before the record
    /// Its state at the first sample (StartState::record), read once from
    /// the record before it is band-limited.
    RecordedState                 recorded;
    /// Its cleaned drive (measured_drive), made once from `run` by
    /// make_run_case: remake it if `run` changes.
    std::shared_ptr<const system::Drive> drive;
    nlohmann::json                start_scores;      ///< residual of each start tried (auto)
    /// Each time the start was chosen again, with a named effect's fit,
    /// and changed: from what, to what, with which effect (a later round
    /// appends its own)
    struct StartRevision
    {
      StartState  from, to;
      std::string effect;
    };
    std::vector<StartRevision>    start_revisions;
    std::vector<Outlier>          outliers;          ///< found and replaced in the record
    double                        band_Hz = 0;        ///< the comparison's band (0: whole)
    double                        harmonics = 0;      ///< harmonics compared (0: every sample)
    /// Why the band stops where it does: as asked, below half the reed's
    /// natural frequency (`reed_Hz`), or not at all (the sampling's Nyquist)
    enum class BandWhy
    {
      unset,
      as_asked,
      below_reed,
      nyquist
    };
    BandWhy                       band_why = BandWhy::unset;
    double                        reed_Hz  = 0;
    double                        band_fraction = 1;  ///< of the white noise's power inside it
    std::map<std::string, double> white_sd;           ///< each signal's white noise (whole band)
    std::map<std::string, double> cyclic_sd;          ///< its cycle-to-cycle scatter inside the band

    /// The simulation options for this run (start, lead).
    SimulationOptions simulation(double relative_tolerance) const;
  };

  /// Training cycles per run (after each run's settling, n_skip) that the
  /// candidates are compared on, so that at most `cap` are compared in
  /// all: the same number from every run that has that many, the whole
  /// training part of the shorter ones, at least 3. 0 (every training
  /// cycle) where the runs hold no more than `cap`, or `cap` is 0.
  double screening_cycles_per_run(const std::vector<RunCase> &runs, double cap);


  /// Prepares a run: its frequency (given, or from the drive) and scales.
  /// Compared within `harmonics` harmonics (0: every sample); with
  /// `reed_frequency_Hz` > 0 (DiagnoseOptions::harmonics_auto, loaded runs)
  /// within at most those below half of it, and at least one.
  RunCase make_run_case(MeasuredRun run, system::Scenario scenario, double frequency_Hz,
                        double training_fraction, bool repair_outliers = true, double harmonics = 0,
                        double reed_frequency_Hz = 0);

  /// Each record in `paths` read (measured frequency_Hz, 0: from the data)
  /// and prepared by make_run_case with the options' training fraction,
  /// outlier repair and harmonics; `notice` gets one line for each column
  /// ignored, spike replaced, or contradiction with the scenario (an
  /// actuator that moves in a no-flow run).
  std::vector<RunCase> read_run_cases(const std::vector<std::string> &paths, system::Scenario scenario,
                                      double frequency_Hz, const DiagnoseOptions &options, double reed_frequency_Hz,
                                      const std::function<void(const std::string &)> &notice);

  /// The reed frequency make_run_case limits the band with: the outlet
  /// reed's natural frequency for a loaded run with options.harmonics_auto,
  /// else 0 (no limit).
  double band_reed_frequency_Hz(const system::SystemParameters &p, system::Scenario scenario,
                                const DiagnoseOptions &options);

  /// The reed's second bending mode in the baseline a diagnosis starts from.
  struct BaselineSecondMode
  {
    double      frequency_Hz = 0; ///< 0: none (one mode)
    std::string reason;           ///< where the value comes from, in words
    /// "4261 Hz, <reason>", or the reason alone when there is none.
    std::string text() const
    {
      return frequency_Hz > 0 ? format_number(std::round(frequency_Hz)) + " Hz, " + reason : reason;
    }
  };

  /// `choice` (diagnose --reed-second-mode): "case" keeps the case's value;
  /// a number [Hz] sets it (above the first mode, InputError otherwise);
  /// "auto" keeps the case's where it gives one and otherwise, in a loaded
  /// run, gives the reed a uniform cantilever's second mode at
  /// (4.694 / 1.875)^2 = 6.267 x its first: off its seat for most of every
  /// cycle, a real reed's second mode shows in a loaded record and, absent
  /// from the baseline, is named as if it were missing physics. In a no-flow
  /// run (valves shut most of the time) auto keeps the case's.
  BaselineSecondMode baseline_second_mode(const system::SystemParameters &p, system::Scenario scenario,
                                          const std::string &choice);

  /// Harmonics compared for a run at `frequency_Hz` (make_run_case): at most
  /// `harmonics`, and with reed_frequency_Hz > 0 at most those at or below
  /// half of it, at least one.
  double compared_harmonics(double harmonics, double frequency_Hz, double reed_frequency_Hz);


  /// Sets each run's start state (options.start; "auto": the best of the
  /// four over the record's first two cycles with the model `base`) and
  /// its settling window.
  void choose_start(const system::SystemParameters &base, const system::ValveMaps &map,
                    std::vector<RunCase> &runs, const DiagnoseOptions &options, unsigned threads = 1);

  /// The first of `per_cycle`'s cycles from which every later value is at
  /// most `tolerance`, kept within [min_cycles, max_cycles] (max_cycles if
  /// the last is above it).
  std::size_t settled_from(const std::vector<double> &per_cycle, double tolerance, std::size_t min_cycles,
                           std::size_t max_cycles);

  /// Whether the model's runs from two starts, `per_cycle` apart (noise
  /// units, RMS per training cycle), meet: within `tolerance` in the last
  /// cycle, or closer there than half their largest difference (they meet
  /// later: a slow mode). Otherwise they are taken to be on two orbits.
  bool runs_meet(const std::vector<double> &per_cycle, double tolerance);

  /// Sets the settling window of each run that does not start at rest
  /// (options.settling_cycles < 0) from the model's memory of its start:
  /// `base` run from the run's start and from another (its periodic orbit;
  /// a periodic start: the recorded state) over the training part; the
  /// window ends where the two agree within options.settling_tolerance
  /// noise units in every later cycle (the runs' scales), at least one
  /// cycle and at most half the training part (the most also where they
  /// have not met by the end but have come half-way together: runs_meet).
  /// Runs that stay further apart (two orbits) leave one cycle. An
  /// estimated start state is wrong in what the record does not show; its
  /// error fades as fast as the model forgets where it started.
  void settle(const system::SystemParameters &base, const system::ValveMaps &map, std::vector<RunCase> &runs,
              const DiagnoseOptions &options, unsigned threads = 1);

  /// Sets each run's residual scales (noise) with the model `base`, the
  /// runs simulated `threads` at once.
  void calibrate_noise(const system::SystemParameters &base, const system::ValveMaps &map,
                       std::vector<RunCase> &runs, double relative_tolerance, unsigned threads = 1);
} // namespace rectify::diagnosis
