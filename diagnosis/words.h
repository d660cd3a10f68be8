// The diagnosis's words, the report's part (report.h, summary_json.cpp, the
// command's answer and its progress lines): every sentence a diagnosis
// writes -- the naming's reasons, the verdict, the trends over the runs, the
// named parameters' uncertainty, each baseline parameter's standing, the
// runs' settling and band, a search's and a ringing start's ways, the
// residuals signal by signal (residual_words.cpp) -- composed from the
// results (results.h, runs.h, residuals.h), which hold numbers, enums and
// names only.
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

  /// Why a baseline parameter stands where it does: held (and why), its
  /// strongest correlation, a left-out one's try, off, or on an end of its
  /// range ("" where none applies).
  std::string standing_words(const BaselineParameter &b);

  /// "rest with the case's baseline, record with valve_leakage's fit": how
  /// a run's start was chosen again with named effects ("" where never).
  std::string start_revision_words(const RunCase &rc);

  /// Why a run's settling window and its band are what they are ("" where
  /// not set).
  std::string settling_words(const RunCase &rc);
  std::string band_words(const RunCase &rc);

  /// A signal's residual in words, without its name ("residual 0.1 MPa RMS
  /// (4 % of its swing), 80 % of it in the refill; ..."); a run's
  /// sentences, each signal's above 3 % of its swing with its name; what a
  /// model leaves in one signal ("strain, 2.72 noise units: residual ...").
  std::string              shape_words(const std::string &signal, const SignalShape &s);
  std::vector<std::string> localisation_words(const Localisation &L);
  std::string              residual_words(const SignalResidual &r);

  /// How a candidate's searches ended where that is not the usual (not
  /// restarted, and why), and what its ringing start did with each
  /// frequency ("" where neither applies).
  std::string search_words(const CandidateResult &c);
  std::string ringing_words(const CandidateResult &c);

  /// The named effect's parameters in words: each one's standard error or
  /// why the record does not determine it, the combined quantity, the
  /// fit's moves along its profile (first) and the held partner (last);
  /// or why the standard errors could not be computed ("" where none were).
  std::string uncertainty_words(const RoundResult &rr);

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
