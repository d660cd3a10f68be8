#include "common/fluid.h"

namespace rectify
{
  namespace
  {
    const Bounds positive = Bounds::positive();
  } // namespace

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
    p.density_kg_per_m3 = f.real(t, "density_kg_per_m3", p.density_kg_per_m3, positive);
    p.viscosity_Pa_s    = f.real(t, "viscosity_Pa_s", p.viscosity_Pa_s, positive);
    p.bulk_modulus_Pa   = f.real(t, "bulk_modulus_Pa", p.bulk_modulus_Pa, positive);
    p.entrained_air_fraction =
      f.real(t, "entrained_air_fraction", p.entrained_air_fraction, Bounds{0.0, 1.0, true, false});
    p.gas_heat_capacity_ratio =
      f.real(t, "gas_heat_capacity_ratio", p.gas_heat_capacity_ratio, Bounds::closed(1.0, 5.0 / 3.0));
    p.bias_pressure_Pa = f.real(t, "bias_pressure_Pa", p.bias_pressure_Pa, positive);
    p.free_air_fraction =
      f.real(t, "free_air_fraction", p.free_air_fraction, Bounds{0.0, 0.5, true, true});
    p.free_air_law = f.text(t, "free_air_law", p.free_air_law, {"polytropic", "constant-modulus"});
    p.cavitation   = f.text(t, "cavitation", p.cavitation, {"discrete-cavity", "none"});
    p.cavitation_pressure_Pa =
      f.real(t, "cavitation_pressure_Pa", p.cavitation_pressure_Pa, Bounds::non_negative());
    if (!(p.cavitation_pressure_Pa < p.bias_pressure_Pa))
      throw InputError(f.where(t, "cavitation_pressure_Pa") + " = " + format_number(p.cavitation_pressure_Pa) +
                       ": at or above the bias pressure (bias_pressure_Pa = " + format_number(p.bias_pressure_Pa) +
                       "): the oil would cavitate at rest; a cavitation pressure is an absolute pressure far "
                       "below the bias");
    return p;
  }

} // namespace rectify
