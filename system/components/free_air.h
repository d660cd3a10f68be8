// entrained_air / entrained_air_constant_modulus: free (undissolved) air in
// the oil ([fluid] free_air_fraction alpha, gas volume per oil volume at the
// bias pressure p_b), which makes each oil volume's compliance depend on its
// pressure. [fluid] free_air_law:
//   "polytropic"        the gas law V_gas ~ p^(-1/gamma), soft at low pressure:
//                       dV/dp per oil volume = alpha (p_b / p)^(1/gamma) / (gamma p)
//   "constant-modulus"  a fixed bulk modulus gamma p_b (eq. 3.26's form at the bias):
//                       alpha / (gamma p_b)
// p absolute, floored at 1 % of the bias (below it the discrete cavities
// take over, system/cavitation.h). Every volume of the model (chamber, high
// and low sides, the outlet line's nodes) holds it in proportion to its oil.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>

#include "system/component.h"
#include "system/model.h"

namespace rectify::system
{
  class FreeAir : public Component
  {
  public:
    explicit FreeAir(const FluidParameters &fluid)
      : alpha_(fluid.free_air_fraction)
      , gamma_(fluid.gas_heat_capacity_ratio)
      , p_bias_(fluid.bias_pressure_Pa)
      , constant_modulus_(fluid.free_air_law == "constant-modulus")
    {}
    /// On with a free-air fraction.
    static std::shared_ptr<const Component> make(const SystemParameters &p, Scenario, const ModelConstants &)
    {
      return p.fluid.free_air_fraction > 0 ? std::make_shared<FreeAir>(p.fluid) : nullptr;
    }

    std::string_view name() const override
    {
      return constant_modulus_ ? "entrained_air_constant_modulus" : "entrained_air";
    }

    double gas_compliance_per_volume(double p_gauge) const override
    {
      if (constant_modulus_)
        return alpha_ / (gamma_ * p_bias_);
      const double p = absolute(p_gauge);
      return alpha_ * std::pow(p_bias_ / p, 1.0 / gamma_) / (gamma_ * p);
    }
    /// alpha (1 - (p_b / p)^(1/gamma)), the integral of the compliance from
    /// the bias (alpha p_gauge / (gamma p_b) for the constant modulus).
    double gas_volume_change_per_volume(double p_gauge) const override
    {
      if (constant_modulus_)
        return alpha_ * p_gauge / (gamma_ * p_bias_);
      return alpha_ * (1.0 - std::pow(p_bias_ / absolute(p_gauge), 1.0 / gamma_));
    }

  private:
    double absolute(double p_gauge) const { return std::max(p_bias_ + p_gauge, 0.01 * p_bias_); }

    double alpha_, gamma_, p_bias_;
    bool   constant_modulus_;
  };
} // namespace rectify::system
