// The reed's material: case table [reed_material]. Shared by the stiffness
// solver (which uses its elastic constants), the map sets (which record
// those, so that a map set made for another material is refused) and the
// system model (which judges the reed's root stress against its fatigue
// data: a Goodman diagram).
#pragma once

#include "common/case_file.h"
#include "common/real_keys.h"

namespace rectify
{
  struct ReedMaterial
  {
    double youngs_modulus_Pa = 200e9;  ///< 304 stainless steel (thesis Table 3.1)
    double poisson_ratio     = 0.29;   ///< not in the thesis; typical of 304
    double density_kg_per_m3 = 8000.0; ///< thesis Table 3.1
    /// Fatigue data, for the reed's Goodman factor (not the maps': a map set
    /// made for another endurance limit is still this reed's). Annealed
    /// 304: endurance limit (fully reversed bending, 1e7-1e8 cycles) about
    /// 240 MPa, ultimate tensile strength 515 MPa (ASTM A240 minimum);
    /// docs/stress.md gives the sources and a valve steel's values.
    double endurance_limit_Pa   = 240e6;
    double ultimate_strength_Pa = 515e6;
    /// Goodman's safety factor of a stress cycling between mean +- amplitude:
    /// 1 / (amplitude / endurance + mean / ultimate); infinite at rest.
    double goodman_factor(double mean_Pa, double amplitude_Pa) const;
    static ReedMaterial from_case(const CaseFile &file);
  };
  /// [reed_material]'s keys (none among those [uncertain] may name).
  const RealKeys<ReedMaterial> &material_keys();
} // namespace rectify
