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

  std::string rule_name(Rule r)
  {
    return r == Rule::gap ? "gap" : r == Rule::feature ? "feature" : "";
  }
} // namespace rectify::diagnosis
