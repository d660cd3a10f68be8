// summary.json's content (part of the report): every stage's result as data.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "diagnosis/diagnose.h"
#include "diagnosis/fit.h"
#include "diagnosis/search.h"
#include "diagnosis/words.h"

namespace rectify::diagnosis
{
  namespace
  {
    using nlohmann::json;

    json candidate_json(const CandidateResult &c)
    {
      json cp = json::object();
      if (c.effect != "none" && c.not_testable.empty())
        {
          const auto e = find_effect(c.effect);
          for (std::size_t i = 0; i < c.values.size(); ++i)
            cp[e->parameters()[i].key] = c.values[i];
        }
      json cj = {{"effect", c.effect}, {"parameters", cp}};
      if (!c.not_testable.empty())
        cj["not_testable"] = c.not_testable;
      else
        {
          cj["force_gain"]   = c.force_gain;
          cj["baseline"]     = c.baseline;
          cj["k"]            = c.k;
          cj["bic"]          = c.bic;
          cj["aic"]          = c.aic;
          cj["compared_samples"] = c.n_train; // its BIC's n (compared_cycles_per_run)
          cj["rms_train"]    = c.rms_train;
          cj["rms_heldout"]  = c.rms_heldout;
          cj["evaluations"]  = c.evaluations;
          cj["wall_time_s"]  = c.wall_time_s;
          cj["failed"]       = c.failed;
          cj["optimiser"]    = c.message;
          if (c.not_restarted)
            cj["search"] = search_words(c);
          if (const auto ringing = ringing_words(c); !ringing.empty())
            {
              cj["ringing"]        = ringing;
              cj["ringing_runs"]   = c.ringing_runs;
              cj["ringing_time_s"] = c.ringing_time_s;
            }
        }
      return cj;
    }

    json baseline_fit_json(const RoundResult &rr)
    {
      json check = json::array();
      for (const auto &b : rr.baseline_check)
        check.push_back({{"parameter", b.name},
                         {"fitted", b.value},
                         {"case_value", b.nominal},
                         {"bounds", {b.lower, b.upper}},
                         {"standard_error_of_range", b.sd_unit},
                         {"identifiable", b.identifiable},
                         {"note", standing_words(b)}});
      return check;
    }

    json freed_json(const RoundResult &rr)
    {
      json freed = json::array();
      for (const auto &b : rr.freed)
        freed.push_back({{"parameter", b.name},
                         {"standard_error_of_range", b.sd_unit},
                         {"note", standing_words(b)},
                         {"freed_as", b.effect_shape ? "the named effect's shape (held while the model lacked it)"
                                                     : "a baseline parameter the named effect's fit determines"},
                         {"refitted", rr.baseline.count(b.name) ? json(rr.baseline.at(b.name)) : json()}});
      return freed;
    }

    /// A left-out parameter's tries; at the named fit (`refitted`) also its
    /// value after the refits
    json tries(const std::vector<BaselineParameter> &b, const RoundResult *refitted = nullptr)
    {
      json out = json::array();
      for (const auto &x : b)
        {
          json t = {{"parameter", x.name}, {"on", x.value != 0.0}, {"fitted", x.value}, {"note", standing_words(x)}};
          if (refitted)
            t["refitted"] = refitted->baseline.count(x.name) ? json(refitted->baseline.at(x.name)) : json();
          out.push_back(std::move(t));
        }
      return out;
    }

    json none_restart_json(const RoundResult &rr)
    {
      json none_restart; // null: no candidate beat none
      if (!rr.none_restart.effect.empty())
        none_restart = {{"from_the_baseline_of", rr.none_restart.effect},
                        {"bic_from_the_case", rr.none_restart.bic_before},
                        {"bic_from_there", rr.none_restart.bic_after},
                        {"rms_train_from_the_case", rr.none_restart.rms_train_before},
                        {"rms_train_from_there", rr.none_restart.rms_train_after},
                        {"kept", rr.none_restart.kept}};
      return none_restart;
    }

