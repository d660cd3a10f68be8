// The working fluid (thesis Table A.1, Mobil DTE 25), shared by every stage:
// density and viscosity for the flow and added-mass calculations, bulk
// modulus and entrained air (eqs. 3.22-3.26) for the lumped model.
#pragma once

#include <string>

#include "common/case_file.h"
#include "common/real_keys.h"

namespace rectify
{
  struct FluidParameters
  {
    double density_kg_per_m3       = 873.0;
    double viscosity_Pa_s          = 0.0386;
    double bulk_modulus_Pa         = 85.0 * 6.894757e6; ///< Table A.1 beta_eff, 85 ksi
    double entrained_air_fraction  = 0.0;               ///< alpha in eq. 3.26
    double gas_heat_capacity_ratio = 1.4;               ///< gamma in eq. 3.25
    double bias_pressure_Pa        = 2.582e6;           ///< see reference.toml
    /// Free (undissolved) air: gas volume per oil volume at the bias
    /// pressure, compressed with the local pressure, so the oil's compliance
    /// depends on pressure (the model's component system/components/free_air.h,
    /// the diagnosis effect `entrained_air`). 0: none. Unlike
    /// entrained_air_fraction, which eq. 3.26 folds into one constant bulk
    /// modulus at the bias pressure.
    double free_air_fraction       = 0.0;
    /// How free air's volume follows pressure: "polytropic" (the gas law,
    /// V ~ p^(-1/gamma): soft at low pressure) or "constant-modulus" (a
    /// fixed bulk modulus gamma p_bias: the form of eq. 3.26 at the bias).
    std::string free_air_law       = "polytropic";
    /// Cavitation in the lumped model's oil volumes (system/cavitation.h):
    /// "discrete-cavity", a volume's absolute pressure cannot fall below
    /// cavitation_pressure_Pa: a cavity opens there and takes up what the
    /// volume loses, and closes when it is filled again (the discrete
    /// vapour cavity model of water-hammer practice, lumped); "none": the
    /// thesis's model, pressures unbounded below.
    std::string cavitation         = "discrete-cavity";
    /// Absolute pressure at which a cavity opens [Pa]: the oil's
    /// gas-release pressure (air saturated at 1 atm comes out of solution
    /// below it; mineral oil's vapour pressure is far lower, about 10 Pa).
    double cavitation_pressure_Pa  = 1.0e5;
    bool   cavitates() const { return cavitation == "discrete-cavity"; }

    /// eq. 3.26 with beta_gas = gamma p_bias (eq. 3.25).
    double effective_bulk_modulus_Pa() const;
    static FluidParameters from_case(const CaseFile &file);
  };

  /// [fluid]'s real keys (the gas-release pressure not among those
  /// [uncertain] may name).
  const RealKeys<FluidParameters> &fluid_keys();

} // namespace rectify
