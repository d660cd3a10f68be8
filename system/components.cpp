// The model's components (system/component.h): one line each. Their order
// is the order the model sums their terms in.
#include "system/component.h"

#include "system/components/coil_dynamics.h"
#include "system/components/free_air.h"
#include "system/components/orifice_flow.h"
#include "system/components/outlet_compliance.h"
#include "system/components/piston_friction.h"
#include "system/components/valve_leakage.h"
#include "system/components/valve_leakage_turbulent.h"

namespace rectify::system
{
  Components make_components(const SystemParameters &p, Scenario scenario)
  {
    using Factory = std::shared_ptr<const Component> (*)(const SystemParameters &, Scenario);
    static constexpr Factory factories[] = {
      &FreeAir::make,
      &OutletCompliance::make,
      &ValveLeakage::make,
      &ValveLeakageTurbulent::make,
      &OrificeFlow::make,
      &CoilDynamics::make,
      &PistonFriction::make,
    };
    Components on;
    for (const Factory make : factories)
      if (auto c = make(p, scenario))
        on.push_back(std::move(c));
    return on;
  }
} // namespace rectify::system
