#include "diagnosis/words.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/case_file.h"
#include "diagnosis/fit.h"

namespace rectify::diagnosis
{
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

  std::string verdict_sentence(Verdict v, const std::string &named_effect, double baseline, double after,
                               double floor_units, double explained, const std::string &where)
  {
    char buf[512];
    switch (v)
      {
        case Verdict::explained:
          if (gap_above_noise(baseline * baseline) > 0)
            std::snprintf(buf, sizeof buf,
                          "%s explains the gap: residual %.3g noise units with the calibrated baseline alone, "
                          "%.3g with it (%.0f %% of the gap above the noise closed)",
                          named_effect.c_str(), baseline, after, 100 * explained);
          else // named on its training part; over the whole record the baseline was within the noise
            std::snprintf(buf, sizeof buf,
                          "%s explains the gap on the fitted part; over the whole record the calibrated baseline "
                          "alone already left %.3g noise units (within the noise), %.3g with it",
                          named_effect.c_str(), baseline, after);
          break;
        case Verdict::partly_explained:
          std::snprintf(buf, sizeof buf,
                        "%s explains %.0f %% of the gap above the noise (residual %.3g -> %.3g noise units); "
                        "%.3g noise units remain, more than %.3g: model error beyond the library. Largest "
                        "remaining residual: %s",
                        named_effect.c_str(), 100 * explained, baseline, after, after, floor_units, where.c_str());
          break;
        case Verdict::no_missing_effect:
          std::snprintf(buf, sizeof buf, "the calibrated baseline leaves %.3g noise units (at most %.3g)", after,
                        floor_units);
          break;
        case Verdict::beyond_library:
          std::snprintf(buf, sizeof buf,
                        "no effect of the library earns its parameters, and %.3g noise "
                        "units remain after the baseline fit (more than %.3g). Largest remaining residual: %s",
                        after, floor_units, where.c_str());
          break;
      }
    return buf;
  }

