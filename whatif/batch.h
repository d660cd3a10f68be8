// `rectify whatif`: many valve designs, each its map set and the system's
// answer, as one batch of jobs on MPI (docs/whatif.md).
//
// Jobs: per map set (designs with equal map-set provenance share one) the
// reed's stiffness solve, then one job per tip opening's Stokes solve (the
// adaptive openings of stokes::plan_resistance_sweep, a round at a time),
// then its assembly (design::write_map_set); per design the loaded velocity
// sweep and the no-flow stored-pressure sweep on its map set. One dynamic
// queue: a scheduler thread on rank 0 hands the next ready job to whichever
// group of --procs-per-job ranks asks (rank 0's own group included), so a
// slow job does not hold the others. Every job's result is a file written
// atomically; the queue is rebuilt from those files when a batch starts, so
// a batch killed at any moment and started again with the same command
// finishes with the files an uninterrupted one writes, and no finished job
// runs again (jobs.log records every start and finish).
//
// Files: OUT/batch.json (the batch's definition; a restart must match it),
// OUT/designs/NAME/{case.toml, velocity/, pressure/, map-set -> CACHE/HASH},
// OUT/work/HASH/ (map sets in the making), OUT/failures/*.json,
// OUT/whatif.{csv,json}, plots; finished map sets in CACHE/HASH, keyed by
// their provenance hash: a design computed before, by this batch or another
// with the same cache, is reused, never recomputed.
#pragma once

#include <filesystem>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/case_file.h"
#include "stokes_solver/resistance_sweep.h"
#include "system/sweep.h"
#include "stokes_solver/stokes.h"
#include "whatif/designs.h"

namespace rectify::whatif
{
  struct FrequencyRange
  {
    double      from_Hz = 0, to_Hz = 0;
    std::size_t n           = 0;
    bool        log_spacing = false;
    nlohmann::json to_json() const;
  };
  /// "FROM:TO:N" or "FROM:TO:N:log"; InputError naming `option` if malformed.
  FrequencyRange parse_frequency_range(const std::string &spec, const std::string &option, bool default_log);

  struct BatchSettings
  {
    std::filesystem::path case_path;
    std::string           case_text; ///< the base case
    std::vector<Design>   designs;
    std::filesystem::path out_dir, cache_dir;
    /// The loaded velocity sweep (thesis Fig. 5.4) at the case's drive.
    FrequencyRange velocity{10, 3500, 100, false};
    /// The no-flow stored-pressure sweep (thesis Fig. 5.3) at 4 A p-p, 2 A bias.
    FrequencyRange pressure{1, 1200, 40, true};
    double         pressure_current_pp_A = 4, pressure_current_bias_A = 2;
    std::size_t    cycles        = 50; ///< measured cycles per sweep point, after settling
    /// "auto": each map set solves the reed's fluid loading ([flow]
    /// reed_loading) only if its design's system model reads it ([reed]
    /// fluid_loading = "map"); "case": as the case says.
    std::string    reed_loading  = "auto";
    unsigned       procs_per_job = 1;
    /// What a restart must match (not the process counts or the cache).
    nlohmann::json definition() const;
  };

  /// One design as a case, read and checked before any job runs.
  struct DesignCase
  {
    Design                design;
    CaseFile              file;
    std::string           case_text;
    std::string           map_set_hash; ///< map_set_hash(file)
    stokes::SweepSettings openings;     ///< its [design] settings
  };

  /// The provenance hash of a case's map set: the case tables and settings
  /// the map set depends on (design::map_set_provenance), the openings'
  /// settings ([design]) and the code's version.
  std::string map_set_hash(const CaseFile &file);

  /// Each design's case; `check` reads it as every stage does (throws
  /// InputError naming the design, key and value). Also refuses a case
  /// whose drive is not the sine (a sweep needs it).
  std::vector<DesignCase> read_design_cases(const BatchSettings &settings,
                                            const std::function<void(const CaseFile &)> &check);

  /// $RECTIFY_CACHE, else $XDG_CACHE_HOME/rectify/map-sets, else ~/.cache/rectify/map-sets.
  std::filesystem::path default_cache_dir();

  /// The system's answers to a velocity sweep (ascending frequencies).
  struct VelocityAnswer
  {
    /// The first frequency where the mean velocity turns from positive to
    /// not positive, linear between the two points around it; NaN if it
    /// never does in the range.
    double first_reversal_Hz = 0;
    /// The largest mean velocity below the first reversal (the usable band;
    /// the whole sweep if it never reverses), and its frequency.
    double peak_velocity_m_per_s = 0, peak_frequency_Hz = 0;
    /// The largest anywhere in the sweep (a band above a reversal can be higher).
    double highest_velocity_m_per_s = 0, highest_frequency_Hz = 0;
  };
  VelocityAnswer velocity_answer(const std::vector<double> &frequencies_Hz, const std::vector<double> &velocities);

  /// The no-flow sweep's answer: the stored pressure at the lowest
  /// frequency, and the first frequency where it has fallen to half of that
  /// (linear in log f between the two points around it; NaN if never).
  struct PressureAnswer
  {
    double low_frequency_pressure_Pa = 0, half_pressure_frequency_Hz = 0;
  };
  PressureAnswer pressure_answer(const std::vector<double> &frequencies_Hz, const std::vector<double> &pressures);

  /// What a design's sweep says once each run's validity is read
  /// (system/validity.h): its valid runs' frequencies and values (the
  /// answers above are taken from these), and what the runs reached.
  struct SweepVerdict
  {
    std::vector<double> valid_frequencies_Hz, valid_values; ///< ascending
    std::vector<double> frequencies_Hz, values;             ///< every finished run's
    std::size_t         points = 0, valid_points = 0, failed_points = 0;
    double worst_goodman_factor        = std::numeric_limits<double>::infinity(); ///< over the finished runs
    double max_impact_velocity_m_per_s = 0; ///< at seat or stop, over the finished runs
    /// The highest frequency up to which every finished run's Goodman
    /// factor is at least 1 (the reed survives), and up to which every run
    /// is valid; NaN if not even the lowest's is.
    double survives_to_Hz = std::numeric_limits<double>::quiet_NaN();
    double valid_to_Hz    = std::numeric_limits<double>::quiet_NaN();
  };
  /// `points`: one series of a sweep, ascending in frequency; `velocity`:
  /// its metric is the mean velocity (else the stored pressure).
  SweepVerdict sweep_verdict(const std::vector<system::SweepPoint> &points, bool velocity);

  struct BatchReport
  {
    std::size_t n_designs = 0, n_failed = 0;
    std::size_t n_jobs_run = 0, n_jobs_failed = 0;
    std::size_t n_map_sets = 0, n_map_sets_cached = 0; ///< cached: found finished when the batch started
    double      wall_time_s = 0;
  };

  /// Runs the batch; every process of `world` calls it together (a
  /// session at MPI_THREAD_MULTIPLE). The report on rank 0.
  BatchReport run_batch(const BatchSettings &settings, const std::vector<DesignCase> &designs,
                        const stokes::MpiSession &world);
} // namespace rectify::whatif
