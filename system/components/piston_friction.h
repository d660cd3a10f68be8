// piston_friction: friction of the output piston's seals, Coulomb's with a
// Stribeck rise at low speed ([load] coulomb_friction_N and its shape keys):
//   F = F_c [1 + (r - 1) exp(-(v / v_st)^2)] tanh(v / v_s),
// r = F_s / F_c the breakaway force over the Coulomb force (1: Coulomb's
// alone), v_st the Stribeck velocity, v_s the smoothing velocity of the sign.
// It acts against the output piston's motion (eq. 3.8).
#pragma once

#include <cmath>
#include <memory>

#include "system/component.h"
#include "system/model.h"

namespace rectify::system
{
  class PistonFriction : public Component
  {
  public:
    explicit PistonFriction(const LoadParameters &load)
      : F_coulomb_(load.coulomb_friction_N)
      , v_friction_(load.friction_velocity_scale_m_per_s)
      , rise_(load.static_friction_ratio - 1.0)
      , v_stribeck_(load.stribeck_velocity_m_per_s)
    {}
    /// On with a Coulomb force.
    static std::shared_ptr<const Component> make(const SystemParameters &p, Scenario, const ModelConstants &)
    {
      return p.load.coulomb_friction_N > 0 ? std::make_shared<PistonFriction>(p.load) : nullptr;
    }

    std::string_view name() const override { return "piston_friction"; }
    double actuator_force(std::span<const double> y) const override { return force(y[state::actuator_v]); }

    /// The friction force at the piston's velocity v [N].
    double force(double v) const
    {
      const double rise = rise_ > 0 ? rise_ * std::exp(-(v / v_stribeck_) * (v / v_stribeck_)) : 0.0;
      return F_coulomb_ * (1.0 + rise) * std::tanh(v / v_friction_);
    }

  private:
    double F_coulomb_, v_friction_, rise_, v_stribeck_;
  };
} // namespace rectify::system
