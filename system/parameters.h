// Parameters of the lumped EHA model (thesis ch. 3, Table A.1), one struct per
// concern, each read and range-checked in one place (`from_case`). SI units;
// the unit is in every key. Defaults are the thesis's values, or, where it
// gives none, the choices documented in cases/reference.toml and
// docs/system-model.md.
#pragma once

#include <array>
#include <cmath>
#include <numbers>
#include <nlohmann/json.hpp>
#include <string>

#include "common/case_file.h"
#include "common/fluid.h"
#include "common/reed_material.h"
#include "common/valve_geometry.h"
#include "maps/map_set.h"

namespace rectify::system
{
  struct TransducerParameters
  {
    double rod_youngs_modulus_Pa             = 35e9;
    double rod_area_m2                       = 0.196 * 0.0254 * 0.0254;
    double rod_length_m                      = 4.5 * 0.0254;
    double diaphragm_stiffness_N_per_m       = 2.15e6;
    double effective_mass_kg                 = 0.124;
    double damping_ratio                     = 0.09;
    double coil_turns                        = 860;
    double piezomagnetic_coefficient_m_per_A = 6.85e-9;
    double coil_resistance_ohm               = 1.9;
    double coil_inductance_H                 = 1.30e-3;

    double rod_stiffness_N_per_m() const; ///< eq. 3.2
    double force_per_ampere_N_per_A() const; ///< eq. 3.1: N q k_td
    static TransducerParameters from_case(const CaseFile &file);
  };

  struct ChamberParameters
  {
    double height_m            = 0.05 * 0.0254;
    double piston_area_m2      = 0.785 * 0.0254 * 0.0254;
    double fluid_damping_ratio = 0.55;
    static ChamberParameters from_case(const CaseFile &file);
  };

  struct ReedParameters
  {
    double stiffness_N_per_m = 6650.0;
    double effective_mass_kg = 0.3643e-3;
    double damping_ratio     = 0.1285;
    double pressure_area_m2  = 0.0123 * 0.0254 * 0.0254;
    double restitution       = 0.0; ///< seat impact: rebound speed / impact speed
    /// A second bending mode (diagnosis effect `reed_second_mode`): natural
    /// frequency [Hz], 0 for none. Its modal mass (normalised to the tip) and
    /// damping ratio are the first mode's, as for a uniform cantilever; the
    /// tip opening is the sum of both modes.
    double second_mode_frequency_Hz = 0.0;
    /// The first mode's natural frequency sqrt(k_r / m_r) / 2 pi [Hz].
    double natural_frequency_Hz() const
    {
      return std::sqrt(stiffness_N_per_m / effective_mass_kg) / (2.0 * std::numbers::pi);
    }
    /// Where stiffness and mass came from: "case", or the reed map (written
    /// by `rectify map-stiffness`) read at a thickness.
    std::string source = "case";
    /// Which mass a reed map or a map set gives: "eq321" (the thesis's 2.75
    /// (m_plate + m_added)) or "modal-in-fluid" (the FE first mode in oil).
    std::string properties_mass = "eq321";
    /// The fluid's loading on the reed (docs/fluid-loading.md): "thesis",
    /// the constant damping ratio and the effective mass above (eq. 3.21's
    /// added mass and 2.75 factor inside it); or "map", from both valves'
    /// map sets: the mass is the first mode's in vacuum plus the added mass
    /// m_a(x), the damping the squeeze film's c(x) plus
    /// structural_damping_ratio's, and the moving reed draws A_m(x) v
    /// through its valve.
    std::string fluid_loading = "thesis";
    double      structural_damping_ratio = 0.0; ///< with fluid_loading = "map"
    /// What ends the squeeze film at the seat (fluid_loading = "map" only;
    /// docs/fluid-loading.md). seat_film_m: the film never gets thinner
    /// than this (the seat's roughness and flatness: a reed "on its seat"
    /// still stands this far off it); the loading is read at x + h0.
    double      seat_film_m = 0.0;
    static Bounds seat_film_bounds() { return Bounds::closed(0.0, 1e-3); }
    /// "cavitation": the film's suction on a lifting reed cannot pull its
    /// pressure below film_cavitation_pressure_Pa (absolute): the suction
    /// force is at most (p_pocket - p_cav) times the map set's film modal
    /// area; "none": unlimited (the quasi-static Stokes film as computed).
    std::string film_suction_limit = "cavitation";
    double      film_cavitation_pressure_Pa = 1.0e5; ///< absolute; default: [fluid] cavitation_pressure_Pa
    /// The stop (guard) that limits the reed's lift ([geometry]
    /// stop_height_m): "on", a contact event like the seat's at the tip
    /// opening stop_lift_m; "off", no stop (the thesis's model: a reed
    /// beyond stop_lift_m has passed its ceiling, which a run reports).
    std::string stop = "on";
    double      stop_lift_m = 1.873e-3;  ///< tip opening at the stop, from [geometry]
    double      stop_restitution = 0.0;  ///< stop impact: rebound speed / impact speed
    /// The reed's bending stress at its root (the clamp's underside, in
    /// tension while the reed opens) per unit tip opening of the first
    /// mode [Pa/m], and of the second mode (signed, referred to the same
    /// surface): from the map set's or reed map's FE solve, else beam
    /// theory of [geometry] and [reed_material] (stress_source says which).
    double      root_stress_per_opening_Pa_per_m = 0.0;
    double      second_mode_root_stress_per_opening_Pa_per_m = 0.0;
    std::string stress_source;
    /// Tip opening beyond which linear elasticity no longer holds ([stiffness]
    /// max_linear_deflection_ratio x the reed's length).
    double      large_deflection_opening_m = 0.61e-3;
    /// Reads [reed]. With `properties_map` set, k_r and m_r are interpolated
    /// (linearly in thickness) from that map at `properties_thickness_m`,
    /// the mass column chosen by `properties_mass`; giving them in the case
    /// as well is an error.
    static ReedParameters from_case(const CaseFile &file);
  };

