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

#include <array>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "diagnosis/effect.h"
#include "diagnosis/options.h"
#include "diagnosis/results.h"
#include "diagnosis/runs.h"
#include "maps/resistance_map.h"
#include "system/parameters.h"

namespace rectify::diagnosis
{
  /// Calibrates the runs' noise (calibrate_noise) and runs the workflow.
  /// One that fails leaves its checkpoint folder as it found it where no
  /// fit was kept (DiagnoseOptions::checkpoint_dir_made).
  DiagnosisResult diagnose(const system::SystemParameters &base, const system::ValveMaps &map,
                           std::vector<RunCase> runs, const DiagnoseOptions &options);

  /// summary.json's content.
  nlohmann::json to_json(const DiagnosisResult &result, const std::vector<RunCase> &runs);
} // namespace rectify::diagnosis
