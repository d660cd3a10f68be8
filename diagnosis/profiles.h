// Uncertainty and profiles (a stage of diagnose()): how well the record
// determines the named effect's parameters at its final fit.
//
// Takes: the named effect's evaluator and fit (search.h).
// Gives: RoundResult's uncertainty (per parameter: local and profile
// standard errors, the parameter it trades with), its combined quantity
// where the effect declares one, and a side of a profile that fits better
// than the fit (BetterSide), where one does.
#pragma once

#include <optional>
#include <vector>

#include "diagnosis/search.h"

namespace rectify::diagnosis
{

  /// A side of a named effect's profile that fits clearly better than
  /// the fit it was taken from (effect_uncertainty): the fit stopped in
  /// one basin of a curved valley, and the profile's refit, started from
  /// the Jacobian's prediction and a scan of the partner parameter,
  /// reached a lower one.
  struct BetterSide
  {
    std::size_t         effect_index = 0; ///< which of the effect's parameters was moved
    double              effect_unit = 0; ///< its position there, in [0, 1]
    std::vector<double> w;               ///< every [uncertain] parameter's position there
    double              gain_unit = 0;   ///< the force gain's position
    double              value = 0, rms = 0, evidence = 0;
  };

  /// The named effect's parameters' uncertainty at (ev, u) into rr (the
  /// method at the definition, profiles.cpp); with `better`, a side of a
  /// profile that fits better than the fit by more than the naming's
  /// evidence.
  void effect_uncertainty(const Evaluator &ev, const std::vector<double> &u, unsigned threads, RoundResult &rr,
                          int &runs_of_the_model, std::optional<BetterSide> *better = nullptr);
} // namespace rectify::diagnosis