  struct ValveParameters
  {
    /// Resolved map-set folders of the outlet [0] and inlet [1] valve (keys
    /// map_set for both, outlet_map_set / inlet_map_set for one); empty: the
    /// valve is described by resistance_map and [reed] pressure_area_m2.
    std::array<std::string, 2> map_set;
    std::string resistance_map;     ///< resolved path of the R(x) map file
    std::string interpolation = "monotone-cubic";
    std::string out_of_range  = "hold";
    double      ideal_open_resistance_Pa_s_per_m3 = 4.5e8;
    /// Leakage past each valve (diagnosis effect `valve_leakage`): a path of
    /// this resistance in parallel with the valve, open or shut; 0 for none.
    double      leak_resistance_Pa_s_per_m3 = 0.0;
    /// Turbulent leakage past each valve (diagnosis effect
    /// `valve_leakage_turbulent`): an orifice of this effective area
    /// (Cd x area) in parallel with the valve, drop rho q|q| / (2 A^2);
    /// 0 for none. With leak_resistance as well: two paths side by side.
    double      leak_area_m2 = 0.0;
    /// Nonlinear orifice flow (diagnosis effect `orifice_flow`): an extra
    /// drop rho q|q| / (2 Cd^2 A^2) through an open valve, A = perimeter x
    /// opening (the curtain area); Cd 0 for none.
    double      orifice_discharge_coefficient = 0.0;
    double      orifice_perimeter_m = 0.0; ///< 0: the circumference of a port of area A_r
    static ValveParameters from_case(const CaseFile &file);
  };

