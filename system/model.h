// The lumped model of the Terfenol-D pump, reed valves, hydraulic circuit and
// output cylinder: thesis eqs. 3.1-3.36, with the corrections listed in
// docs/system-model.md (each marked "correction" below).
//
// States (system/states.h):
//   mechanics  x_p, v_p (piston + rod), x_f, v_f (chamber fluid mass),
//              x_act, v_act (output piston and load),
//              x_ro, v_ro, x_ri, v_ri (outlet and inlet reed tips, >= 0)
//   pressures  p_ch, p_acc, p_h, p_l, gauge about the bias pressure
//   integrals  V_out, V_in (volume through each valve), int p_o dt
//
//   m_eff x_p'' = N q k_td I - (b_f + b_eff) x_p' + b_f x_f' - (k_eff + k_f) x_p + k_f x_f   (3.6)
//   m_f   x_f'' = b_f x_p' - b_f x_f' + k_f x_p - k_f x_f - p_ch A_pi      (3.7, sign corrected)
//   m_l x_act'' = (p_h - p_l) A_po - b_l x_act' - k_l x_act                (3.8)
//   m_r x_ro''  = (p_ch - p_o) A(x_ro) - b_r x_ro' - k_r x_ro,  0 <= x_ro <= x_stop  (3.9)
//   m_r x_ri''  = (p_i - p_ch) A(x_ri) - b_r x_ri' - k_r x_ri,  0 <= x_ri <= x_stop  (3.10)
//   (seat and stop are contact events, system/reed.h; the stop is not the thesis's)
//   A = A_r (thesis) or, from a map set, A_eff(x) open and the seated area on the seat
//   C_ch p_ch'  = A_pi x_p' + q_in - q_out                                 (3.31)
//   C_acc p_acc' = q_acc,  C_h p_h' = q_out - A_po x_act',  C_l p_l' = q_low + A_po x_act'
//
// with the circuit of Fig. 3.5: chamber -R1(x_ro)- p_o -R3- high side;
// junction p_a -R4- p_i -R2(x_ri)- chamber; junction -R5- accumulator;
// junction -R6- low side. The junction has no capacitance: p_a follows from
// Kirchhoff's current law. Flows are computed as such (node form), which is
// algebraically the same as eqs. 3.32-3.36 once their typos are corrected.
//
// Cavitation ([fluid] cavitation, system/cavitation.h): the pressure states
// of the oil volumes (chamber, high and low sides, the outlet line's nodes)
// are each volume's liquid pressure psi; the model reads max(psi, p_c), the
// volume's cavity takes up the rest. Off: the thesis's unbounded pressures.
#pragma once

#include <array>
#include <limits>
#include <utility>
#include <optional>
#include <nlohmann/json.hpp>
#include <span>
#include <vector>

#include "maps/map_set.h"
#include "maps/resistance_map.h"
#include "system/component.h"
#include "system/drive.h"
#include "system/integrator.h"
#include "system/parameters.h"
#include "system/reed.h"
#include "system/states.h"
#include "system/reed_second_mode.h"

namespace rectify::system
{
  enum class ValveModel
  {
    dynamic, ///< 1-DOF reeds with seat contact and R(x) from the map
    ideal    ///< binary valves: open (fixed low R) while the pressure drives flow forward
  };

  enum class Scenario
  {
    no_flow, ///< output mass 1e12 kg (thesis sec. 5.1)
    loaded   ///< inertial load (thesis sec. 5.2)
  };

  /// The maps of the outlet [0] and inlet [1] valve.
  using ValveMaps = std::array<maps::MapSet, 2>;

  ValveModel parse_valve_model(const std::string &name);
  Scenario   parse_scenario(const std::string &name);
  std::string to_string(ValveModel v);
  std::string to_string(Scenario s);


  /// Model constants derived from the parameters (eqs. 3.2-3.5, 3.28, 3.29,
  /// Tables 3.5-3.6). Damping coefficients from damping ratios: b = 2 zeta sqrt(k m)
  /// with (k_eff, m_eff) for the transducer, (k_f, m_f) for the chamber fluid,
  /// (k_r, m_r) for a reed.
  struct ModelConstants
  {
    double force_per_ampere; ///< N q k_td [N/A]
    double k_td, k_eff, k_f, m_eff, m_f, b_eff, b_f, A_pi;
    ReedConstants reed; ///< k_r, m_r, b_r, A_r, restitution
    double k_l, m_l, b_l, A_po;
    double beta_eff, C_ch, C_acc, C_h, C_l;
    double R3, R4, R5, R6;
    double R_ideal_open;
    double p_bias; ///< absolute pressure the gauge states are measured from
    maps::OutOfRange out_of_range;
    double V_ch, V_h, V_l;         ///< oil volumes of the chamber, high and low sides
    double R_coil;                 ///< the coil's resistance: a voltage drive's current V / R
    /// Each reed's second bending mode (system/reed_second_mode.h); none: off
    std::optional<ReedSecondMode> second_mode;
    /// The components the case switches on (system/component.h), made
    /// from the thesis's constants; their adjust()s are applied.
    Components components;

