// The diagnosis's results as data (what each stage gives, diagnose.h): the
// baseline's parameters, each candidate's fit and scores, a round's naming
// and refinement, the named parameters' uncertainty, the verdict. Words are
// written from these by the report (words.h, report.h, summary_json.cpp).
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "diagnosis/naming.h"
#include "diagnosis/observation.h"
#include "diagnosis/residuals.h"
#include "diagnosis/runs.h"
#include "diagnosis/verdict.h"
#include "system/parameters.h"

namespace rectify::diagnosis
{
  /// A baseline parameter at the baseline fit ("none" with every uncertain
  /// parameter and the force gain) and whether the data determine it.
  /// A left-out parameter tried on with the named effect (calibrate_left_out):
  /// not tried (the named fit's training RMS, noise units, leaves no gap
  /// above the noise), turned on (the best of `starts` fits, from
  /// `best_from`, beat the fit without it), no better, or every fit failed.
  struct LeftOutTry
  {
    enum class Outcome
    {
      not_tried,
      on,
      no_better,
      failed
    };
    Outcome outcome = Outcome::not_tried;
    int     starts  = 0;
    double  rms_train = 0, best_from = 0, bic_with = 0, bic_without = 0;
  };

  struct BaselineParameter
  {
    std::string name;          ///< "table.key", or "force_gain"
    double      value = 0, nominal = 0, lower = 0, upper = 0;
    double      sd_unit = 0;   ///< standard error as a share of its (log) range
    bool        identifiable = true;
    /// Its strongest correlation with another parameter at the check that
    /// judged it, where above 0.9 in size (else 0)
    double      correlation = 0;
    std::string correlated_with;
    /// Held by that check: its standard error (sd_unit) too large, or a
    /// partner it cannot be told apart from
    bool        held_undetermined = false;
    /// Where a fit leaves it on an end of its declared range: -1 the lower,
    /// +1 the upper, 0 neither (or the value is not a fit's)
    int         at_end = 0;
    /// Before an effect is named: left out (off in the case, tried on with
    /// the named effect), or why it does nothing in the case's model
    bool        left_out = false;
    std::string inert;
    /// What trying it on with the named effect did
    std::optional<LeftOutTry> tried;
    /// freed at a named fit as the effect's own shape (it does nothing in
    /// the case's model: the friction's with piston_friction), not as a
    /// baseline parameter the effect's fit determines
    bool effect_shape = false;
  };

  /// A candidate's searches not restarted: its first searches closed
  /// `closed` of the gap above the noise that none leaves, `reachable` if
  /// two more gained as much; `restart_needed` would have restarted them,
  /// `name_needed` names it (shares of that gap).
  struct SearchStop
  {
    double closed = 0, reachable = 0, restart_needed = 0, name_needed = 0;
  };

  /// What a ringing start did with one frequency of the residual's
  /// spectrum, its values over the residual with the effect off (the weak
  /// end's): the grid's best over 3 cycles (-1: no value in range rings
  /// there); where the pair grids were not run, the bases' and lines' best
  /// (else 0) and the reach they needed; the best after the valley search
  /// and scans over 6 cycles (-1: not refined) and whether that is a start.
  struct RingingTry
  {
    double f = 0, grid = -1, lines = 0, lines_needed = 0, six = -1;
    bool   start = false;
  };
  struct RingingLog
  {
    bool                    no_peak = false; ///< no peak in the residual's spectrum where it can ring
    std::vector<RingingTry> tries;
  };

  struct CandidateResult
  {
    std::string         effect;            ///< "none" or an effect's name
    std::string         not_testable;      ///< why it was skipped (then no fit)
    std::vector<double> values;            ///< fitted effect parameters
    double              force_gain = 1.0;  ///< fitted nuisance
    std::map<std::string, double> baseline; ///< every [uncertain] parameter's value in this fit
    std::vector<double> u;                 ///< the fit as a point in [0, 1]^k
    int                 k          = 0;    ///< parameters fitted
    double              ssr_train  = 0;
    std::size_t         n_train    = 0;
    double              rms_train = 0, rms_heldout = 0;
    double              bic = 0, aic = 0;
    int                 evaluations = 0;
    double              wall_time_s = 0;
    bool                failed = false;    ///< every start failed to simulate
    std::string         message;
    /// Where its searches were not restarted (too far from closing the gap
    /// to be named; fit.cpp), by how far.
    std::optional<SearchStop> not_restarted;
    /// What its ringing start (an effect whose parameter sets a ringing:
    /// the outlet line) did with each frequency; none where it has none.
    std::optional<RingingLog> ringing;
    int                 ringing_runs   = 0; ///< of `evaluations`: the ringing start's (short) runs
    double              ringing_time_s = 0; ///< of `wall_time_s`: the ringing start's
  };