  struct LineParameters
  {
    double diameter_m = 0.18 * 0.0254;
    double length_m   = 12 * 0.0254;
    /// eq. 3.28: 128 mu L / (pi d^4)
    double resistance_Pa_s_per_m3(double viscosity_Pa_s) const;
    /// Fluid inertance of the outlet line (diagnosis effect `line_inertance`):
    /// that of an added length l of line of this bore, 4/3 rho l / A
    /// (laminar), which also adds its resistance and oil (ModelConstants);
    /// 0 for none (the thesis neglects it).
    double outlet_inertance_Pa_s2_per_m3 = 0.0;
    /// That added line as this many lumped pi sections in a chain. 1, the
    /// default: a short line, the pump body's outlet passage (a few cm, an
    /// [uncertain] baseline parameter of the reference case), whose
    /// ringing lies far above the pumping harmonics. A hose needs 12 (the
    /// diagnosis effect `line_inertance` sets them): a distributed line
    /// that carries its waves, its lowest three modes within 0.3, 1.1 and
    /// 2.3 % of a continuous line's; 6 sections put the second 4 % low,
    /// which a bench's hose showed; one section's lowest rings 34 % low.
    /// Not a length-based count: a fit of L or of the bore would jump
    /// where the count changes (docs/diagnosis-history.md, "A distributed outlet
    /// line").
    long outlet_line_segments = 1;
    static LineParameters from_case(const CaseFile &file);
  };

  struct CylinderParameters
  {
    double piston_area_m2     = 0.2 * 0.0254 * 0.0254;
    double wetted_length_m    = 1.0 * 0.0254;
    double high_side_fraction = 0.5;
    /// Extra compliance on the high (outlet) side, a soft seal or hose
    /// (diagnosis effect `outlet_compliance`); 0 for none.
    double seal_compliance_m3_per_Pa = 0.0;
    static CylinderParameters from_case(const CaseFile &file);
  };

  struct AccumulatorParameters
  {
    double gas_volume_m3 = 1.0 * 0.0254 * 0.0254 * 0.0254;
    static AccumulatorParameters from_case(const CaseFile &file);
  };

  struct LoadParameters
  {
    double mass_kg             = 50 * 0.45359237;
    double damping_N_s_per_m   = 0.0;
    double stiffness_N_per_m   = 0.0;
    double no_flow_mass_kg     = 1e12;
    /// Friction on the output piston (diagnosis effect `piston_friction`),
    /// Coulomb's with a Stribeck rise at low speed:
    /// F_c [1 + (r - 1) exp(-(v / v_st)^2)] tanh(v / v_s), where r = F_s / F_c
    /// is the breakaway force over the Coulomb force (1: no rise, Coulomb's
    /// alone), v_st the Stribeck velocity and v_s the smoothing velocity of
    /// the sign; F_c = 0 for none.
    double coulomb_friction_N = 0.0;
    double friction_velocity_scale_m_per_s = 1e-3;
    double static_friction_ratio = 1.0;
    double stribeck_velocity_m_per_s = 1e-3;
    static LoadParameters from_case(const CaseFile &file);
  };

  struct DriveParameters
  {
    /// The coil currents' admissible ranges (case file and command line):
    /// wide for any Terfenol-D drive, narrow enough to catch a current
    /// given in mA.
    static Bounds current_pp_bounds() { return Bounds::closed(0.0, 2000.0); }
    static Bounds current_bias_bounds() { return Bounds::closed(-1000.0, 1000.0); }
    /// InputError naming `what` (a key or an option) unless both are in range.
    static void check_currents(double pp_A, double bias_A, const std::string &pp_name,
                               const std::string &bias_name);

    double      current_pp_A   = 20.0;
    double      current_bias_A = 10.0;
    std::string waveform       = "sine"; ///< "sine" or the resolved path of a CSV (time_s, current_A)
    /// With a voltage drive (measured voltage_V): "off" takes the coil as a
    /// resistor, I = V/R; "on" integrates L dI/dt = V - R I with the
    /// transducer's coil resistance and inductance (diagnosis effect
    /// `coil_dynamics`). A current drive ignores it.
    std::string coil_dynamics  = "off";
    static DriveParameters from_case(const CaseFile &file);
  };

  struct SolverParameters
  {
    double      relative_tolerance = 1e-5;
    double      absolute_tolerance_factor = 10.0; ///< atol_i = factor * rtol * typical size of state i
    std::string jacobian           = "analytic"; ///< or "finite-difference"
    double      samples_per_cycle  = 200;
    double      max_steps_per_cycle = 1e6;
    static SolverParameters from_case(const CaseFile &file);
  };
  /// [solver]'s real keys (none among those [uncertain] may name).
  const RealKeys<SolverParameters> &solver_keys();