    /// The thesis's constants, then each component's adjust().
    ModelConstants(const SystemParameters &p, Scenario scenario);
    nlohmann::json to_json() const;
  };

  /// Algebraic quantities at one state.
  struct Flows
  {
    double R1, R2;                 ///< valve resistances [Pa s/m^3]
    double p_junction;             ///< p_a
    double p_outlet, p_inlet;      ///< p_o, p_i
    double q_outlet;               ///< out of the chamber through the outlet valve
    double q_line;                 ///< into the high side through the outlet line (= q_outlet
                                   ///< without an outlet element, Component::outlet_node)
    double q_inlet;                ///< junction -> chamber, through the inlet valve
    double q_accumulator;          ///< junction -> accumulator
    double q_low;                  ///< junction -> low side
    double outlet_force, inlet_force; ///< opening pressure force on each reed [N]: A dp
    /// Each reed's fluid loading at its opening (fluid_loading "map", open reed).
    std::array<std::optional<maps::LoadingMap::Value>, 2> loading;
  };

  /// What bounds the states a run may reach and still describe hardware
  /// (system/validity.h): the reed's material, its linear range, the stop's
  /// lift in the geometry and the oil's cavitation pressure.
  struct StateLimits
  {
    ReedMaterial material;
    double       large_deflection_opening_m = 0; ///< linear elasticity's end
    double       geometric_stop_lift_m      = 0; ///< where the stop (or the ceiling) is, on or off
    double       cavitation_pressure_Pa     = 0; ///< absolute
    bool         stop_on = false, cavitation_on = false;
    std::string  stress_source;
  };

  class Model : public OdeSystem
  {
  public:
    /// Each valve (0 outlet, 1 inlet) from its map set: R(x), the opening
    /// force's area A_eff(x), the seated reed's area.
    Model(const SystemParameters &parameters, std::array<maps::MapSet, 2> valve_maps, ValveModel valves,
          Scenario scenario, Drive drive);
    /// Both valves from one R(x) map with the constant force area A_r
    /// ([reed] pressure_area_m2): the thesis's model.
    Model(const SystemParameters &parameters, maps::ResistanceMap map, ValveModel valves,
          Scenario scenario, Drive drive);

    std::size_t n_states() const override
    {
      return needs_difference_jacobian() ? state::count + extra_states_ : state::thesis_count;
    }
    void        rhs(double t, std::span<const double> y, std::span<double> ydot) const override;
    void        jacobian(double t, std::span<const double> y, DenseView J) const override;
    /// The states each component of rhs() reads, for the coloured
    /// difference-quotient Jacobian (every effect's states; valves open or
    /// on their seats; tests Effects.RhsReadsCoversEveryDependence, ReedLoading.RhsReads...).
    std::vector<std::vector<std::size_t>> rhs_reads() const override;
    /// Per valve v: 2v its seat or held contact, 2v + 1 its stop, 4 + 2v and
    /// 5 + 2v its root stress's maximum and minimum (logged, nothing
    /// changes); 8 + k the cavitation of volume k (cavity_nodes()[k]).
    /// A root function that never crosses zero changes nothing CVODE does;
    /// one that does changes how the others' roots are bracketed, and so the
    /// trajectory in its last bits. The stress's extrema are therefore roots
    /// only while a run records events (system::run) and not in the
    /// thesis's model (no stop, no cavitation), which stays the thesis's to
    /// the bit; there, and in the diagnosis's runs, they are never found.
    std::size_t n_roots() const override { return 8 + cavity_nodes_.size(); }
    void        roots(double t, std::span<const double> y, std::span<double> g) const override;
    bool handle_events(double t, std::span<double> y, std::span<const int> found) override;

