// outlet_compliance: an extra compliance on the high (outlet) side, a soft
// seal or a hose ([cylinder] seal_compliance_m3_per_Pa): added to the high
// side's oil compliance C_h, wherever the model reads it (its pressure's
// equation, its stored volume, its cavity, the outlet line's ringing).
#pragma once

#include <memory>

#include "system/component.h"
#include "system/model.h"

namespace rectify::system
{
  class OutletCompliance : public Component
  {
  public:
    explicit OutletCompliance(double compliance_m3_per_Pa)
      : C_seal_(compliance_m3_per_Pa)
    {}
    static std::shared_ptr<const Component> make(const SystemParameters &p, Scenario, const ModelConstants &)
    {
      const double C = p.cylinder.seal_compliance_m3_per_Pa;
      return C > 0 ? std::make_shared<OutletCompliance>(C) : nullptr;
    }

    std::string_view name() const override { return "outlet_compliance"; }
    void adjust(ModelConstants &c) const override { c.C_h += C_seal_; }

  private:
    double C_seal_;
  };
} // namespace rectify::system
