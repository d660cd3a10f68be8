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

  namespace
  {
    /// One parameter's standard error, or why the record does not determine it.
    std::string parameter_words(const ParameterUncertainty &p)
    {
      char        buf[768];
      std::string as_well; // the profile's sides that fit as well
      const bool  tried = p.profile_tried[0] || p.profile_tried[1];
      for (int side = 0; side < 2; ++side)
        if (p.profile_tried[side] && !(p.profile_evidence[side] > p.evidence_needed))
          {
            std::snprintf(buf, sizeof buf,
                          "%s%s at %.3g (%s) with the baseline refitted fits as well "
                          "(training residual %.4g noise units against %.4g; evidence %.1f, %.0f needed)",
                          as_well.empty() ? "" : "; ", p.key.c_str(), p.profile_value[side], side ? "higher" : "lower",
                          p.profile_rms[side], p.rms_at_fit, p.profile_evidence[side], p.evidence_needed);
            as_well += buf;
          }
      if (p.determined)
        std::snprintf(buf, sizeof buf,
                      "%s = %.3g, standard error %.2g %% (%s); %.0f %% either way with the "
                      "baseline's uncertain parameters refitted fits worse (evidence %.0f and %.0f)",
                      p.key.c_str(), p.value, 100 * p.relative_sd,
                      tried ? "from its profile" : "local, from the fit's covariance", 100 * p.profile_step,
                      p.profile_evidence[0], p.profile_evidence[1]);
      else if (tried)
        std::snprintf(buf, sizeof buf,
                      "%s = %.3g is not determined by the record to %.0f %%: %s; it trades "
                      "with %s (correlation %.2f)",
                      p.key.c_str(), p.value, 100 * p.profile_step, as_well.c_str(), p.correlated_with.c_str(),
                      p.correlation);
      else
        std::snprintf(buf, sizeof buf,
                      "%s = %.3g is not determined by the record to %.0f %%: standard error "
                      "%.0f %% with the baseline's uncertain parameters within their ranges, %.0f %% with "
                      "them known; it trades with %s (correlation %.2f)",
                      p.key.c_str(), p.value, 100 * p.profile_step, 100 * p.relative_sd,
                      100 * p.local_relative_sd_given_baseline, p.correlated_with.c_str(), p.correlation);
      return buf;
    }

    std::string combined_words(const CombinedEstimate &e)
    {
      char buf[768];
      std::snprintf(buf, sizeof buf, "%s %s = %.3g, standard error %.2g %% (local; %s)",
                    e.determined ? "the record determines" : "the record does not determine", e.name.c_str(), e.value,
                    100 * e.relative_sd, e.meaning.c_str());
      return buf;
    }

    std::string profile_moves_words(const nlohmann::json &moves)
    {
      if (moves.empty())
        return "";
      char words[256];
      std::snprintf(words, sizeof words,
                    "the fit moved along its profile %zu time(s) to a side that fitted better "
                    "(the last at %.4g, evidence %.1f) and was refitted there; ",
                    moves.size(), moves.back()["value"].get<double>(), moves.back()["evidence"].get<double>());
      return words;
    }

    /// The held partner (RoundResult::held_partner): what holding it at the
    /// case's value did, and the effect over the partner's range.
    std::string held_partner_words(const nlohmann::json &h, const ParameterUncertainty &now,
                                   const std::string &combination)
    {
      const auto bound = [](const nlohmann::json &x) {
        char b[40];
        std::snprintf(b, sizeof b, "%.3g", x.is_null() ? 0.0 : x.get<double>());
        return x.is_null() ? std::string("none") : std::string(b);
      };
      const auto evidence = [&] {
        return std::to_string(static_cast<int>(std::lround(h["evidence"].get<double>())));
      };
      std::string how;
      if (!h.contains("evidence"))
        how = "no value of the effect keeps the sum there: the split kept";
      else if (h.contains("refit_failed"))
        how = "its refit failed: the split kept";
      else if (!h["kept"].get<bool>())
        how = "fits worse (evidence " + evidence() + "): the split kept";
      else
        how = std::string(h["evidence"].get<double>() < -now.evidence_needed ? "fits better" : "fits as well") +
              " (evidence " + evidence() + "): kept" +
              (now.determined ? "; there its profile determines it" : "; still not determined");
      const std::string name = h["parameter"].get<std::string>(), &key = now.key;
      char              words[900];
      std::snprintf(words, sizeof words,
                    "; the fit's split (%s %.4g, %s %.3g) left %s not determined by the record, "
                    "only %s: with %s held at the case's %.4g (not traded against the effect) "
                    "%s = %.3g %s; over %s's declared range (%.4g-%.4g) %s would be %s to %s",
                    name.c_str(), h["split"][name].get<double>(), key.c_str(), h["split"][key].get<double>(),
                    key.c_str(), combination.c_str(), name.c_str(), h["case_value"].get<double>(), key.c_str(),
                    h.contains("held_value") ? h["held_value"].get<double>() : std::nan(""),
                    ("(" + how + ")").c_str(), name.c_str(), h["range"][0].get<double>(),
                    h["range"][1].get<double>(), key.c_str(), bound(h["effect_over_its_range"][0]).c_str(),
                    bound(h["effect_over_its_range"][1]).c_str());
      return words;
    }
  } // namespace

  std::string standing_words(const BaselineParameter &b)
  {
    char        buf[240];
    std::string s;
    if (b.left_out)
      s = "left out until an effect is named, then tried on with it";
    else if (!b.inert.empty())
      s = "held at the case's value: " + b.inert +
          "; freed with a named effect that makes it act, where the data determine it";
    else if (b.tried)
      {
        const auto &t = *b.tried;
        switch (t.outcome)
          {
            case LeftOutTry::Outcome::not_tried:
              std::snprintf(buf, sizeof buf,
                            "not tried: the named fit leaves no gap above the noise (training RMS %.3g noise units)",
                            t.rms_train);
              break;
            case LeftOutTry::Outcome::on:
              std::snprintf(buf, sizeof buf,
                            "tried on from %d points along its range, the best from %.3g: BIC %.6g against %.6g off",
                            t.starts, t.best_from, t.bic_with, t.bic_without);
              break;
            case LeftOutTry::Outcome::no_better:
              std::snprintf(buf, sizeof buf,
                            "a fit with it, from %d points along its range, scored no better (BIC %.6g against %.6g)",
                            t.starts, t.bic_with, t.bic_without);
              break;
            case LeftOutTry::Outcome::failed:
              std::snprintf(buf, sizeof buf, "every fit with it, from %d points along its range, failed", t.starts);
              break;
          }
        s = buf;
      }
    else
      {
        std::string correlated;
        if (b.correlation != 0.0)
          {
            std::snprintf(buf, sizeof buf, "correlated %.3f with %s", b.correlation, b.correlated_with.c_str());
            correlated = buf;
          }
        if (b.held_undetermined)
          {
            std::snprintf(buf, sizeof buf, "held at the case's value: standard error %.2g of its range%s%s",
                          b.sd_unit, correlated.empty() ? "" : ", ", correlated.c_str());
            s = buf;
          }
        else
          s = correlated;
      }
    const auto also = [&](const std::string &more) { s = (s.empty() ? "" : s + "; ") + more; };
    if (b.value == 0.0)
      also("off, as the case has it");
    else if (b.at_end != 0)
      also(std::string("at the ") + (b.at_end > 0 ? "upper" : "lower") +
           " end of its range: the data ask for a value beyond it (a missing effect can pull it there, or "
           "the range is too narrow)");
    return s;
  }

  std::string settling_words(const RunCase &rc)
  {
    using Why     = RunCase::Settling::Why;
    const auto &s = rc.settling;
    char        buf[400];
    switch (s.why)
      {
        case Why::unset:
          return "";
        case Why::given:
          return "as given (--settling-cycles)";
        case Why::rest_exact:
          return "none: a start at rest is exact";
        case Why::one_cycle:
          return "one cycle";
        case Why::few_cycles:
          return "one cycle (the model's memory of its start not measured: fewer than two training cycles)";
        case Why::run_failed:
          return "one cycle (the model's memory of its start not measured: a run failed)";
        case Why::orbits_apart:
          std::snprintf(buf, sizeof buf,
                        "one cycle: the model's runs from the %s start and from the %s one do not meet within the "
                        "training part, nor come half-way together (%.3g noise units apart in its last cycle, "
                        "%.3g at most)",
                        to_string(s.start).c_str(), to_string(s.other).c_str(), s.last, s.largest);
          break;
        case Why::meets_later:
          std::snprintf(buf, sizeof buf,
                        "%zu cycles, half the training part: the model's runs from the %s start and from the %s one "
                        "meet later (%.3g noise units apart in cycle %zu)",
                        s.cycles, to_string(s.start).c_str(), to_string(s.other).c_str(), s.apart, s.cycles + 1);
          break;
        case Why::settled:
          std::snprintf(buf, sizeof buf,
                        "%zu cycle%s: the model's runs from the %s start and from the %s one differ by at most "
                        "%.3g noise units per cycle from then on (%.3g in the first)",
                        s.cycles, s.cycles == 1 ? "" : "s", to_string(s.start).c_str(), to_string(s.other).c_str(),
                        s.tolerance, s.apart);
          break;
      }
    return buf;
  }

  std::string band_words(const RunCase &rc)
  {
    switch (rc.band_why)
      {
        case RunCase::BandWhy::as_asked:
          return "as asked";
        case RunCase::BandWhy::below_reed:
          return "below half the reed's natural frequency (" +
                 std::to_string(static_cast<long>(std::lround(rc.reed_Hz))) +
                 " Hz): the valves flutter there in a loaded run";
        case RunCase::BandWhy::nyquist:
          return "the band asked for reaches the sampling's Nyquist frequency: every sample";
        case RunCase::BandWhy::unset:
          break;
      }
    return "";
  }

  std::string start_revision_words(const RunCase &rc)
  {
    std::string s;
    for (const auto &v : rc.start_revisions)
      s += (s.empty() ? to_string(v.from) + " with the case's baseline" : "") + ", " + to_string(v.to) + " with " +
           v.effect + "'s fit";
    return s;
  }

  std::string search_words(const CandidateResult &c)
  {
    if (!c.not_restarted)
      return "";
    const auto &s = *c.not_restarted;
    char        buf[320];
    std::snprintf(buf, sizeof buf,
                  "not restarted: its first searches close %.0f %% of the gap above the noise that none "
                  "leaves, %.0f %% if two more gained as much (%.0f %% needed to be restarted, %.0f %% "
                  "to be named)",
                  std::max(0.0, 100 * s.closed), std::max(0.0, 100 * s.reachable), 100 * s.restart_needed,
                  100 * s.name_needed);
    return buf;
  }

  std::string ringing_words(const CandidateResult &c)
  {
    if (!c.ringing)
      return "";
    if (c.ringing->no_peak)
      return "no peak in the residual's spectrum where it can ring";
    std::string note;
    for (const auto &t : c.ringing->tries)
      {
        char buf[240];
        if (t.grid < 0)
          std::snprintf(buf, sizeof buf, "%.0f Hz: out of its range", t.f);
        else if (t.lines > 0)
          std::snprintf(buf, sizeof buf,
                        "%.0f Hz: the lines along the baseline %.3g x the residual with it off over 3 cycles, its "
                        "pair grids not run (below %.3g x needed)",
                        t.f, t.lines, t.lines_needed);
        else if (t.six < 0)
          std::snprintf(buf, sizeof buf, "%.0f Hz: its grid %.3g x the residual with it off over 3 cycles, no further",
                        t.f, t.grid);
        else
          std::snprintf(buf, sizeof buf,
                        "%.0f Hz: its grid %.3g x the residual with it off over 3 cycles, refined to %.3g x over 6 "
                        "(%s)",
                        t.f, t.grid, t.six, t.start ? "a start" : "not a start");
        note += (note.empty() ? "" : "; ") + std::string(buf);
      }
    return note;
  }

  std::string uncertainty_words(const RoundResult &rr)
  {
    if (!rr.uncertainty_error.empty())
      return "the parameters' standard errors could not be computed: " + rr.uncertainty_error;
    std::string s;
    for (const auto &p : rr.uncertainty)
      s += (s.empty() ? "" : "; ") + parameter_words(p);
    if (rr.combined)
      s += "; " + combined_words(*rr.combined);
    s = profile_moves_words(rr.profile_moves) + s;
    if (!rr.held_partner.is_null() && !rr.uncertainty.empty() && rr.combined)
      s += held_partner_words(rr.held_partner, rr.uncertainty.front(), rr.combined->name);
    return s;
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
      where = residual_words(*most) + (r.runs.size() > 1 ? " (run " + r.runs[k].run.source + ")" : "");
    const std::string named_effect =
      r.rounds.empty() ? "none" : r.rounds.front().effect.value_or("none");
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
      out += (out.empty() ? "" : ", ") + x.name + " " + standing_words(x);
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
                  100 * m.judgement.closed, m.judgement.failed == Rule::feature ? ", too little of the dominant feature" : "");
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
    if (!rr.effect)
      return "no significant missing effect: " + judging_words(rr);
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "%s: BIC better than none by %.1f, held-out RMS %.4g vs none's %.4g, next best %s by %.1f; ",
                  rr.effect->c_str(), rr.named.delta_bic, rr.named.rms_heldout, rr.named.none_rms_heldout,
                  rr.named.next.c_str(), rr.named.next_delta_bic);
    std::string s = buf + signature_words(rr);
    if (rr.near_miss.named)
      s += "; named after its fit and none's were made again with the parameters the case leaves out (it was the "
           "nearest miss without them: " +
           std::string(rr.near_miss.judgement.failed == Rule::feature ? "it explained too little of the dominant feature" :
                                                             "it closed too little of the gap") +
           ")";
    return s;
  }
} // namespace rectify::diagnosis