  std::string absorbed_sentence(const AbsorbedEffect &a)
  {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "; the calibrated baseline holds %s at %.3g, %.2g x the case's %.3g (%s): as much as "
                  "%s adding %.3g to the case's would, and this record cannot tell the two apart",
                  a.quantity.c_str(), a.fitted, a.fitted / a.case_value, a.case_value, a.meaning.c_str(),
                  a.effect.c_str(), a.fitted - a.case_value);
    std::string out = buf;
    if (a.set_by.empty())
      return out;
    std::string keys;
    for (std::size_t i = 0; i < a.set_by.size(); ++i)
      {
        std::snprintf(buf, sizeof buf, "%s%s (fitted %.3g)", i == 0 ? "" : i + 1 == a.set_by.size() ? " and " : ", ",
                      a.set_by[i].first.c_str(), a.set_by[i].second);
        keys += buf;
      }
    return out + ". To tell them apart, measure " + keys +
           " on the rig and give the case those values (or narrow their [uncertain] ranges to what is measured): "
           "the rest is then " + a.effect + "'s";
  }
  std::string verdict_words(const DiagnosisResult &r)
  {
    std::string where;
    if (const auto [k, most] = most_remaining(r.remaining); most)
      where = most->description + (r.runs.size() > 1 ? " (run " + r.runs[k].run.source + ")" : "");
    const std::string named_effect = r.rounds.empty() ? "none" : r.rounds.front().effect;
    std::string       s = verdict_sentence(r.verdict, named_effect, r.residual_baseline, r.residual_after.at("overall"),
                                           r.floor_units, r.explained_fraction, where);
    if (std::any_of(r.sensor_lags.begin(), r.sensor_lags.end(),
                    [](const SensorLag &l) { return !std::isinf(l.applied_Hz()); }))
      {
        char buf[200];
        std::snprintf(buf, sizeof buf,
                      " (the model seen through the sensors' fitted lags; with ideal sensors %.3g noise units)",
                      r.residual_after_ideal.at("overall"));
        s += buf;
      }
    for (const auto &a : r.absorbed_by_baseline)
      s += absorbed_sentence(a);
    return s;
  }

  std::vector<std::string> trends(const std::vector<RunLevel> &levels)
  {
    std::vector<std::string> out;
    if (levels.size() < 2)
      return out;
    const auto percent = [](double fraction) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.0f %%", 100 * fraction);
      return std::string(buf);
    };
    const auto describe = [&](double RunLevel::*x, const std::string &what, const std::string &unit) {
      std::vector<std::size_t> idx(levels.size());
      for (std::size_t i = 0; i < idx.size(); ++i)
        idx[i] = i;
      std::sort(idx.begin(), idx.end(), [&](auto i, auto j) { return levels[i].*x < levels[j].*x; });
      if (levels[idx.front()].*x == levels[idx.back()].*x)
        return;
      std::string s = "residual against " + what + ":";
      for (auto i : idx)
        s += " " + format_number(std::round(levels[i].*x * 10) / 10) + " " + unit + " -> " +
             percent(levels[i].residual) + ";";
      const double lo = levels[idx.front()].residual, hi = levels[idx.back()].residual;
      s += hi > 1.5 * lo ? " grows with " + what : lo > 1.5 * hi ? " falls with " + what : " about flat";
      out.push_back(s);
    };
    describe(&RunLevel::frequency_Hz, "frequency", "Hz");
    describe(&RunLevel::drive_pp, "drive amplitude", "(drive units p-p)");
    return out;
  }

  std::string left_out_words(const std::vector<BaselineParameter> &b)
  {
    std::string out;
    for (const auto &x : b)
      out += (out.empty() ? "" : ", ") + x.name + " " + x.note;
    return out.empty() ? std::string("nothing to try (its effect sets it)") : out;
  }

  std::string none_restart_words(const RoundResult::NoneRestart &n)
  {
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "none refitted from %s's baseline: BIC %.6g against %.6g from the case's (training RMS "
                  "%.4g against %.4g noise units), %s",
                  n.effect.c_str(), n.bic_after, n.bic_before, n.rms_train_after, n.rms_train_before,
                  n.kept ? "kept: every candidate is judged against it" : "not better: none's fit stands");
    return buf;
  }

  std::string nearest_miss_tried_words(const RoundResult::NearMiss &m)
  {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%s, the nearest miss (%.0f %% of the gap closed%s)", m.effect.c_str(),
                  100 * m.closed, m.judgement.failed == Rule::feature ? ", too little of the dominant feature" : "");
    return std::string("the parameters the case leaves out, tried on at none's fit and at ") + buf +
           ": at none's, " + left_out_words(m.at_none) + "; at " + m.effect + "'s, " + left_out_words(m.at_effect);
  }

  std::string near_miss_reason(const RoundResult &rr)
  {
    const auto &m = rr.near_miss;
    return m.effect.empty() ? std::string() : describe(m.judgement, m.candidate, m.baseline, rr.rules);
  }

  std::string set_by_effect_reason(const RoundResult &rr)
  {
    const auto &s = rr.set_by_effect;
    return s.effect.empty() || s.named ? std::string() : describe(s.judgement, s.candidate, s.baseline, rr.rules);
  }

  std::string signature_words(const RoundResult &rr)
  {
    if (!rr.signature_explained)
      return {};
    char buf[256];
    std::snprintf(buf, sizeof buf, "dominant residual feature (%s, %s half) %.3g -> %.3g noise units",
                  rr.feature.signal.c_str(), rr.feature.half.c_str(), rr.feature.before, rr.feature.after);
    return buf;
  }

  namespace
  {
    /// Why nothing was named: each step of the judging in turn.
    std::string judging_words(const RoundResult &rr)
    {
      using Kind = RoundResult::JudgingStep::Kind;
      std::string s;
      for (const auto &step : rr.judging)
        switch (step.kind)
          {
            case Kind::none_refitted:
              s += none_restart_words(rr.none_restart) + ". ";
              break;
            case Kind::judged:
              s += describe(step.judgement, step.candidate, step.baseline, rr.rules);
              break;
            case Kind::set_by_effect_rejected:
              s += step.candidate.effect +
                   " passed every rule against none, but it sets what the case leaves out, and against none "
                   "with that tried on (" +
                   left_out_words(rr.set_by_effect.at_none) +
                   "): " + describe(step.judgement, step.candidate, step.baseline, rr.rules);
              break;
            case Kind::nearest_miss_tried:
              s += "Then " + nearest_miss_tried_words(rr.near_miss) +
                   (step.changed ? "; judged again: " : ": nothing changed. ");
              break;
            case Kind::fits_without_stand:
              s += "The fits without them stand. ";
              break;
          }
      return s;
    }
  } // namespace

  std::string decision_words(const RoundResult &rr)
  {
    if (rr.effect == "none")
      return "no significant missing effect: " + judging_words(rr);
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "%s: BIC better than none by %.1f, held-out RMS %.4g vs none's %.4g, next best %s by %.1f; ",
                  rr.effect.c_str(), rr.named.delta_bic, rr.named.rms_heldout, rr.named.none_rms_heldout,
                  rr.named.next.c_str(), rr.named.next_delta_bic);
    std::string s = buf + signature_words(rr);
    if (rr.near_miss.named)
      s += "; named after its fit and none's were made again with the parameters the case leaves out (it was the "
           "nearest miss without them: " +
           std::string(rr.near_miss.missed_by == "feature" ? "it explained too little of the dominant feature" :
                                                             "it closed too little of the gap") +
           ")";
    return s;
  }
} // namespace rectify::diagnosis