  /// A baseline parameter the case marks as uncertain: in its [uncertain]
  /// table, "table.key" = [lower, upper] (the thesis's gaps: lines, cylinder,
  /// accumulator, ...). Simulations use the key's own value; the diagnosis
  /// fits it inside these bounds with every candidate (docs/diagnosis.md).
  struct UncertainParameter
  {
    std::string table, key;
    double      lower = 0, upper = 0;
    /// The case leaves it out (its value 0, e.g. the outlet passage's
    /// inertance, which the thesis's model has none of): the fit's
    /// position 0 is the parameter off (0), as the case has it, and
    /// (0, 1] the range, so a record without it is still fitted exactly.
    bool off_at_zero = false;
    std::string name() const { return table + "." + key; }
  };

  struct SystemParameters
  {
    FluidParameters       fluid;
    TransducerParameters  transducer;
    ChamberParameters     chamber;
    ReedParameters        reed;
    ValveParameters       valves;
    LineParameters        lines;
    CylinderParameters    cylinder;
    AccumulatorParameters accumulator;
    LoadParameters        load;
    DriveParameters       drive;
    SolverParameters      solver;
    ReedMaterial          material; ///< [reed_material]: the Goodman factor's fatigue data
    std::vector<UncertainParameter> uncertain; ///< [uncertain]; empty if none

    /// The real-valued parameter [table] key (a pointer into this struct), or
    /// nullptr if there is no such real parameter.
    double *real_field(const std::string &table, const std::string &key);
    double  real_value(const std::string &table, const std::string &key) const
    {
      return *const_cast<SystemParameters *>(this)->real_field(table, key);
    }

    /// Reads every table; with map sets, checks each against the case's
    /// [geometry], [fluid] and [reed_material] and takes k_r and m_r from it.
    /// `read_map_sets` false: the map-set keys are read but the folders not
    /// opened (for a command about to write them).
    static SystemParameters from_case(const CaseFile &file, bool read_map_sets = true);
    /// All inputs and the derived model constants, for summaries.
    nlohmann::json to_json() const;
  };
  /// Makes both valves read the map set in `dir` (a command line's
  /// --map-set, which wins over the case's [valves] and [reed] k_r, m_r and
  /// pressure_area_m2): checks it against the case's [geometry], [fluid] and
  /// [reed_material] and takes k_r and m_r from it if it has a reed.
  void use_map_set(SystemParameters &parameters, const CaseFile &file, const std::string &dir);
  /// Sets [reed] fluid_loading ("thesis" or "map", a command line's
  /// --fluid-loading) and, since the reed's mass depends on it, takes the
  /// mass from the case's map sets again.
  void use_fluid_loading(SystemParameters &parameters, const CaseFile &file, const std::string &mode);
  /// Sets what ends the map's squeeze film at the seat (a command line's
  /// --seat-film-m, --film-suction-limit): a NaN seat film or an empty limit
  /// leaves the case's. InputError unless the fluid loading is "map" and the
  /// values are in [reed]'s ranges.
  void use_seat_film(SystemParameters &parameters, double seat_film_m, const std::string &suction_limit);
  /// The thesis's model: no stop ([reed] stop = "off") and no cavitation
  /// ([fluid] cavitation = "none"); its runs are the thesis model's to the bit.
  void use_thesis_model(SystemParameters &parameters);
  /// Beam theory's root bending stress per unit tip opening of a uniform
  /// cantilever (length L, thickness t, modulus E) bent into the reference
  /// "beam" shape, a point load at a: 3 E t / (a (3L - a)); and its second
  /// mode's (Euler-Bernoulli, unit tip deflection): -(E t / 2) (4.694 / L)^2.
  std::pair<double, double> beam_root_stress_per_opening(const ValveGeometry &geometry, const ReedMaterial &material);

  /// The two valves' maps (0 outlet, 1 inlet): their map sets, or the R(x)
  /// map with the constant area A_r. InputError for a missing or bad file.
  std::array<maps::MapSet, 2> load_valve_maps(const SystemParameters &parameters);
} // namespace rectify::system
