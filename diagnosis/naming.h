// Naming (a stage of diagnose()): whether a candidate's fit earns its name
// against a baseline fit. The rules, in order:
//  1. evidence: its BIC beats the baseline's by more than bic_threshold
//     (failing it, so do all the candidates that rank lower: stop);
//  2. held out: its held-out residual is below the baseline's;
//  3. gap: it closes at least min_gap_closed of the gap above the noise
//     that the baseline leaves (training RMS in noise units, r -> sqrt(r^2 - 1)).
//     BIC alone counts every sample as independent, which coloured noise
//     and small model errors are not: over 10^4 samples a fit that closes
//     4 % of a 1.35-unit residual still "wins" by 600;
//  4. feature: it takes at least half of the dominant residual feature
//     above the noise (the signal and cycle half where the baseline's
//     residual is largest; in noise units, so no effect takes the unit away).
// A candidate that fails only rule 3 or 4 is a near miss.
//
// Takes: the fits' scores (and, for rule 4, the feature's, asked for only
// where rules 1-3 pass). Gives: the Judgement, a pure function of them;
// words.h's describe() puts it in words.
#pragma once

#include <functional>
#include <string>

namespace rectify::diagnosis
{
  /// A fit's scores, as the rules read them (CandidateResult's).
  struct FitScores
  {
    std::string effect;
    double      bic = 0, rms_train = 0, rms_heldout = 0; ///< residuals in noise units
  };

  /// The dominant residual feature: the baseline's and the candidate's RMS
  /// over it (noise units, pooled over the runs).
  struct FeatureScores
  {
    std::string signal, half;
    double      before = 0, after = 0;
  };

  struct NamingRules
  {
    double bic_threshold  = 10.0;
    double min_gap_closed = 0.5;
  };

  /// The rule a candidate failed first (passed: it is named).
  enum class Rule
  {
    passed,
    evidence,
    held_out,
    gap,
    feature
  };

  struct Judgement
  {
    Rule          failed    = Rule::passed;
    double        delta_bic = 0; ///< the baseline's BIC minus the candidate's
    double        closed    = 0; ///< the share of the gap closed (rule 3 on; else 0)
    FeatureScores feature;       ///< rule 4's (where it was reached)

    bool named() const { return failed == Rule::passed; }
    /// the evidence rule: the candidates ranked below fail it too
    bool stop() const { return failed == Rule::evidence; }
    bool near() const { return failed == Rule::gap || failed == Rule::feature; }
  };

  /// The rules applied to `candidate` against `baseline`; `feature` is
  /// called only where rules 1-3 pass.
  Judgement judge(const FitScores &candidate, const FitScores &baseline,
                  const std::function<FeatureScores()> &feature, const NamingRules &rules);

  /// "gap" or "feature" for a near miss's rule, else "".
  std::string rule_name(Rule r);
} // namespace rectify::diagnosis
