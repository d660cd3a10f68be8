// The naming rules (diagnosis/naming.h), the verdict (diagnosis/verdict.h)
// and their words (diagnosis/words.h) on constructed score tables: no model
// is run.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "diagnosis/naming.h"
#include "diagnosis/verdict.h"
#include "diagnosis/words.h"

using namespace rectify::diagnosis;

namespace
{
  const NamingRules rules{10.0, 0.5};

  /// none's fit: BIC 1000, training RMS 3 noise units (gap sqrt(8)), held out 3.2
  const FitScores none{"none", 1000.0, 3.0, 3.2};

  /// A candidate whose fit passes the first three rules against `none`: BIC
  /// 100 better, held-out 1.5, training RMS 1.2 (gap sqrt(0.44) of sqrt(8):
  /// 77 % closed).
  FitScores good() { return {"valve_leakage", 900.0, 1.2, 1.5}; }

  /// A feature the candidate takes (gap 3.87 -> 0.75: less than half left)
  FeatureScores taken() { return {"outlet_pressure_Pa", "rising", 4.0, 1.25}; }

  /// The gap above the noise of an RMS r, as the rules count it
  double gap(double r) { return std::sqrt(std::max(r * r - 1.0, 0.0)); }
} // namespace

TEST(Naming, ACandidateThatPassesEveryRuleIsNamed)
{
  int        asked = 0;
  const auto j     = judge(good(), none, [&] { ++asked; return taken(); }, rules);
  EXPECT_TRUE(j.named());
  EXPECT_FALSE(j.near());
  EXPECT_FALSE(j.stop());
  EXPECT_EQ(asked, 1);
  EXPECT_DOUBLE_EQ(j.delta_bic, 100.0);
  EXPECT_NEAR(j.closed, 1.0 - gap(1.2) / gap(3.0), 1e-15);
  EXPECT_EQ(j.feature.signal, "outlet_pressure_Pa");
  EXPECT_EQ(describe(j, good(), none, rules), "");
}

TEST(Naming, TheEvidenceRuleStopsAndNeverAsksForTheFeature)
{
  for (const double bic : {995.0, 990.0}) // 5 and exactly the threshold: not more than 10 better
    {
      auto c  = good();
      c.bic   = bic;
      int  asked = 0;
      const auto j = judge(c, none, [&] { ++asked; return taken(); }, rules);
      EXPECT_EQ(j.failed, Rule::evidence) << bic;
      EXPECT_TRUE(j.stop());
      EXPECT_FALSE(j.near());
      EXPECT_EQ(asked, 0);
      EXPECT_NE(describe(j, c, none, rules).find("BIC better than none by only"), std::string::npos);
    }
  auto c = good();
  c.bic  = 989.9; // just over the threshold
  EXPECT_NE(judge(c, none, taken, rules).failed, Rule::evidence);
}

TEST(Naming, AHeldOutResidualNotBelowNonesFailsWithoutStopping)
{
  auto c        = good();
  c.rms_heldout = none.rms_heldout; // equal is not below
  const auto j  = judge(c, none, taken, rules);
  EXPECT_EQ(j.failed, Rule::held_out);
  EXPECT_FALSE(j.stop());
  EXPECT_FALSE(j.near());
  c.rms_heldout = std::numeric_limits<double>::quiet_NaN(); // a failed held-out run: not below
  EXPECT_EQ(judge(c, none, taken, rules).failed, Rule::held_out);
  EXPECT_EQ(describe(j, c, none, rules).rfind("valve_leakage: held-out residual", 0), 0u);
}

