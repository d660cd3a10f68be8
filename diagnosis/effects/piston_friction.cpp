// piston_friction: friction of the output piston's seals (Coulomb's, with a Stribeck rise).
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  namespace
  {
    class PistonFriction : public Effect
    {
    public:
      using Effect::Effect;
      std::string not_testable(const RunTraits &traits) const override
      {
        return traits.scenario == system::Scenario::loaded ?
                 "" :
                 "in a no-flow run the output piston is held: its friction does nothing";
      }
    };
  } // namespace

  std::shared_ptr<const Effect> make_piston_friction()
  {
    return std::make_shared<PistonFriction>(
      "piston_friction",
      "friction on the output piston, F_c [1 + (r - 1) exp(-(v / v_st)^2)] tanh(v / v_s): Coulomb's, with a "
      "Stribeck rise to r F_c at low speed; the shape from [load] (friction_velocity_scale_m_per_s, "
      "static_friction_ratio, stribeck_velocity_m_per_s; declared [uncertain], they are freed at its named fit "
      "where the data determine them)",
      "the loaded actuator moves slower by a constant force's worth, F_c / A_po of pressure "
      "difference; the outlet pressure sits higher",
      // 12 grid points: 0.33 decade apart, as 9 were over the former 0.1..100
      std::vector<EffectParameter>{{"load", "coulomb_friction_N", 0.01, 100.0, true,
                                    "Coulomb friction force on the output piston", 12}},
      [](std::span<const double> v, system::SystemParameters &p) {
        p.load.coulomb_friction_N = v[0];
      });
  }
} // namespace rectify::diagnosis
