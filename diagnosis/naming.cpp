#include "diagnosis/naming.h"

#include <cstdio>

#include "diagnosis/fit.h"

namespace rectify::diagnosis
{
  namespace
  {
    double gap(double rms) { return gap_above_noise(rms * rms); }
  } // namespace

  Judgement judge(const FitScores &candidate, const FitScores &baseline,
                  const std::function<FeatureScores()> &feature, const NamingRules &rules)
  {
    Judgement j;
    j.delta_bic = baseline.bic - candidate.bic;
    if (j.delta_bic <= rules.bic_threshold)
      {
        j.failed = Rule::evidence;
        return j;
      }
    if (!(candidate.rms_heldout < baseline.rms_heldout))
      {
        j.failed = Rule::held_out;
        return j;
      }
    j.closed = gap(baseline.rms_train) > 0 ? 1.0 - gap(candidate.rms_train) / gap(baseline.rms_train) : 0.0;
    if (!(j.closed >= rules.min_gap_closed))
      {
        j.failed = Rule::gap;
        return j;
      }
    j.feature = feature();
    if (!(gap(j.feature.after) <= 0.5 * gap(j.feature.before)))
      j.failed = Rule::feature;
    return j;
  }

  std::string describe(const Judgement &j, const FitScores &c, const FitScores &base, const NamingRules &rules)
  {
    char buf[512];
    switch (j.failed)
      {
        case Rule::passed:
          return "";
        case Rule::evidence:
          std::snprintf(buf, sizeof buf, "%s: BIC better than none by only %.1f (needs > %.0f). ", c.effect.c_str(),
                        j.delta_bic, rules.bic_threshold);
          break;
        case Rule::held_out:
          std::snprintf(buf, sizeof buf, "%s: held-out residual %.4g not below none's %.4g. ", c.effect.c_str(),
                        c.rms_heldout, base.rms_heldout);
          break;
        case Rule::gap:
          std::snprintf(buf, sizeof buf,
                        "%s: closes only %.0f %% of the gap above the noise that the calibrated baseline "
                        "leaves (training RMS %.3g -> %.3g noise units; needs %.0f %%). ",
                        c.effect.c_str(), 100 * j.closed, base.rms_train, c.rms_train, 100 * rules.min_gap_closed);
          break;
        case Rule::feature:
          std::snprintf(buf, sizeof buf,
                        "%s: explains too little of the dominant feature (%s, %s half: %.3g -> %.3g noise "
                        "units; half of it above the noise needed). ",
                        c.effect.c_str(), j.feature.signal.c_str(), j.feature.half.c_str(), j.feature.before,
                        j.feature.after);
          break;
      }
    return buf;
  }

  std::string rule_name(Rule r)
  {
    return r == Rule::gap ? "gap" : r == Rule::feature ? "feature" : "";
  }
} // namespace rectify::diagnosis
