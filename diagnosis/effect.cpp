#include "diagnosis/effect.h"

#include <algorithm>
#include <cmath>

#include "common/case_file.h"

namespace rectify::diagnosis
{
  double EffectParameter::mid() const
  {
    return log_scale ? std::sqrt(lower * upper) : 0.5 * (lower + upper);
  }

  double EffectParameter::to_unit(double value) const
  {
    return log_scale ? std::log(value / lower) / std::log(upper / lower) :
                       (value - lower) / (upper - lower);
  }

  double EffectParameter::from_unit(double u) const
  {
    // clamped: the power (or the sum) can round past a bound at u = 0 or 1
    return std::clamp(log_scale ? lower * std::pow(upper / lower, u) : lower + u * (upper - lower), lower, upper);
  }

  Effect::Effect(std::string name, std::string physics, std::string signature,
                 std::vector<EffectParameter> parameters, Apply apply,
                 std::vector<FixedKey> fixed_keys, Combination combination)
    : name_(std::move(name))
    , physics_(std::move(physics))
    , signature_(std::move(signature))
    , parameters_(std::move(parameters))
    , apply_(std::move(apply))
    , fixed_keys_(std::move(fixed_keys))
    , combination_(std::move(combination))
  {}

  void Effect::apply(std::span<const double> values, system::SystemParameters &p) const
  {
    if (values.size() != parameters_.size())
      throw std::logic_error("effect " + name_ + ": " + std::to_string(values.size()) +
                             " values for " + std::to_string(parameters_.size()) + " parameters");
    apply_(values, p);
  }

  bool Effect::sets(const std::string &table, const std::string &key) const
  {
    return std::any_of(parameters_.begin(), parameters_.end(),
                       [&](const EffectParameter &p) { return p.table == table && p.key == key; });
  }

  std::string Effect::not_testable(const RunTraits &) const { return {}; }

  std::shared_ptr<const Effect> find_effect(const std::string &name)
  {
    for (const auto &e : effect_library())
      if (e->name() == name)
        return e;
    throw InputError("unknown effect '" + name + "' (known: " + effect_names() + ")");
  }

  std::string effect_names()
  {
    std::string names;
    for (const auto &e : effect_library())
      names += (names.empty() ? "" : ", ") + e->name();
    return names;
  }
  std::string inert_reason(const system::SystemParameters &p, const std::string &table, const std::string &key)
  {
    if (table != "load")
      return "";
    const bool shape = key == "friction_velocity_scale_m_per_s" || key == "static_friction_ratio" ||
                       key == "stribeck_velocity_m_per_s";
    if (shape && !(p.load.coulomb_friction_N > 0))
      return "no piston friction in this model ([load] coulomb_friction_N = 0)";
    if (key == "stribeck_velocity_m_per_s" && !(p.load.static_friction_ratio > 1))
      return "no Stribeck rise in this model ([load] static_friction_ratio = 1)";
    return "";
  }

} // namespace rectify::diagnosis
