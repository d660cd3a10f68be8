// The verdict (the last stage of diagnose()): how much of the gap above the
// noise that the calibrated baseline leaves the named effect closes, and
// whether what is left is within the noise.
//
// Takes: whether an effect was named, the overall residuals (noise units)
// of the baseline fit and of the final model, the floor
// (DiagnoseOptions::beyond_library_noise_units).
// Gives: the Verdict and the share of the gap explained, pure functions of
// those; the quantities a baseline took up that a candidate shares with it
// (absorbed_by_baseline). Its words: words.h.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "diagnosis/effect.h"
#include "system/parameters.h"

namespace rectify::diagnosis
{
  struct AbsorbedEffect;

  enum class Verdict
  {
    explained,         ///< an effect named, at most the floor left
    partly_explained,  ///< an effect named, more than the floor left: model error beyond the library
    no_missing_effect, ///< nothing named, the baseline fit leaves at most the floor
    beyond_library     ///< nothing named, more than the floor left
  };

  /// "explained", "partly explained", "no missing effect", "beyond the library"
  std::string to_string(Verdict v);

  Verdict verdict_of(bool effect_named, double residual_after, double floor_units);

  /// The share of the gap above the noise (sqrt(r^2 - 1)) that the baseline
  /// leaves which the final model closes, in [0, 1]; 0 where the baseline
  /// leaves none.
  double explained_fraction(double residual_baseline, double residual_after);

  /// The candidates in `library` whose combined quantity is more than
  /// `factor` times higher with the calibrated baseline `fitted` than with
  /// the case's `case_parameters` (the effects add to it: a seal cannot
  /// take compliance away). Test Diagnosis.ABaselineThatTakesUpASealIsReported.
  std::vector<AbsorbedEffect> absorbed_by_baseline(const std::vector<std::shared_ptr<const Effect>> &library,
                                                   const system::SystemParameters &case_parameters,
                                                   const system::SystemParameters &fitted, double factor);
} // namespace rectify::diagnosis
