// Fitting a candidate (a stage of diagnose()): one effect of the library,
// or none, with the baseline's free [uncertain] parameters and the force
// gain, by least squares on the runs' normalised training residuals.
//
// Takes: the candidate's evaluator (search.h).
// Gives: CandidateResult (its parameters, scores, runs of the model) and its
// predictions of every run; the residuals' pooled norms the verdict reads.
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "diagnosis/search.h"

namespace rectify::diagnosis
{
  /// The part of a residual above the noise, from its mean square in noise
  /// units (an RMS r gives r * r): what an effect must close.
  inline double gap_above_noise(double mean_square) { return std::sqrt(std::max(mean_square - 1.0, 0.0)); }

  /// A candidate's searches are restarted only where their first runs
  /// closed at least this share of DiagnoseOptions::min_gap_closed (fit()).
  inline constexpr double restart_closure = 0.4;

  /// Fits ev's candidate: from a coarse grid over the effect's first
  /// parameter (gain 1; a ringing start where the parameter sets one), or,
  /// when `from_point` is given (a point in [0, 1]^k), locally from there
  /// with first steps of `first_step` (of each position's [0, 1] range).
  CandidateResult fit(const Evaluator &ev, std::vector<Signals> &predictions,
                      const std::vector<double> *from_point = nullptr, double first_step = 0.02,
                      int max_attempts = 3);

  /// The run and signal where a model leaves the most noise units, from
  /// each run's list (residuals_in_noise_units, the most first); nullptr
  /// where no run has a signal.
  std::pair<std::size_t, const SignalResidual *>
  most_remaining(const std::vector<std::vector<SignalResidual>> &remaining);

  /// Each signal's residual norm pooled over the runs (and "overall"): in
  /// noise units, or with `swings` as fractions of each signal's swing.
  std::map<std::string, double> pooled_norms(const std::vector<RunCase> &runs,
                                             const std::vector<Signals> &model, bool swings);
} // namespace rectify::diagnosis