    json near_miss_json(const RoundResult &rr)
    {
      json near_miss; // null: not tried
      if (!rr.near_miss.effect.empty())
        near_miss = {{"effect", rr.near_miss.effect},
                     {"gap_closed_without", rr.near_miss.judgement.closed},
                     {"missed_by", rule_name(rr.near_miss.judgement.failed)},
                     {"reason_without", near_miss_reason(rr)},
                     {"none_without", {{"bic", rr.near_miss.none_bic}, {"rms_train", rr.near_miss.none_rms_train}}},
                     {"effect_without",
                      {{"bic", rr.near_miss.effect_bic}, {"rms_train", rr.near_miss.effect_rms_train}}},
                     {"at_none", tries(rr.near_miss.at_none)},
                     {"at_the_effect", tries(rr.near_miss.at_effect)},
                     {"named", rr.near_miss.named}};
      return near_miss;
    }

    json set_by_effect_json(const RoundResult &rr)
    {
      json set_by_effect; // null: no effect that passed sets one
      if (!rr.set_by_effect.effect.empty())
        set_by_effect = {{"effect", rr.set_by_effect.effect},
                         {"at_none", tries(rr.set_by_effect.at_none)},
                         {"named", rr.set_by_effect.named},
                         {"reason", set_by_effect_reason(rr)},
                         {"none_without",
                          {{"bic", rr.set_by_effect.none_bic}, {"rms_train", rr.set_by_effect.none_rms_train}}}};
      return set_by_effect;
    }

    json uncertainty_json(const RoundResult &rr)
    {
      json uncertainty = json::array();
      for (const auto &q : rr.uncertainty)
        uncertainty.push_back({{"parameter", q.key},
                               {"value", q.value},
                               {"relative_standard_error", q.relative_sd},
                               {"one_standard_error", {q.lower, q.upper}},
                               {"local_relative_standard_error", q.local_relative_sd},
                               {"local_relative_standard_error_given_baseline", q.local_relative_sd_given_baseline},
                               {"most_correlated_with", q.correlated_with},
                               {"correlation", q.correlation},
                               {"profile",
                                {{"values", q.profile_value},
                                 {"training_residual", q.profile_rms},
                                 {"training_residual_at_the_fit", q.rms_at_fit},
                                 {"evidence_against", q.profile_evidence},
                                 {"determined", q.profile_determined}}},
                               {"determined", q.determined}});
      return uncertainty;
    }

    json combined_json(const RoundResult &rr)
    {
      json combined = nullptr;
      if (rr.combined)
        combined = {{"quantity", rr.combined->name},
                    {"meaning", rr.combined->meaning},
                    {"value", rr.combined->value},
                    {"relative_standard_error", rr.combined->relative_sd},
                    {"determined", rr.combined->determined}};
      return combined;
    }

    json parameters_json(const std::optional<std::string> &effect, const std::vector<double> &values)
    {
      json p = json::object();
      if (effect)
        {
          const auto e = find_effect(*effect);
          for (std::size_t i = 0; i < values.size(); ++i)
            p[e->parameters()[i].key] = values[i];
        }
      return p;
    }

    json round_json(const RoundResult &rr)
    {
      const json p          = parameters_json(rr.effect, rr.values);
      const json check      = baseline_fit_json(rr);
      const json freed      = freed_json(rr);
      const json left_out   = tries(rr.left_out, &rr);
      const json none_restart  = none_restart_json(rr);
      const json near_miss     = near_miss_json(rr);
      const json set_by_effect = set_by_effect_json(rr);
      const json uncertainty   = uncertainty_json(rr);
      const json combined      = combined_json(rr);
      json       candidates    = json::array();
      for (const auto &c : rr.candidates)
        candidates.push_back(candidate_json(c));
      return {{"effect", rr.effect.value_or("none")},
              {"parameters", p},
              {"parameter_uncertainty", uncertainty},
              {"combined", combined},
              {"uncertainty_sentence", uncertainty_words(rr)},
              {"uncertainty_runs_of_the_model", rr.uncertainty_runs},
              {"moved_along_its_profile", rr.profile_moves},
              {"held_partner", rr.held_partner},
              {"force_gain", rr.force_gain},
              {"baseline", rr.baseline},
              {"baseline_fit", check},
              {"freed_at_the_named_fit", freed},
              {"left_out_tried_at_the_named_fit", left_out},
              {"nearest_miss_with_left_out", near_miss},
              {"none_restarted", none_restart},
              {"left_out_judged_with_the_effect_that_sets_it", set_by_effect},
              {"confidence", rr.confidence},
              {"decision", decision_words(rr)},
              {"signature_explained", rr.signature_explained},
              {"signature", signature_words(rr)},
              {"refits_with_rescaled_residuals", rr.refine_passes},
              {"candidates", candidates}};
    }