TEST(Naming, TooLittleOfTheGapClosedIsANearMiss)
{
  // training RMS 2.6 against 3: gap sqrt(5.76) of sqrt(8), 15 % closed
  auto c      = good();
  c.rms_train = 2.6;
  int  asked  = 0;
  const auto j = judge(c, none, [&] { ++asked; return taken(); }, rules);
  EXPECT_EQ(j.failed, Rule::gap);
  EXPECT_TRUE(j.near());
  EXPECT_EQ(asked, 0);
  EXPECT_NEAR(j.closed, 1.0 - gap(2.6) / gap(3.0), 1e-15);
  EXPECT_EQ(rule_name(j.failed), "gap");
  EXPECT_NE(describe(j, c, none, rules).find("closes only 15 % of the gap"), std::string::npos);
  // just over half closed passes the gap rule, just under does not
  c.rms_train = std::sqrt(1.0 + 0.49 * 0.49 * (3.0 * 3.0 - 1.0));
  EXPECT_NE(judge(c, none, taken, rules).failed, Rule::gap);
  c.rms_train = std::sqrt(1.0 + 0.51 * 0.51 * (3.0 * 3.0 - 1.0));
  EXPECT_EQ(judge(c, none, taken, rules).failed, Rule::gap);
}

TEST(Naming, ABaselineWithinTheNoiseLeavesNoGapToClose)
{
  const FitScores quiet{"none", 1000.0, 0.9, 1.0};
  auto            c = good();
  c.rms_train       = 0.8;
  c.rms_heldout     = 0.95;
  const auto j      = judge(c, quiet, taken, rules);
  EXPECT_EQ(j.failed, Rule::gap);
  EXPECT_EQ(j.closed, 0.0);
}

TEST(Naming, TooLittleOfTheDominantFeatureIsANearMiss)
{
  FeatureScores f{"strain", "falling", 4.0, 3.0}; // gap 3.87 -> 2.83: more than half left
  const auto    j = judge(good(), none, [&] { return f; }, rules);
  EXPECT_EQ(j.failed, Rule::feature);
  EXPECT_TRUE(j.near());
  EXPECT_EQ(rule_name(j.failed), "feature");
  EXPECT_NE(describe(j, good(), none, rules).find("(strain, falling half: 4 -> 3 noise units"), std::string::npos);
  // just under half of the feature's gap left is enough
  f.after = std::sqrt(1.0 + 0.49 * 0.49 * (4.0 * 4.0 - 1.0));
  EXPECT_TRUE(judge(good(), none, [&] { return f; }, rules).named());
  // a feature already within the noise cannot be explained further: named
  EXPECT_TRUE(judge(good(), none, [] { return FeatureScores{"strain", "rising", 0.9, 0.95}; }, rules).named());
}

TEST(Naming, TheRulesReadTheirThresholds)
{
  const NamingRules strict{150.0, 0.9};
  EXPECT_EQ(judge(good(), none, taken, strict).failed, Rule::evidence); // 100 better, 150 asked
  const NamingRules gap_only{10.0, 0.9};
  EXPECT_EQ(judge(good(), none, taken, gap_only).failed, Rule::gap); // 77 % closed, 90 % asked
}

TEST(Verdict, NamedOrNotAgainstTheFloor)
{
  EXPECT_EQ(verdict_of(true, 1.4, 2.0), Verdict::explained);
  EXPECT_EQ(verdict_of(true, 2.0, 2.0), Verdict::explained);
  EXPECT_EQ(verdict_of(true, 2.1, 2.0), Verdict::partly_explained);
  EXPECT_EQ(verdict_of(false, 1.9, 2.0), Verdict::no_missing_effect);
  EXPECT_EQ(verdict_of(false, 2.5, 2.0), Verdict::beyond_library);
  const double nan = std::numeric_limits<double>::quiet_NaN(); // a residual that could not be computed
  EXPECT_EQ(verdict_of(true, nan, 2.0), Verdict::partly_explained);
  EXPECT_EQ(verdict_of(false, nan, 2.0), Verdict::beyond_library);
  EXPECT_EQ(to_string(Verdict::explained), "explained");
  EXPECT_EQ(to_string(Verdict::partly_explained), "partly explained");
  EXPECT_EQ(to_string(Verdict::no_missing_effect), "no missing effect");
  EXPECT_EQ(to_string(Verdict::beyond_library), "beyond the library");
}