  /// A named effect's parameter at its final fit and how well the record
  /// determines it: the fit's covariance (J^T J / s2, s2 = SSR over the
  /// band's independent values) with a uniform prior over each parameter's
  /// range (diagnosis/uncertainty.h).
  struct ParameterUncertainty
  {
    std::string key;
    double      value = 0;
    /// Standard error of ln(value) for a log-scaled parameter (about the
    /// relative error while small), of value over |value| otherwise, from
    /// its profile (below): the step over the square root of the evidence
    /// against it, the larger side; infinite where a side fits as well.
    double      relative_sd = 0;
    /// One standard error either side, within the bounds; NaN where that
    /// side of the profile fits as well (more than its step).
    double      lower = 0, upper = 0;
    /// The same from the fit's covariance (local): the baseline's
    /// [uncertain] parameters and the force gain unknown within their
    /// ranges, and known (at the fit).
    double      local_relative_sd = 0, local_relative_sd_given_baseline = 0;
    std::string correlated_with;                ///< the parameter it trades with most
    double      correlation = 0;
    /// Its profile: the parameter moved by determined_relative_sd down and up
    /// (a factor exp(-+sd) when log-scaled) and held while the baseline's
    /// [uncertain] parameters and the gain are refitted; each side's
    /// training residual (noise units) and evidence against it, n_eff
    /// ln(SSR ratio) (NaN: at a bound, not tried, or failed).
    std::array<double, 2> profile_value{}, profile_rms{}, profile_evidence{};
    double      rms_at_fit = 0;                 ///< the fit's own training residual, the same units
    bool        profile_determined = true;      ///< every side tried: evidence > DiagnoseOptions::bic_threshold
    std::array<bool, 2> profile_tried{};        ///< each side moved and refitted
    /// The profile's step (DiagnoseOptions::determined_relative_sd) and the
    /// evidence a side needs against it (DiagnoseOptions::bic_threshold).
    double      profile_step = 0, evidence_needed = 0;
    /// profile_determined (where no side could be tried: local_relative_sd
    /// <= DiagnoseOptions::determined_relative_sd)
    bool        determined = true;
  };

  /// The named effect's combined quantity (Effect::Combination) at its fit.
  struct CombinedEstimate
  {
    std::string name, meaning;
    double      value = 0;
    double      relative_sd = 0; ///< standard error over the value (delta method)
    bool        determined = true;
  };