    /// The run and signal where a model leaves the most noise units (null: none)
    json largest_json(const std::vector<std::vector<SignalResidual>> &remaining, const std::vector<RunCase> &runs)
    {
      json largest;
      if (const auto [k, most] = most_remaining(remaining); most && k < runs.size())
        largest = {{"run", runs[k].run.source},
                   {"signal", most->signal},
                   {"noise_units", most->noise_units},
                   {"description", residual_words(*most)}};
      return largest;
    }

    json absorbed_json(const DiagnosisResult &r)
    {
      const auto set_by = [](const AbsorbedEffect &a) {
        json out = json::array();
        for (const auto &[key, fitted] : a.set_by)
          out.push_back({{"key", key}, {"fitted", fitted}});
        return out;
      };
      json absorbed = json::array();
      for (const auto &a : r.absorbed_by_baseline)
        absorbed.push_back({{"effect", a.effect}, {"quantity", a.quantity}, {"meaning", a.meaning},
                            {"case_value", a.case_value}, {"fitted", a.fitted},
                            {"as_the_effect", a.fitted - a.case_value}, {"set_by", set_by(a)}});
      return absorbed;
    }

    json localisation_json(const DiagnosisResult &r, const std::vector<RunCase> &runs)
    {
      // run i's list, the most first, as the report gives it (empty where
      // there is none: a diagnosis that stopped before its verdict)
      const auto in_noise_units = [](const std::vector<std::vector<SignalResidual>> &all, std::size_t i) {
        json out = json::array();
        if (i < all.size())
          for (const auto &x : all[i])
            out.push_back({{"signal", x.signal}, {"noise_units", x.noise_units}, {"description", residual_words(x)}});
        return out;
      };
      json localisation = json::array();
      for (std::size_t i = 0; i < runs.size(); ++i)
        localisation.push_back({{"run", runs[i].run.source},
                                {"frequency_Hz", runs[i].setup.frequency_Hz},
                                {"start", to_string(r.runs[i].start)},
                                {"start_residuals", r.runs[i].start_scores},
                                {"start_revised", start_revision_words(r.runs[i])},
                                {"harmonics_compared", r.runs[i].harmonics},
                                {"band_Hz", r.runs[i].band_Hz},
                                {"band_reason", band_words(r.runs[i])},
                                {"lead_cycles", r.runs[i].lead_cycles},
                                {"settling_samples_left_out", r.runs[i].n_skip},
                                {"settling_reason", settling_words(r.runs[i])},
                                {"start_memory_noise_units", r.runs[i].start_memory},
                                {"outliers", [&] {
                                   json o = json::array();
                                   for (const auto &x : r.runs[i].outliers)
                                     o.push_back({{"column", x.column},
                                                  {"row", x.row},
                                                  {"time_s", x.time_s},
                                                  {"size", x.size},
                                                  {"noise_units", x.noise_units}});
                                   return o;
                                 }()},
                                {"sentences", localisation_words(r.localisation[i])},
                                {"before_in_noise_units", in_noise_units(r.remaining_before, i)},
                                {"after_in_noise_units", in_noise_units(r.remaining, i)},
                                {"numbers", r.localisation[i].numbers()}});
      return localisation;
    }