    Flows               flows(std::span<const double> y) const;
    /// The state as the physics reads it: each cavitating volume's pressure
    /// at the cavitation pressure (system/cavitation.h); y itself without cavitation.
    std::vector<double> physical_state(std::span<const double> y) const;
    /// Tip opening of valve v (0 outlet, 1 inlet): first plus second mode.
    double              opening(std::size_t v, std::span<const double> y) const;
    /// The fluid's loading on open reed `v` (docs/fluid-loading.md) at its
    /// opening, with [reed] fluid_loading = "map"; none otherwise.
    std::optional<maps::LoadingMap::Value> loading(std::size_t v, std::span<const double> y) const;
    /// gamma of valve `v`: the loading map's tip-referred mass and damping are
    /// divided by it in the reed's equation (1 without loading).
    double              loading_scale(std::size_t v) const { return loading_scale_[v]; }
    /// The reed's structural damping b_s with the loading (its mass m_r / gamma).
    double              structural_damping(std::size_t v) const { return structural_damping_[v]; }
    /// The squeeze film's force against open reed `v`'s motion in the
    /// model's coordinate (c(x) v / gamma, its suction on a lifting reed
    /// limited by cavitation in the pocket: system/reed.h film_force); 0
    /// without loading. `f`: flows(y) (the pocket's pressure).
    double              film_force(std::size_t v, std::span<const double> y, const Flows &f) const;
    /// The film's suction limit on reed `v` at state y (model coordinate;
    /// infinity with film_suction_limit = "none" or without loading).
    double              film_suction_cap(std::size_t v, std::span<const double> y, const Flows &f) const;
    /// The flow reed `v` draws through its valve by moving, A_m(x) v (0 without loading).
    double              displaced_flow(std::size_t v, std::span<const double> y) const;
    /// Coil current: the drive itself, V/R, or the coil state (coil dynamics).
    double              current_A(double t, std::span<const double> y) const;
    /// Oil (and free air) stored in the components' volumes (the outlet
    /// line's nodes) at state y, relative to the bias state (0 without).
    double              component_stored_volume(std::span<const double> y) const;
    /// Oil (and free air) volume stored at gauge pressure p in volume
    /// `node` (volumes(): 0 chamber, 1 high side, 2 low side, then the
    /// components', 3 the node after the outlet valve with an outlet line),
    /// relative to the bias state: the integral of its compliance (for the
    /// volume balances).
    double              stored_volume(std::size_t node, double p) const;
    /// The model's oil volumes: chamber, high side, low side, then the components'.
    const std::vector<OilVolume> &volumes() const { return volumes_; }
    /// The components' free gas per unit oil volume at gauge pressure p:
    /// its compliance and its volume lost from the bias state (0 without).
    double gas_compliance(double p) const;
    double gas_volume_change(double p) const;
    /// True if an optional effect is on (a component or a core effect): the
    /// analytic Jacobian covers only the thesis model, so CVODE's difference
    /// quotients are used instead.
    bool                needs_difference_jacobian() const;
    /// The highest BDF order the integrator should use (0: no limit): the
    /// lowest its components ask for (Component::max_bdf_order).
    int                 max_bdf_order() const;
    std::vector<double> initial_state() const;
    /// Typical magnitude of each state, for absolute tolerances.
    std::vector<double> typical_sizes() const;

    /// Valve `v` (0 outlet, 1 inlet) is closed: reed on its seat (dynamic) or
    /// valve shut (ideal).
    bool closed(std::size_t v) const { return closed_[v]; }
    /// Valve `v`'s reed is held at its stop.
    bool at_stop(std::size_t v) const { return at_stop_[v]; }
    void set_at_stop(std::size_t v, bool held) { at_stop_[v] = held; }
    /// The tip opening at the stop (infinity: no stop, [reed] stop = "off").
    double stop_lift() const { return stop_lift_; }
    /// Sets the discrete state: both valves closed, reeds on their seats.
    void reset();
    /// Sets one valve's discrete state (tests, and starting from a given state).
    void set_closed(std::size_t v, bool closed) { closed_[v] = closed; }
    std::size_t n_seat_impacts() const { return n_impacts_; }
    std::size_t n_stop_impacts() const { return n_stop_impacts_; }

    /// What happened to a reed at an event, for the run's statistics.
    struct ReedEvent
    {
      enum Kind
      {
        seat_impact,
        stop_impact,
        stress_maximum,
        stress_minimum
      };
      double      t;
      std::size_t valve;
      Kind        kind;
      double      velocity;    ///< the tip's speed toward the seat or stop before an impact [m/s]
      double      opening;     ///< tip opening [m]
      double      root_stress; ///< [Pa]
    };
    /// Keep ReedEvents from now on (a run's sampling drains them).
    void                   record_events(bool on) { record_events_ = on; }
    std::vector<ReedEvent> take_events() { return std::exchange(events_, {}); }

    /// The reed's bending stress at its root, valve v at state y [Pa]:
    /// per unit opening of each mode ([reed] root_stress_...) times its
    /// modal coordinate; positive: the underside in tension.
    double root_stress(std::size_t v, std::span<const double> y) const;
    /// Its rate of change at state y [Pa/s] (0 where the reed is held).
    double root_stress_rate(std::size_t v, std::span<const double> y) const;