  struct RoundResult
  {
    std::optional<std::string>   effect; ///< the named effect (none: no candidate was named)
    std::vector<double>          values;
    double                       force_gain = 1.0;
    std::map<std::string, double> baseline;       ///< [uncertain] values of the chosen fit
    std::vector<BaselineParameter> baseline_check; ///< the baseline fit and identifiability
    /// held at the baseline fit, determined at the named effect's fit: freed for its refits
    std::vector<BaselineParameter> freed;
    /// [uncertain] parameters the case leaves out (0), tried on again at
    /// the named effect's settled fit: on (fitted value) or off (0)
    std::vector<BaselineParameter> left_out;
    /// Where nothing was named at first and more than the noise floor
    /// remained: the candidate that came nearest, judged again after the
    /// parameters the case leaves out were tried on at none's fit and at
    /// its own (empty effect: not tried).
    struct NearMiss
    {
      std::string                    effect;
      /// without them, its scores and none's: the share of the gap it
      /// closed (judgement.closed) and the rule it failed (judgement.failed)
      Judgement                      judgement;
      FitScores                      candidate, baseline;
      /// none's and its fits without them (the candidates' table holds the
      /// fits with them where it was named)
      double none_bic = 0, none_rms_train = 0, effect_bic = 0, effect_rms_train = 0;
      std::vector<BaselineParameter> at_none, at_effect; ///< what each try did with them
      bool                           named = false;
    } near_miss;
    /// The candidate that passed every rule but sets a parameter the case
    /// leaves out (a hose: the outlet passage's key), judged again against
    /// none with that parameter tried on (empty effect: none did)
    struct SetByEffect
    {
      std::string                    effect;
      std::vector<BaselineParameter> at_none; ///< what none's try did with it
      bool                           named = false;
      /// why not, where not: judged against none with it tried on
      Judgement                      judgement;
      FitScores                      candidate, baseline;
      double none_bic = 0, none_rms_train = 0; ///< none's fit without it (the table's none is with it where on)
    } set_by_effect;
    /// none refitted from the best candidate's baseline before any was
    /// judged (empty effect: no candidate beat none by the BIC threshold)
    struct NoneRestart
    {
      std::string effect;                ///< whose baseline it started from
      double      bic_before = 0, bic_after = 0, rms_train_before = 0, rms_train_after = 0;
      bool        kept = false;          ///< it fitted better and stood as none's fit
    } none_restart;
    double                       confidence = 0; ///< BIC weight of the named candidate
    NamingRules                  rules;          ///< the rules it was judged by
    /// One step of the round's judging, in order (words.h: the decision in words).
    struct JudgingStep
    {
      enum class Kind
      {
        none_refitted,          ///< none refitted from the best candidate's baseline, kept (none_restart)
        judged,                 ///< a candidate judged against none: judgement, candidate, baseline
        set_by_effect_rejected, ///< it passed, but not against none with what it sets tried on (set_by_effect)
        nearest_miss_tried,     ///< the left-out parameters tried at none's and the nearest miss's fits (near_miss)
        fits_without_stand      ///< the nearest miss not named with them either: the fits without them stand
      };
      Kind      kind = Kind::judged;
      Judgement judgement;
      FitScores candidate, baseline;
      bool      changed = false; ///< nearest_miss_tried: one of them turned on
    };
    std::vector<JudgingStep>     judging;
    /// The named candidate against none and the next best by BIC (none: "-")
    struct Named
    {
      double      delta_bic = 0, rms_heldout = 0, none_rms_heldout = 0;
      std::string next = "-";
      double      next_delta_bic = 0;
    } named;
    std::vector<CandidateResult> candidates;
    bool                         signature_explained = false;
    FeatureScores                feature; ///< the dominant residual feature, where signature_explained
    int                          refine_passes = 0; ///< refits with rescaled residuals
    std::vector<ParameterUncertainty> uncertainty;  ///< per effect parameter, at the final fit
    std::optional<CombinedEstimate>   combined;     ///< when the effect declares a combination
    /// Why the standard errors could not be computed ("" where they were;
    /// words.h: uncertainty_words, the parameters' part in words).
    std::string                       uncertainty_error;
    int                               uncertainty_runs = 0; ///< runs of the model they took
    /// Where the fit moved to a better side of its profile: each move's
    /// value, training residual (noise units) and evidence (negative: better)
    nlohmann::json                    profile_moves = nlohmann::json::array();
    /// A parameter the record does not determine whose combination it does:
    /// the baseline parameter it trades with held at the case's value
    /// (parameter, case_value, split, held_value, evidence, kept,
    /// effect_over_its_range, range); null where not tried.
    nlohmann::json                    held_partner = nullptr;
  };

  /// A quantity an effect shares with the baseline (Effect::Combination:
  /// the seal and the oil column add up to the high side's compliance)
  /// that the calibrated baseline raised beyond what the case holds: the
  /// effect adding `fitted - case_value` to the case's baseline would
  /// give the same, so the record cannot tell the two apart.
  struct AbsorbedEffect
  {
    std::string effect, quantity, meaning;
    double      case_value = 0, fitted = 0;
    /// The [uncertain] parameters that set the baseline's part of the
    /// quantity, as fitted: measured on the rig and declared, they leave
    /// the rest to the effect.
    std::vector<std::pair<std::string, double>> set_by;
  };

