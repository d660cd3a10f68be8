// coil_dynamics: a voltage-driven coil's current lags its voltage through the
// coil's inductance, L dI/dt = V - R I.
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  namespace
  {
    class CoilDynamics : public Effect
    {
    public:
      using Effect::Effect;
      std::string not_testable(const RunTraits &traits) const override
      {
        return traits.voltage_drive ? "" :
                                      "the runs give the coil current, not the voltage: the coil's "
                                      "electrical dynamics are already in the measured drive";
      }
    };
  } // namespace

  std::shared_ptr<const Effect> make_coil_dynamics()
  {
    return std::make_shared<CoilDynamics>(
      "coil_dynamics",
      "the coil as resistance and inductance in series, L dI/dt = V - R I, instead of a "
      "resistor (I = V/R) between the measured voltage and the rod's force",
      "everything the drive moves lags and shrinks by the same first-order factor, more at "
      "higher frequency (corner R / (2 pi L))",
      std::vector<EffectParameter>{{"transducer", "coil_inductance_H", 1e-5, 1e-2, true,
                                    "coil inductance"}},
      [](std::span<const double> v, system::SystemParameters &p) {
        p.transducer.coil_inductance_H = v[0];
        p.drive.coil_dynamics          = "on";
      },
      std::vector<Effect::FixedKey>{{"drive", "coil_dynamics", "\"on\""}});
  }
} // namespace rectify::diagnosis
