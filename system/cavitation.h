// Cavitation in a lumped oil volume: the discrete vapour cavity model of
// water-hammer practice (DVCM: Wylie & Streeter, "Fluid Transients in
// Systems", 1993, on column separation; Bergant, Simpson & Tijsseling, "Water hammer
// with column separation: a historical review", J. Fluids Struct. 22
// (2006) 135-171), applied to one lumped volume instead of a pipe's
// computational section. A volume whose absolute pressure falls to the
// cavitation pressure p_c holds it there; what it loses beyond that is
// taken up by a cavity, which closes (and the pressure rises again) when
// the volume has been filled back.
//
// The volume's state is psi, the pressure its oil would have without the
// cavity (its compliance C integrates the net inflow: C psi' = q_net, as
// without cavitation). Then
//   pressure       p     = max(psi, p_c),
//   cavity volume  V_cav = C(p_c) (p_c - psi)  where psi < p_c, else 0,
// which is the DVCM's pressure held at p_c with V_cav' = -q_net while the
// cavity is open, its volume balance closed by construction. The kink at
// psi = p_c is an event (the integrator restarts there), root functions below.
#pragma once

#include <algorithm>

namespace rectify::system
{
  /// The volume's pressure for its state psi.
  inline double cavity_pressure(double psi, double p_cavitation) { return std::max(psi, p_cavitation); }

  /// The cavity's volume for state psi, C_c the volume's compliance at p_c.
  inline double cavity_volume(double psi, double p_cavitation, double compliance_at_cavitation)
  {
    return psi < p_cavitation ? compliance_at_cavitation * (p_cavitation - psi) : 0.0;
  }

  /// Root function: crosses zero from above when a cavity opens (psi falls
  /// through p_c) or, while one is open, when it closes (psi rises through p_c).
  inline double cavity_root(bool cavitating, double psi, double p_cavitation)
  {
    return cavitating ? p_cavitation - psi : psi - p_cavitation;
  }
} // namespace rectify::system
