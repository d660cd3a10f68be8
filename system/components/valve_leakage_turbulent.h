// valve_leakage_turbulent: a turbulent leak past each valve, an orifice of
// effective area A_L (Cd x area, [valves] leak_area_m2) in parallel with the
// valve, open or shut: its drop is K q|q|, K = rho / (2 A_L^2) (laminar
// below about 1 kPa: the model's turbulent_leak_flow).
#pragma once

#include <memory>

#include "system/component.h"
#include "system/model.h"

namespace rectify::system
{
  class ValveLeakageTurbulent : public Component
  {
  public:
    ValveLeakageTurbulent(double area_m2, double density_kg_per_m3)
      : K_leak_(density_kg_per_m3 / (2.0 * area_m2 * area_m2))
    {}
    static std::shared_ptr<const Component> make(const SystemParameters &p, Scenario, const ModelConstants &)
    {
      const double A = p.valves.leak_area_m2;
      return A > 0 ? std::make_shared<ValveLeakageTurbulent>(A, p.fluid.density_kg_per_m3) : nullptr;
    }

    std::string_view name() const override { return "valve_leakage_turbulent"; }
    void add_to_branch(std::size_t, std::optional<double>, BranchLaw &law) const override { law.leak_K = K_leak_; }
    /// rho / (2 A_L^2) [Pa s^2/m^6]
    double drop_coefficient() const { return K_leak_; }

  private:
    double K_leak_;
  };
} // namespace rectify::system