TEST(Verdict, TheExplainedShareIsOfTheGapAboveTheNoise)
{
  EXPECT_NEAR(explained_fraction(3.0, 1.0), 1.0, 1e-15);                   // all of it
  EXPECT_NEAR(explained_fraction(3.0, 2.0), 1.0 - gap(2.0) / gap(3.0), 1e-15); // sqrt(3) of sqrt(8)
  EXPECT_EQ(explained_fraction(3.0, 4.0), 0.0);                             // worse: none, not negative
  EXPECT_EQ(explained_fraction(0.9, 0.8), 0.0);                             // no gap to close
  const auto s = verdict_sentence(Verdict::partly_explained, "valve_leakage", 3.0, 2.5, 2.0,
                                  explained_fraction(3.0, 2.5), "the outlet pressure's rising half");
  EXPECT_NE(s.find("valve_leakage explains 19 % of the gap"), std::string::npos) << s;
  EXPECT_NE(s.find("Largest remaining residual: the outlet pressure's rising half"), std::string::npos) << s;
}

// A round's decision in words (words.h) from its judging steps, on a
// constructed round: each step's sentence in turn, none named.
TEST(Words, TheDecisionTellsEachJudgingStepInTurn)
{
  using Kind = RoundResult::JudgingStep::Kind;
  RoundResult rr;
  rr.rules        = rules;
  rr.none_restart = {"valve_leakage", 1000.0, 990.0, 3.0, 2.9, true};
  FitScores weak  = good();
  weak.rms_train  = 2.9; // closes little of the gap
  const auto near = judge(weak, none, [] { return taken(); }, rules);
  ASSERT_EQ(near.failed, Rule::gap);
  rr.near_miss.effect    = "valve_leakage";
  rr.near_miss.judgement = near;
  rr.near_miss.candidate = weak;
  rr.near_miss.baseline  = none;
  BaselineParameter inertance;
  inertance.name  = "lines.outlet_inertance_Pa_s2_per_m3";
  inertance.tried = LeftOutTry{LeftOutTry::Outcome::no_better, 4, 2.9, 0, 1001, 1000};
  rr.near_miss.at_none = {inertance};
  rr.judging = {{Kind::none_refitted},
                {Kind::judged, near, weak, none},
                {Kind::nearest_miss_tried, {}, {}, {}, false}};
  const std::string d = decision_words(rr);
  EXPECT_EQ(d.rfind("no significant missing effect: none refitted from valve_leakage's baseline: BIC 990 against "
                    "1000 from the case's (training RMS 2.9 against 3 noise units), kept: every candidate is judged "
                    "against it. valve_leakage: closes only ",
                    0),
            0u)
    << d;
  EXPECT_NE(d.find("Then the parameters the case leaves out, tried on at none's fit and at valve_leakage, the nearest "
                   "miss (" +
                   std::to_string(static_cast<int>(std::round(100 * near.closed))) +
                   " % of the gap closed): at none's, lines.outlet_inertance_Pa_s2_per_m3 a fit with it, from 4 points along "
                   "its range, scored no better (BIC 1001 against 1000); off, as the case has it; at "
                   "valve_leakage's, nothing to try (its effect sets it): nothing changed. "),
            std::string::npos)
    << d;
  EXPECT_EQ(near_miss_reason(rr), describe(near, weak, none, rules));
  EXPECT_EQ(set_by_effect_reason(rr), ""); // no effect set one
  // the same steps with the try turned something on, then the fits without them standing
  rr.judging.back().changed = true;
  rr.judging.push_back({Kind::judged, near, weak, none});
  rr.judging.push_back({Kind::fits_without_stand});
  const std::string again = decision_words(rr);
  EXPECT_NE(again.find("nothing to try (its effect sets it); judged again: valve_leakage: closes only"), std::string::npos)
    << again;
  EXPECT_TRUE(again.ends_with("The fits without them stand. ")) << again;
  EXPECT_EQ(signature_words(rr), "");

  // named: against none and the next best, with its feature
  rr.effect              = "valve_leakage";
  rr.named               = {100.0, 1.5, 3.2, "orifice_flow", 42.0};
  rr.signature_explained = true;
  rr.feature             = taken();
  EXPECT_EQ(decision_words(rr), "valve_leakage: BIC better than none by 100.0, held-out RMS 1.5 vs none's 3.2, next "
                                "best orifice_flow by 42.0; dominant residual feature (outlet_pressure_Pa, rising "
                                "half) 4 -> 1.25 noise units");
  rr.near_miss.named = true;
  EXPECT_NE(decision_words(rr).find("(it was the nearest miss without them: it closed too little of the gap)"),
            std::string::npos);
}

