// The library of candidate effects: each a named, physically parameterised
// extension of the system model with bounds. An effect is one file in
// effects/ defining a `make_<name>()` function, plus one line in
// registry.cpp. Its physics lives in system/ (case-file keys, and a
// component of the model, system/component.h, of the same name); the
// effect says which keys a fit sets. docs/adding-an-effect.md walks through one.
#pragma once

#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "system/model.h"
#include "system/parameters.h"

namespace rectify::diagnosis
{
  /// One physical parameter of an effect: its case-file key, unit and bounds.
  struct EffectParameter
  {
    std::string table;       ///< case-file table, e.g. "valves"
    std::string key;         ///< case-file key with its unit, e.g. "leak_resistance_Pa_s_per_m3"
    double      lower = 0, upper = 0; ///< physical bounds of the fit
    bool        log_scale = true;     ///< fitted in log(value): bounds span decades
    std::string meaning;              ///< one line for reports
    /// Start grid over this parameter (0: the workflow's, 9 points).
    int grid_points = 0;
    /// For a parameter that sets a lightly damped ringing: the frequency
    /// [Hz] the model rings at for a value of the parameter (with the other
    /// parameters `p`), decreasing in the value. The residual's dependence
    /// on such a parameter is a comb of basins a few per cent wide (the
    /// ringing's phase), which no coarse grid finds: the workflow starts
    /// from the ringing frequency it measures in the residual (diagnose.cpp).
    std::function<double(double value, const system::SystemParameters &p)> ringing_Hz = nullptr;

    /// The middle of the bounds (geometric for log_scale): synth's default.
    double mid() const;
    /// value <-> position in [0, 1] over the bounds (log or linear).
    double to_unit(double value) const;
    double from_unit(double u) const;
  };

  /// What a run must offer for an effect to be tested on it.
  struct RunTraits
  {
    system::Scenario scenario     = system::Scenario::no_flow;
    bool             voltage_drive = false;
  };

  class Effect
  {
  public:
    using Apply = std::function<void(std::span<const double>, system::SystemParameters &)>;

    /// A key the effect sets to a fixed value (table, key, TOML value).
    struct FixedKey
    {
      std::string table, key, value;
    };

    /// A quantity a record can determine where the effect's parameter alone
    /// is traded against a baseline parameter of the same physics: the
    /// seal's compliance and the oil column's add up to the high side's.
    /// The diagnosis reports it with its standard error beside the
    /// parameter's (diagnose.h, CombinedEstimate).
    struct Combination
    {
      std::string name;    ///< with its unit, e.g. "high_side_compliance_m3_per_Pa"
      std::string meaning; ///< one line for reports
      std::function<double(const system::SystemParameters &)> value;
    };

    Effect(std::string name, std::string physics, std::string signature,
           std::vector<EffectParameter> parameters, Apply apply,
           std::vector<FixedKey> fixed_keys = {}, Combination combination = {});
    virtual ~Effect() = default;

    const std::string                  &name() const { return name_; }
    /// The physics in one or two sentences (reports, docs/diagnosis.md).
    const std::string                  &physics() const { return physics_; }
    /// The residual signature the effect should explain, in words.
    const std::string                  &signature() const { return signature_; }
    const std::vector<EffectParameter> &parameters() const { return parameters_; }
    /// Keys set to fixed values besides the parameters (for the case file).
    const std::vector<FixedKey>        &fixed_keys() const { return fixed_keys_; }
    /// The combined quantity, or null when the effect declares none.
    const Combination *combination() const { return combination_.value ? &combination_ : nullptr; }
    /// Whether one of its parameters is [table] key (an [uncertain] baseline
    /// parameter it then supersedes).
    bool sets(const std::string &table, const std::string &key) const;
    /// Sets the effect's keys in `p` to `values` (one per parameter).
    void apply(std::span<const double> values, system::SystemParameters &p) const;
    /// Empty if the effect can show in runs like `traits`, else why not
    /// (friction on an output piston that a no-flow run holds still).
    virtual std::string not_testable(const RunTraits &traits) const;

  private:
    std::string                  name_, physics_, signature_;
    std::vector<EffectParameter> parameters_;
    Apply                        apply_;
    std::vector<FixedKey>        fixed_keys_;
    Combination                  combination_;
  };

  /// Why [table] key does nothing in the model the parameters p make, or ""
  /// where it acts: the friction's shape without friction ([load]
  /// coulomb_friction_N = 0), the Stribeck velocity without a Stribeck rise
  /// (static_friction_ratio = 1). A diagnosis holds such an [uncertain]
  /// parameter out of its fits until it acts.
  std::string inert_reason(const system::SystemParameters &p, const std::string &table, const std::string &key);

  /// Every effect of the library, in report order ("none" is not one of them).
  const std::vector<std::shared_ptr<const Effect>> &effect_library();
  /// The effect called `name`; InputError listing the names if there is none.
  std::shared_ptr<const Effect> find_effect(const std::string &name);
  /// The library's names, "a, b, ..." for messages.
  std::string effect_names();
} // namespace rectify::diagnosis
