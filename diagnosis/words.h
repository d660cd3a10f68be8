// The diagnosis's words, the report's part (report.h, summary_json.cpp, the
// command's answer and its progress lines): the naming's reasons, the
// verdict's sentence and the trends over the runs, composed from the
// results (results.h), which hold numbers, enums and names only.
#pragma once

#include <string>
#include <vector>

#include "diagnosis/results.h"
#include "diagnosis/verdict.h"

namespace rectify::diagnosis
{
  /// Why the candidate was not named, in one sentence ending ". " (empty
  /// where it was).
  std::string describe(const Judgement &j, const FitScores &candidate, const FitScores &baseline,
                       const NamingRules &rules);

  /// A round's decision: the named effect against none and the next best,
  /// its dominant feature; or why nothing was named, step by step.
  std::string decision_words(const RoundResult &rr);
  /// The named effect's dominant residual feature before and after ("" where none was named).
  std::string signature_words(const RoundResult &rr);
  /// The nearest miss's rule without the left-out parameters; the effect
  /// that sets one of them, why it was not named against none with it on
  /// ("" where it was or none did).
  std::string near_miss_reason(const RoundResult &rr);
  std::string set_by_effect_reason(const RoundResult &rr);
  /// none refitted from the best candidate's baseline; the left-out
  /// parameters tried at none's and the nearest miss's fits.
  std::string none_restart_words(const RoundResult::NoneRestart &n);
  std::string nearest_miss_tried_words(const RoundResult::NearMiss &m);
  /// What a try of left-out parameters did with each.
  std::string left_out_words(const std::vector<BaselineParameter> &b);

  /// The verdict in words: `where` is the largest remaining residual's
  /// description.
  std::string verdict_sentence(Verdict v, const std::string &named_effect, double residual_baseline,
                               double residual_after, double floor_units, double explained, const std::string &where);

  /// A result's whole verdict in words: verdict_sentence with the first
  /// round's effect and where the most is left, the sensors' part, and
  /// what the calibrated baseline absorbed where nothing was named.
  std::string verdict_words(const DiagnosisResult &r);

  /// "; the calibrated baseline holds ... cannot tell the two apart" and how
  /// to tell them apart, for one absorbed quantity.
  std::string absorbed_sentence(const AbsorbedEffect &a);

  /// Sentences on trends over several runs: the case's residual against
  /// frequency and drive amplitude (none with fewer than two runs).
  std::vector<std::string> trends(const std::vector<RunLevel> &levels);
} // namespace rectify::diagnosis