    json sensors_json(const DiagnosisResult &r)
    {
      nlohmann::json sensors = nlohmann::json::array();
      const auto     hz      = [](double f) { return std::isinf(f) ? nlohmann::json() : nlohmann::json(f); }; // inf: null
      for (const auto &l : r.sensor_lags)
        sensors.push_back({{"signal", l.signal},
                           {"bandwidth_Hz", hz(l.applied_Hz())},
                           {"fitted_bandwidth_Hz", hz(l.fitted_Hz)},
                           {"kept", l.kept},
                           {"lowest_bandwidth_Hz", l.lowest_Hz},
                           {"at_lowest", l.at_lowest()},
                           {"training_residual_ideal", l.residual_ideal},
                           {"training_residual_lagged", l.residual_lagged},
                           {"heldout_residual_ideal", l.heldout_ideal},
                           {"heldout_residual_lagged", l.heldout_lagged}});
      return sensors;
    }

    json definitions()
    {
      return {{"residual", "RMS of (model - data) / (the signal's expected noise: its white noise and the "
                           "model's response to the drive's noise), per signal over every run; overall: RMS "
                           "over the signals. About 1 when the model explains the data to within its noise"},
              {"residual_before_fraction_of_swing", "the same residual over the measured signal's RMS about its mean"},
              {"sensor_lags",
               "each signal's sensor as a first-order lag (-3 dB bandwidth; null: ideal), fitted between the "
               "case's [sensors] lowest bandwidth and an ideal sensor to the final model on the training samples "
               "(fitted_bandwidth_Hz), one per signal for every run, after everything else was decided, and kept "
               "(bandwidth_Hz) where the held-out samples fit at least as well with it; residual_after and the "
               "verdict count the model through the kept lags, residual_after_ideal_sensors without them"},
              {"largest_residual_after",
               "where the final model leaves the most, the verdict's \"where\": the run and signal with the "
               "largest residual in noise units (from the run's settling on), and how that residual lies (its "
               "share of the swing, cycle half, mean offset, harmonic, trend over the record)"},
              {"largest_residual_before",
               "the same for the case's model as given, before any fit (residual_before's largest), in the same "
               "units and window"},
              {"localisation",
               "per run: before_in_noise_units and after_in_noise_units, every signal's residual in noise units "
               "from the run's settling on with its description, the most first (the report's lists; their "
               "firsts over the runs are largest_residual_before and _after); sentences, the case's model as "
               "given described signal by signal where its residual exceeds 3 % of the signal's swing; numbers, "
               "each signal's harmonics, cycle halves and trend"},
              {"bic", "n ln(SSR/n) + k ln n on the training samples (first part of each run; for the "
                      "candidates, the first compared_cycles_per_run cycles of it after the settling)"},
              {"compared_cycles_per_run",
               "the candidates (none too) were fitted and scored on this many training cycles of each run after "
               "its settling (the whole training part of a shorter run), at most DiagnoseOptions::compared_cycles "
               "in all; the named effect was then refitted on every training cycle. 0: every training cycle"},
              {"none_restarted",
               "none refitted, before any candidate was judged, from the [uncertain] parameters and gain of the "
               "candidate with the best BIC (where it beat none's fit from the case's values by the BIC "
               "threshold): its BIC and training RMS against none's from the case's; kept: it fitted better and "
               "stood as none's fit, against which every candidate was judged. null: no candidate beat none"},
              {"aic", "n ln(SSR/n) + 2k"},
              {"rms_heldout", "normalised RMS residual on the last part of each run, unseen by the fit"},
              {"confidence", "BIC weight exp(-BIC/2) / sum over the candidates"},
              {"relative_standard_error",
               "of the named effect's parameter at its final fit: the standard error of ln(value) (log-scaled "
               "parameters; about the relative error while small) or of value / |value|, from its profile: the "
               "step over the square root of the evidence against it, the larger side (null: a side fits as "
               "well, more than the step); one_standard_error: the value that far down and up (null on a side "
               "that fits as well)"},
              {"standard_error_of_range",
               "a baseline parameter's standard error at the baseline fit (Gauss-Newton, Jacobian by forward "
               "differences) as a share of its range (log range where log-scaled), counting every compared "
               "sample as independent (s2 = SSR / n): smaller than the error per independent value of the band "
               "by sqrt(n / independent values), about 3x within 10 harmonics at 200 samples per cycle, 5x "
               "within 3; the identifiability limit (identifiability_sd) applies to this number"},
              {"baseline_standard_error_factor",
               "sqrt(n / independent values of the compared band): a baseline parameter's standard error counted "
               "per independent value is standard_error_of_range times this"},
              {"local_relative_standard_error",
               "the same from the fit's covariance (Jacobian by forward differences, the residual's variance "
               "per independent value of the compared band) with every [uncertain] baseline parameter and the "
               "force gain unknown within its range (uniform prior); given_baseline: with them known. Local: it "
               "can call a curved or flat valley determined"},
              {"profile",
               "the named effect's parameter moved by determined_relative_sd down and up and held while every "
               "[uncertain] baseline parameter and the force gain are refitted: each side's training residual "
               "(noise units) and the evidence against it, n_eff ln(SSR / SSR at the fit); determined when both "
               "exceed the naming's BIC threshold"},
              {"force_gain", "nuisance: the rod's force per ampere times this, fitted with every candidate"}};
    }
  } // namespace

