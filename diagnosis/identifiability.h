// Identifiability and the parameters the case leaves out (stages of
// diagnose()): which baseline parameters a record determines, which are
// held, which a named effect frees, and the [uncertain] parameters the case
// leaves off (off_at_zero) tried on after a fit.
//
// Takes: a fit's evaluator and point (search.h, fit.h).
// Gives: one BaselineParameter per parameter judged (its value, standard
// error, why held); the evaluator's free set and held positions updated.
// The methods are described at each definition (identifiability.cpp).
#pragma once

#include <Eigen/Dense>

#include <string>
#include <utility>
#include <vector>

#include "diagnosis/search.h"

namespace rectify::diagnosis
{
  /// The residual vector's Jacobian at u0 (residual r0 there) by forward
  /// differences of 0.01 in the [0, 1] positions.
  Eigen::MatrixXd unit_jacobian(const Evaluator &ev, const std::vector<double> &u0, const std::vector<double> &r0,
                                int &runs_of_the_model, unsigned threads = 1);

  /// The same fit with every [uncertain] parameter free: the evaluator and
  /// the point.
  std::pair<Evaluator, std::vector<double>> with_every_uncertain(const Evaluator &ev, const std::vector<double> &u,
                                                                 bool effect_shape = false);

  /// An [uncertain] parameter as reported, at position `unit`.
  BaselineParameter baseline_parameter(const system::SystemParameters &base, const system::UncertainParameter &q,
                                       double unit, double sd_unit, bool identifiable, bool fitted = true);

  /// The baseline fit's parameters the data determine; the others held
  /// (ev updated).
  std::vector<BaselineParameter> check_identifiability(Evaluator &ev, const CandidateResult &none,
                                                       double limit, int &runs_of_the_model, unsigned threads);

  /// After an effect is named: the held parameters its fit determines,
  /// freed (ev and u updated); with `effect_shape`, the effect's own shape.
  std::vector<BaselineParameter> free_determined(Evaluator &ev, std::vector<double> &u, double limit,
                                                 int &runs_of_the_model, unsigned threads,
                                                 bool effect_shape = false);

  /// The training residual's sum of squares at x, or 1e300 where the model
  /// fails to integrate.
  double training_or_worst(const Evaluator &ev, const std::vector<double> &x);

  /// The parameters the case leaves out, tried on after the fit `fitted`
  /// (ev, fitted and predictions updated where one turns on).
  std::vector<BaselineParameter> calibrate_left_out(Evaluator &ev, CandidateResult &fitted,
                                                    std::vector<Signals> &predictions, unsigned threads);

  /// Freed parameters placed at the best of a scan over their ranges.
  void place_freed(const Evaluator &ev, const std::vector<BaselineParameter> &freed, std::vector<double> &u,
                   unsigned threads);
} // namespace rectify::diagnosis
