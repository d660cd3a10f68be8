// The naming rules (diagnosis/naming.h) and the verdict (diagnosis/verdict.h)
// on constructed score tables: no model is run.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "diagnosis/naming.h"
#include "diagnosis/verdict.h"

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