  nlohmann::json to_json(const DiagnosisResult &r, const std::vector<RunCase> &runs)
  {
    const auto &first  = r.rounds.front();
    json        rounds = json::array();
    for (const auto &rr : r.rounds)
      rounds.push_back(round_json(rr));
    const json parameters   = parameters_json(first.effect, first.values);
    const json largest      = largest_json(r.remaining, runs); // the verdict's "where"
    const json absorbed     = absorbed_json(r);
    const json localisation = localisation_json(r, runs);
    const json sensors      = sensors_json(r);
    double shrink = 0;
    if (r.residual_before.at("overall") > 0)
      shrink = 1.0 - r.residual_after.at("overall") / r.residual_before.at("overall");
    return {{"effect", first.effect.value_or("none")},
            {"parameters", parameters},
            {"parameter_uncertainty", rounds.front()["parameter_uncertainty"]},
            {"combined", rounds.front()["combined"]},
            {"held_partner", rounds.front()["held_partner"]},
            {"uncertainty_sentence", uncertainty_words(first)},
            {"confidence", first.confidence},
            {"decision", decision_words(first)},
            {"residual_before", r.residual_before},
            {"residual_after", r.residual_after},
            {"residual_after_ideal_sensors", r.residual_after_ideal},
            {"sensor_lags", sensors},
            {"residual_shrink", shrink},
            {"verdict", to_string(r.verdict)},
            {"verdict_sentence", verdict_words(r)},
            {"largest_residual_after", largest},
            {"largest_residual_before", largest_json(r.remaining_before, runs)},
            {"absorbed_by_baseline", absorbed},
            {"explained_fraction", r.explained_fraction},
            {"residual_baseline_fit", r.residual_baseline},
            {"baseline_standard_error_factor", r.baseline_sd_factor},
            {"compared_cycles_per_run", r.compared_cycles_per_run},
            {"resumed_fits", r.resumed},
            {"baseline", first.baseline},
            {"baseline_fit", rounds.front()["baseline_fit"]},
            {"freed_at_the_named_fit", rounds.front()["freed_at_the_named_fit"]},
            {"left_out_tried_at_the_named_fit", rounds.front()["left_out_tried_at_the_named_fit"]},
            {"nearest_miss_with_left_out", rounds.front()["nearest_miss_with_left_out"]},
            {"none_restarted", rounds.front()["none_restarted"]},
            {"left_out_judged_with_the_effect_that_sets_it",
             rounds.front()["left_out_judged_with_the_effect_that_sets_it"]},
            {"residual_before_fraction_of_swing", r.swing_before},
            {"residual_after_fraction_of_swing", r.swing_after},
            {"candidates", rounds.front()["candidates"]},
            {"rounds", rounds},
            {"localisation", localisation},
            {"trends", trends(r.run_levels)},
            {"wall_time_s", r.wall_time_s},
            {"runs_evaluated_ahead", r.runs_evaluated_ahead},
            {"definitions", definitions()}};
  }
} // namespace rectify::diagnosis
