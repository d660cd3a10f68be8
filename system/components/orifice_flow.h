// orifice_flow: an open reed valve as an orifice as well as a resistance:
// an extra drop rho q|q| / (2 Cd^2 A^2) through it, A = P x the tip opening
// (the curtain area; [valves] orifice_discharge_coefficient Cd and
// orifice_perimeter_m P, by default the circumference of a round port of
// the reed's pressure area A_r).
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>

#include "system/component.h"
#include "system/model.h"

namespace rectify::system
{
  class OrificeFlow : public Component
  {
  public:
    /// rho / (2 Cd^2 P^2): the drop's K is this over the opening squared.
    explicit OrificeFlow(double factor)
      : factor_(factor)
    {}
    static std::shared_ptr<const Component> make(const SystemParameters &p, Scenario, const ModelConstants &)
    {
      const double Cd = p.valves.orifice_discharge_coefficient;
      if (!(Cd > 0))
        return nullptr;
      const double P = p.valves.orifice_perimeter_m > 0 ?
                         p.valves.orifice_perimeter_m :
                         std::sqrt(4.0 * M_PI * p.reed.pressure_area_m2); // pi d, pi d^2/4 = A_r
      return std::make_shared<OrificeFlow>(p.fluid.density_kg_per_m3 / (2.0 * Cd * Cd * P * P));
    }

    std::string_view name() const override { return "orifice_flow"; }
    void add_to_branch(std::size_t, std::optional<double> opening, BranchLaw &law) const override
    {
      if (!opening)
        return;
      const double x = std::max(*opening, 1e-9);
      law.series_K += factor_ / (x * x);
    }

  private:
    double factor_;
  };
} // namespace rectify::system