TEST(Words, TheParametersSayWhatTheRecordDeterminesAndWhatNot)
{
  RoundResult rr;
  EXPECT_EQ(uncertainty_words(rr), ""); // nothing named: nothing to say
  ParameterUncertainty p;
  p.key              = "leak_resistance_Pa_s_per_m3";
  p.value            = 2.5e11;
  p.relative_sd      = 0.031;
  p.profile_step     = 0.2;
  p.evidence_needed  = 10;
  p.profile_tried    = {true, true};
  p.profile_evidence = {41.6, 52.0};
  rr.uncertainty     = {p};
  EXPECT_EQ(uncertainty_words(rr), "leak_resistance_Pa_s_per_m3 = 2.5e+11, standard error 3.1 % (from its profile); "
                                   "20 % either way with the baseline's uncertain parameters refitted fits worse "
                                   "(evidence 42 and 52)");
  // the upper side fits as well: not determined, and with what it trades
  p.determined          = false;
  p.profile_determined  = false;
  p.profile_value[1]    = 3.0e11;
  p.profile_rms         = {3.2, 1.25};
  p.profile_evidence[1] = 4.0;
  p.rms_at_fit          = 1.2;
  p.correlated_with     = "[piston] area_m2";
  p.correlation         = -0.93;
  rr.uncertainty        = {p};
  rr.combined           = CombinedEstimate{"high-side compliance", "the seal's and the oil's", 1e-13, 0.02, true};
  rr.profile_moves      = {{{"value", 2.4e11}, {"training_residual", 1.3}, {"evidence", -12.0}}};
  EXPECT_EQ(uncertainty_words(rr),
            "the fit moved along its profile 1 time(s) to a side that fitted better (the last at 2.4e+11, evidence "
            "-12.0) and was refitted there; leak_resistance_Pa_s_per_m3 = 2.5e+11 is not determined by the record to "
            "20 %: leak_resistance_Pa_s_per_m3 at 3e+11 (higher) with the baseline refitted fits as well (training "
            "residual 1.25 noise units against 1.2; evidence 4.0, 10 needed); it trades with [piston] area_m2 "
            "(correlation -0.93); the record determines high-side compliance = 1e-13, standard error 2 % (local; the "
            "seal's and the oil's)");
  // a failure says so, whatever was computed before it
  rr.uncertainty_error = "a side's refit diverged";
  EXPECT_EQ(uncertainty_words(rr), "the parameters' standard errors could not be computed: a side's refit diverged");
}