  /// A signal's sensor lag as a diagnosis fitted it (sensors.h).
  struct SensorLag
  {
    std::string signal;
    double      lowest_Hz    = 0;                                        ///< the case's bound
    double      fitted_Hz    = std::numeric_limits<double>::infinity(); ///< the training fit's; inf: ideal
    bool        kept         = true; ///< false: the held-out samples fit worse with the fitted lag
    /// the signal's training RMS residual (noise units, every run) with an
    /// ideal sensor and with the fitted lag (fitted_Hz)
    double residual_ideal = 0, residual_lagged = 0;
    /// the same over the held-out samples, which the lag's fit did not see (0: none)
    double heldout_ideal = 0, heldout_lagged = 0;

    /// The bandwidth applied: fitted_Hz where kept (the held-out samples
    /// fit at least as well with it as with an ideal sensor, or there are
    /// none), else ideal (inf).
    double applied_Hz() const { return kept ? fitted_Hz : std::numeric_limits<double>::infinity(); }
    /// The fit stopped at the lowest bandwidth allowed.
    bool at_lowest() const { return fitted_Hz <= lowest_Hz / (1 - 1e-3); }
  };

  /// A run's level: its pumping frequency, its drive's peak-to-peak and the
  /// case's overall residual on it (as a fraction of the swing) - the trends
  /// over the runs (words.h).
  struct RunLevel
  {
    double frequency_Hz = 0, drive_pp = 0, residual = 0;
  };

  struct DiagnosisResult
  {
    std::vector<RoundResult> rounds;
    /// The candidate fits taken from DiagnoseOptions::checkpoint_dir, not
    /// fitted again ("round 1: valve_leakage")
    std::vector<std::string> resumed;
    system::SystemParameters final_parameters;   ///< base + named effects + gain
    std::vector<Signals>     before, after;      ///< per run, whole records
    std::map<std::string, double> residual_before, residual_after; ///< per signal + overall, noise units
    std::map<std::string, double> swing_before, swing_after; ///< the same as fractions of each swing
    std::vector<RunCase>      runs;                ///< the runs with their calibrated scales
    std::vector<Localisation> localisation;       ///< per run, before
    std::vector<RunLevel>     run_levels;         ///< per run, the case's model as given
    /// The honest verdict: "explained" (the named effect leaves at most
    /// beyond_library_noise_units), "partly explained" (it leaves more: model
    /// error beyond the library), "no missing effect" (the baseline fit
    /// leaves at most that), "beyond the library" (no effect helps and the
    /// residual stays above it).
    Verdict                   verdict = Verdict::no_missing_effect;
    double                    floor_units = 0;        ///< DiagnoseOptions::beyond_library_noise_units, as judged
    double                    explained_fraction = 0; ///< of the gap above the noise left by the baseline fit
    /// Per run, what the final model leaves in each signal, in noise units
    /// from the run's settling on, the most first (residuals_in_noise_units);
    /// the largest of them is the verdict's "where".
    std::vector<std::vector<SignalResidual>> remaining;
    /// The same for the case's model as given (`before`), in the same
    /// units, window and order: the report's "before".
    std::vector<std::vector<SignalResidual>> remaining_before;
    /// Each signal's sensor lag, fitted to the final model and applied to
    /// `after` (calibrate_sensor_lags, sensors.h); empty: ideal sensors
    /// (DiagnoseOptions::sensor_lowest_bandwidth_Hz empty).
    std::vector<SensorLag>    sensor_lags;
    /// residual_after with ideal sensors (equal where none is fitted)
    std::map<std::string, double> residual_after_ideal;
    double                    residual_baseline  = 0; ///< overall, the baseline fit (none), noise units
    /// sqrt(n / independent values of the compared band): how much larger a
    /// baseline parameter's standard error (samples counted as independent,
    /// BaselineParameter::sd_unit) is when counted per independent value.
    double                    baseline_sd_factor = 1;
    /// The candidates' fits and scores saw the first this many training
    /// cycles of each run after its settling (screening_cycles_per_run);
    /// 0: every training cycle.
    double                    compared_cycles_per_run = 0;
    /// Where nothing is named: the quantities the calibrated baseline
    /// shares with a candidate and moved as the candidate would (see
    /// absorbed_by_baseline); the verdict says so.
    std::vector<AbsorbedEffect> absorbed_by_baseline;
    double                    wall_time_s = 0;
    /// Of the runs of the model: those a search took from an idle core,
    /// where they had been evaluated ahead (the first points of a search
    /// that runs alone); their values are the ones it would have made.
    int                       runs_evaluated_ahead = 0;
  };
} // namespace rectify::diagnosis
