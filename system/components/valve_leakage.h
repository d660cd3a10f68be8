// valve_leakage: a laminar leak path past each valve, a resistance in
// parallel with the valve, open or shut ([valves] leak_resistance_Pa_s_per_m3).
#pragma once

#include <memory>

#include "system/component.h"
#include "system/model.h"

namespace rectify::system
{
  class ValveLeakage : public Component
  {
  public:
    explicit ValveLeakage(double resistance_Pa_s_per_m3)
      : R_leak_(resistance_Pa_s_per_m3)
    {}
    static std::shared_ptr<const Component> make(const SystemParameters &p, Scenario, const ModelConstants &)
    {
      const double R = p.valves.leak_resistance_Pa_s_per_m3;
      return R > 0 ? std::make_shared<ValveLeakage>(R) : nullptr;
    }

    std::string_view name() const override { return "valve_leakage"; }
    void add_to_branch(std::size_t, std::optional<double>, BranchLaw &law) const override
    {
      law.leak_resistance = R_leak_;
    }

  private:
    double R_leak_;
  };
} // namespace rectify::system