TEST(Words, ABaselineParametersStandingIsSaidFromWhatTheChecksFound)
{
  BaselineParameter b;
  b.name  = "pump.free_air_fraction";
  b.value = 0.01;
  EXPECT_EQ(standing_words(b), ""); // free, uncorrelated, inside its range
  b.correlation     = -0.953;
  b.correlated_with = "lines.oil_bulk_modulus_Pa";
  EXPECT_EQ(standing_words(b), "correlated -0.953 with lines.oil_bulk_modulus_Pa");
  b.held_undetermined = true;
  b.sd_unit           = 0.42;
  EXPECT_EQ(standing_words(b), "held at the case's value: standard error 0.42 of its range, correlated -0.953 with "
                               "lines.oil_bulk_modulus_Pa");
  b.held_undetermined = false;
  b.correlation       = 0;
  b.at_end            = 1;
  EXPECT_EQ(standing_words(b), "at the upper end of its range: the data ask for a value beyond it (a missing effect "
                               "can pull it there, or the range is too narrow)");
  b.value = 0; // off is not an end the data push against
  EXPECT_EQ(standing_words(b), "off, as the case has it");

  BaselineParameter left;
  left.left_out = true;
  EXPECT_EQ(standing_words(left), "left out until an effect is named, then tried on with it; off, as the case has it");
  BaselineParameter inert;
  inert.value = 0.5;
  inert.inert = "coulomb_friction_N = 0";
  EXPECT_EQ(standing_words(inert), "held at the case's value: coulomb_friction_N = 0; freed with a named effect that "
                                   "makes it act, where the data determine it");

  BaselineParameter tried;
  using Outcome = LeftOutTry::Outcome;
  tried.tried   = LeftOutTry{Outcome::not_tried, 0, 0.87, 0, 0, 0};
  EXPECT_EQ(standing_words(tried), "not tried: the named fit leaves no gap above the noise (training RMS 0.87 noise "
                                   "units); off, as the case has it");
  tried.tried = LeftOutTry{Outcome::failed, 4, 3, 0, 0, 0};
  EXPECT_EQ(standing_words(tried), "every fit with it, from 4 points along its range, failed; off, as the case has it");
  tried.value = 2.4e8;
  tried.tried = LeftOutTry{Outcome::on, 4, 3, 3.75e8, 1234.5678, 1300};
  EXPECT_EQ(standing_words(tried), "tried on from 4 points along its range, the best from 3.75e+08: BIC 1234.57 "
                                   "against 1300 off");
}

TEST(Words, ARunsSettlingBandAndRevisedStartAreSaidFromTheirReasons)
{
  using Why = RunCase::Settling::Why;
  RunCase rc;
  EXPECT_EQ(settling_words(rc), "");
  EXPECT_EQ(band_words(rc), "");
  EXPECT_EQ(start_revision_words(rc), "");
  rc.settling = {Why::rest_exact};
  EXPECT_EQ(settling_words(rc), "none: a start at rest is exact");
  rc.settling = {Why::few_cycles};
  EXPECT_EQ(settling_words(rc),
            "one cycle (the model's memory of its start not measured: fewer than two training cycles)");
  rc.settling = {Why::settled, StartState::periodic, StartState::record, 3, 2.5, 0, 0, 0.1};
  EXPECT_EQ(settling_words(rc), "3 cycles: the model's runs from the periodic start and from the record one differ "
                                "by at most 0.1 noise units per cycle from then on (2.5 in the first)");
  rc.settling.cycles = 1;
  EXPECT_NE(settling_words(rc).find("1 cycle: "), std::string::npos) << settling_words(rc);
  rc.settling = {Why::meets_later, StartState::record, StartState::periodic, 4, 0.31};
  EXPECT_EQ(settling_words(rc), "4 cycles, half the training part: the model's runs from the record start and from "
                                "the periodic one meet later (0.31 noise units apart in cycle 5)");
  rc.settling = {Why::orbits_apart, StartState::record, StartState::periodic, 0, 0, 12.5, 40};
  EXPECT_EQ(settling_words(rc), "one cycle: the model's runs from the record start and from the periodic one do not "
                                "meet within the training part, nor come half-way together (12.5 noise units apart "
                                "in its last cycle, 40 at most)");
  rc.band_why = RunCase::BandWhy::below_reed;
  rc.reed_Hz  = 1849.6;
  EXPECT_EQ(band_words(rc), "below half the reed's natural frequency (1850 Hz): the valves flutter there in a loaded "
                            "run");
  rc.start_revisions.push_back({StartState::rest, StartState::record, "valve_leakage"});
  rc.start_revisions.push_back({StartState::record, StartState::periodic, "line_inertance"});
  EXPECT_EQ(start_revision_words(rc),
            "rest with the case's baseline, record with valve_leakage's fit, periodic with line_inertance's fit");
}
