// coil_dynamics: a voltage-driven coil as resistance and inductance in
// series, L dI/dt = V - R I ([drive] coil_dynamics = "on", [transducer]
// coil_resistance_ohm and coil_inductance_H), instead of the resistor
// I = V / R between the drive's voltage and the rod's force. Its state is
// the coil current; a current drive leaves it without work.
#pragma once

#include <memory>

#include "system/component.h"
#include "system/drive.h"
#include "system/model.h"

namespace rectify::system
{
  class CoilDynamics : public Component
  {
  public:
    explicit CoilDynamics(const TransducerParameters &t)
      : R_(t.coil_resistance_ohm)
      , L_(t.coil_inductance_H)
    {}
    static std::shared_ptr<const Component> make(const SystemParameters &p, Scenario, const ModelConstants &)
    {
      return p.drive.coil_dynamics == "on" ? std::make_shared<CoilDynamics>(p.transducer) : nullptr;
    }

    std::string_view name() const override { return "coil_dynamics"; }
    bool acts(const Drive &drive) const override { return drive.is_voltage(); }
    std::optional<double> current(double, std::span<const double> y, const Drive &) const override
    {
      return y[state::coil_current];
    }
    /// At rest: the steady coil, V(0) / R.
    void initial_state(std::span<double> y, const Drive &drive) const override
    {
      y[state::coil_current] = drive.value(0.0) / R_;
    }
    void own_rhs(double t, std::span<const double> y, const Model &model, const Flows &,
                 std::span<double> ydot) const override
    {
      ydot[state::coil_current] = (model.drive().value(t) - R_ * y[state::coil_current]) / L_;
    }
    void own_reads(std::vector<std::vector<std::size_t>> &r, const std::vector<std::size_t> &) const override
    {
      r[state::piston_v].push_back(state::coil_current); // the rod's force
      r[state::coil_current] = {state::coil_current};
    }

    double resistance_ohm() const { return R_; }
    double inductance_H() const { return L_; }

  private:
    double R_, L_;
  };
} // namespace rectify::system
