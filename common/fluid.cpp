#include "common/fluid.h"

namespace rectify
{
  namespace
  {
    const Bounds positive = Bounds::positive();
  } // namespace

  const RealKeys<FluidParameters> &fluid_keys()
  {
    using T = FluidParameters;
    static const RealKeys<T> keys{
      {"density_kg_per_m3", &T::density_kg_per_m3, positive},
      {"viscosity_Pa_s", &T::viscosity_Pa_s, positive},
      {"bulk_modulus_Pa", &T::bulk_modulus_Pa, positive},
      {"entrained_air_fraction", &T::entrained_air_fraction, Bounds{0.0, 1.0, true, false}},
      {"gas_heat_capacity_ratio", &T::gas_heat_capacity_ratio, Bounds::closed(1.0, 5.0 / 3.0)},
      {"bias_pressure_Pa", &T::bias_pressure_Pa, positive},
      {"free_air_fraction", &T::free_air_fraction, Bounds{0.0, 0.5, true, true}},
      {"cavitation_pressure_Pa", &T::cavitation_pressure_Pa, Bounds::non_negative(), false}};
    return keys;
  }

  double FluidParameters::effective_bulk_modulus_Pa() const
  {
    const double gas_bulk_modulus = gas_heat_capacity_ratio * bias_pressure_Pa; // eq. 3.25
    return 1.0 / ((1.0 - entrained_air_fraction) / bulk_modulus_Pa +
                  entrained_air_fraction / gas_bulk_modulus); // eq. 3.26
  }

  FluidParameters FluidParameters::from_case(const CaseFile &f)
  {
    FluidParameters p;
    const std::string t = "fluid";
    read_reals(f, t, fluid_keys(), p);
    p.free_air_law = f.text(t, "free_air_law", p.free_air_law, {"polytropic", "constant-modulus"});
    p.cavitation   = f.text(t, "cavitation", p.cavitation, {"discrete-cavity", "none"});
    if (!(p.cavitation_pressure_Pa < p.bias_pressure_Pa))
      throw InputError(f.where(t, "cavitation_pressure_Pa") + " = " + format_number(p.cavitation_pressure_Pa) +
                       ": at or above the bias pressure (bias_pressure_Pa = " + format_number(p.bias_pressure_Pa) +
                       "): the oil would cavitate at rest; a cavitation pressure is an absolute pressure far "
                       "below the bias");
    return p;
  }

} // namespace rectify