    /// The volumes that can cavitate: their pressure states (chamber, high
    /// side, low side, the outlet line's nodes), none without cavitation.
    const std::vector<std::size_t> &cavity_nodes() const { return cavity_nodes_; }
    /// Volume k's cavity at state y [m^3] (0 when its liquid holds).
    double cavity_volume(std::size_t k, std::span<const double> y) const;
    bool   cavitating(std::size_t k) const { return cavitating_[k] != 0; }
    /// Sets each volume's discrete state from y (a start from a given state).
    void   sync_cavitation(std::span<const double> y);
    /// The cavitation pressure as a gauge state (about the bias).
    double cavitation_gauge_pressure() const { return p_cavitation_; }

    /// The components the model composes (system/component.h), in order.
    const Components           &components() const { return components_; }
    /// The component called `name`, or nullptr if it is off.
    const Component            *component(std::string_view name) const;
    const ModelConstants       &constants() const { return c_; }
    const StateLimits          &limits() const { return limits_; }
    const Drive                &drive() const { return drive_; }
    const maps::MapSet         &valve_map(std::size_t v) const { return maps_[v]; }
    /// The opening force's area of valve v at state y and its slope dA/dx:
    /// the seated area while the reed is seated (or an ideal valve), else A_eff(x).
    maps::AreaMap::Value        force_area(std::size_t v, std::span<const double> y) const;
    ValveModel                  valve_model() const { return valves_; }
    Scenario                    scenario() const { return scenario_; }

  private:
    Flows flows_at(std::span<const double> y) const;
    void  rhs_at(double t, std::span<const double> y, std::span<double> ydot) const;
    void  jacobian_at(std::span<const double> y, DenseView J) const;
    /// Calls f with the physical state of y (cavitating volumes clamped),
    /// without a copy where nothing is.
    template <typename F>
    void with_physical(std::span<const double> y, const F &f) const;
    /// The compliance of volume k (volumes(); cavity k where they cavitate) at gauge pressure p.
    double node_compliance(std::size_t k, double p) const;
    /// A seat or stop root of valve v with one mode (x, v: its tip).
    void contact_event(std::size_t v, double t, std::span<double> y, bool stop_root);
    /// The same with two modes: the contact holds the tip, not the reed.
    void two_mode_contact_event(std::size_t v, double t, std::span<double> y, bool stop_root);
    void log_event(double t, std::size_t v, ReedEvent::Kind kind, double velocity, std::span<const double> y);


    /// R and dR/dx of valve v at state y.
    maps::ResistanceMap::Value valve_resistance(std::size_t v, std::span<const double> y) const;
    /// What the components add to valve v's branch at state y.
    BranchLaw branch_law(std::size_t v, std::span<const double> y) const;
    /// Pressure difference that drives flow forward through valve v.
    static double driving_pressure(std::size_t v, std::span<const double> y, const Flows &f);

    ModelConstants        c_;
    Components            components_; ///< those that act with this drive
    std::size_t           extra_states_ = 0; ///< theirs beyond state::count
    std::vector<OilVolume> volumes_;
    /// The component the outlet valve discharges into (the outlet line) and its node's state.
    const Component      *outlet_element_ = nullptr;
    std::size_t           outlet_node_    = state::high_p;
    StateLimits           limits_;
    std::array<maps::MapSet, 2> maps_;
    ValveModel            valves_;
    Scenario              scenario_;
    Drive                 drive_;
    std::array<bool, 2>   closed_{true, true};
    std::array<bool, 2>   at_stop_{false, false};
    std::size_t           n_impacts_ = 0, n_stop_impacts_ = 0;
    double                stop_lift_ = std::numeric_limits<double>::infinity();
    double                stop_restitution_ = 0.0;
    double                stress1_ = 0.0; ///< root stress per unit opening of the first mode
    bool                  record_events_ = false;
    bool                  stress_extrema_ = false; ///< the stress's extrema as roots (not the thesis's model)
    std::vector<ReedEvent> events_;
    std::vector<std::size_t> cavity_nodes_;   ///< pressure states that can cavitate
    std::vector<char>        cavitating_;     ///< per cavity node: its cavity is open
    double                   p_cavitation_ = 0.0; ///< gauge
    bool                  loading_   = false; ///< [reed] fluid_loading = "map" (dynamic valves)
    std::array<double, 2> loading_scale_{1.0, 1.0};      ///< gamma = mean A_m / A_eff of each valve's map
    std::array<double, 2> structural_damping_{0.0, 0.0}; ///< b_s with the mass m_r / gamma
    double                seat_film_ = 0.0;                ///< [reed] seat_film_m: the loading is read at x + this
    bool                  suction_limit_ = false;          ///< [reed] film_suction_limit = "cavitation"
    double                cavitation_pressure_ = 0.0;      ///< absolute [Pa]
    std::array<double, 2> film_area_{0.0, 0.0};            ///< each map's film modal area [m^2], tip-referred
  };
} // namespace rectify::system
