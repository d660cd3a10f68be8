// The diagnosis workflow (issue 4): simulate each measured run, localise the
// disagreement, fit every candidate effect of the library (and "none") with a
// bounded optimiser, score them, name the effect that earns its parameters,
// and re-simulate with it.
//
// Fit: nonlinear least squares on the normalised residuals of every measured
// signal over the first `training_fraction` of each run, by NLopt's BOBYQA
// (bounded, derivative-free: each residual needs a whole simulation) started
// from the best of a coarse grid. Parameters move in [0, 1] over their
// bounds (log-scaled where the bounds span decades). Nuisance parameter, fitted
// with every candidate including "none": the drive's force gain (the rod's
// piezomagnetic coefficient times [0.9, 1.1]), the least certain constant
// between the measured drive and the model.
//
// Residual scale: each signal's expected noise, sd^2 = (white noise on the
// measured signal, from its second differences)^2 + (the model's response to
// the drive's own measurement noise)^2, the latter by simulating the model
// three more times with that much extra noise on the drive (the median of
// the three; the drive is cleaned of its noise before it drives the model,
// observation.h, and so is each shaken copy). The drive's noise
// matters: the outlet valve opens by a small difference of two large
// pressures in a no-flow run, so 0.3 % on the drive moves its opening by a
// tenth of its swing. Residuals in these units are about 1 for a model that
// explains the data to within its noise.
//
// Scores: BIC = n ln(SSR/n) + k ln n and AIC = n ln(SSR/n) + 2k on the
// training samples (k counts the nuisance too); held-out RMS over the last
// part of every run, which the fit never saw. An effect is named when its BIC
// beats "none" by more than `bic_threshold` (strong evidence on Kass and
// Raftery's scale), its held-out residual is lower than none's, and its fit
// explains the residual's dominant feature (the signal and cycle half where
// the residual is largest shrink by half); else "none".
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "diagnosis/effect.h"
#include "diagnosis/measured_run.h"
#include "diagnosis/observation.h"
#include "diagnosis/residuals.h"
#include "maps/resistance_map.h"
#include "system/parameters.h"

namespace rectify::diagnosis
{
  struct DiagnoseOptions
  {
    double              training_fraction  = 0.75;
    /// CVODE's: its error (1e-4 of a signal's swing) stays far below 1 % noise,
    /// and each fit runs the model some twenty times per candidate.
    double              relative_tolerance = 1e-5;
    double              bic_threshold      = 10.0;
    int                 grid_points        = 9;  ///< coarse start grid per effect parameter
    int                 max_evaluations    = 40; ///< BOBYQA's, per candidate
    double              gain_range         = 0.1; ///< nuisance force gain in 1 +- this
    int                 refine_passes      = 3;  ///< at most, after naming (see diagnose.cpp)
    std::vector<std::string> effects;              ///< candidates; empty: the whole library
    unsigned            threads = 0;               ///< 0: all cores
    int                 rounds  = 1;               ///< 2: look for a second effect
    std::function<void(const std::string &)> progress; ///< one line per finished candidate
  };

  /// One run with its setup and normalisation.
  struct RunCase
  {
    MeasuredRun                   run;
    RunSetup                      setup;
    std::map<std::string, double> scales; ///< residual scale per signal (noise, see above)
    std::map<std::string, double> swings; ///< RMS about the mean per signal (for words)
    double                        drive_noise_sd = 0; ///< estimated from the drive
    std::size_t                   n_train = 0; ///< samples the fit sees
  };

  struct CandidateResult
  {
    std::string         effect;            ///< "none" or an effect's name
    std::string         not_testable;      ///< why it was skipped (then no fit)
    std::vector<double> values;            ///< fitted effect parameters
    double              force_gain = 1.0;  ///< fitted nuisance
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
  };

  struct RoundResult
  {
    std::string                  effect = "none"; ///< named effect or "none"
    std::vector<double>          values;
    double                       force_gain = 1.0;
    double                       confidence = 0; ///< BIC weight of the named candidate
    std::string                  decision;       ///< the reasoning in words
    std::vector<CandidateResult> candidates;
    bool                         signature_explained = false;
    std::string                  signature_detail;
    int                          refine_passes = 0; ///< refits with rescaled residuals
  };

  struct DiagnosisResult
  {
    std::vector<RoundResult> rounds;
    system::SystemParameters final_parameters;   ///< base + named effects + gain
    std::vector<Signals>     before, after;      ///< per run, whole records
    std::map<std::string, double> residual_before, residual_after; ///< per signal + overall, noise units
    std::map<std::string, double> swing_before, swing_after; ///< the same as fractions of each swing
    std::vector<RunCase>      runs;                ///< the runs with their calibrated scales
    std::vector<Localisation> localisation;       ///< per run, before
    std::vector<std::string>  trend_sentences;
    double                    wall_time_s = 0;
  };

  /// Prepares a run: its frequency (given, or from the drive) and scales.
  RunCase make_run_case(MeasuredRun run, system::Scenario scenario, double frequency_Hz,
                        double training_fraction);

  /// Sets each run's residual scales (noise) with the model `base`, the
  /// runs simulated `threads` at once.
  void calibrate_noise(const system::SystemParameters &base, const system::ValveMaps &map,
                       std::vector<RunCase> &runs, double relative_tolerance, unsigned threads = 1);

  /// Calibrates the runs' noise (calibrate_noise) and runs the workflow.
  DiagnosisResult diagnose(const system::SystemParameters &base, const system::ValveMaps &map,
                           std::vector<RunCase> runs, const DiagnoseOptions &options);

  /// summary.json's content.
  nlohmann::json to_json(const DiagnosisResult &result, const std::vector<RunCase> &runs);
} // namespace rectify::diagnosis
