#include "system/model.h"

#include <algorithm>
#include <cmath>

#include "common/case_file.h"
#include "system/cavitation.h"

namespace rectify::system
{
  ValveModel parse_valve_model(const std::string &name)
  {
    if (name == "dynamic")
      return ValveModel::dynamic;
    if (name == "ideal")
      return ValveModel::ideal;
    throw InputError("unknown valve model '" + name + "' (dynamic or ideal)");
  }

  Scenario parse_scenario(const std::string &name)
  {
    if (name == "no-flow")
      return Scenario::no_flow;
    if (name == "loaded")
      return Scenario::loaded;
    throw InputError("unknown scenario '" + name + "' (no-flow or loaded)");
  }

  std::string to_string(ValveModel v) { return v == ValveModel::dynamic ? "dynamic" : "ideal"; }
  std::string to_string(Scenario s) { return s == Scenario::no_flow ? "no-flow" : "loaded"; }

  ModelConstants::ModelConstants(const SystemParameters &p, Scenario scenario)
  {
    const auto &td = p.transducer;
    k_td             = td.rod_stiffness_N_per_m();      // eq. 3.2
    force_per_ampere = td.force_per_ampere_N_per_A();   // eq. 3.1
    k_eff            = k_td + td.diaphragm_stiffness_N_per_m; // eq. 3.5
    m_eff            = td.effective_mass_kg;
    b_eff            = 2.0 * td.damping_ratio * std::sqrt(k_eff * m_eff);

    beta_eff         = p.fluid.effective_bulk_modulus_Pa(); // eq. 3.26
    A_pi             = p.chamber.piston_area_m2;
    const double V_c = A_pi * p.chamber.height_m;
    m_f              = V_c * p.fluid.density_kg_per_m3;           // eq. 3.3
    k_f              = beta_eff * A_pi / p.chamber.height_m;      // eq. 3.4
    b_f              = 2.0 * p.chamber.fluid_damping_ratio * std::sqrt(k_f * m_f);
    C_ch             = V_c / beta_eff;                            // eq. 3.29

    reed.stiffness   = p.reed.stiffness_N_per_m;
    reed.mass        = p.reed.effective_mass_kg;
    // With the fluid's loading from the map sets, the reed's own damping is
    // the structural part; the squeeze film's c(x) comes on top (Model::rhs).
    reed.damping = 2.0 * (p.reed.fluid_loading == "map" ? p.reed.structural_damping_ratio : p.reed.damping_ratio) *
                   std::sqrt(reed.stiffness * reed.mass);
    reed.area        = p.reed.pressure_area_m2;
    reed.restitution = p.reed.restitution;

    A_po = p.cylinder.piston_area_m2;
    m_l  = scenario == Scenario::no_flow ? p.load.no_flow_mass_kg : p.load.mass_kg;
    b_l  = p.load.damping_N_s_per_m;
    k_l  = p.load.stiffness_N_per_m;
    C_h  = A_po * p.cylinder.high_side_fraction * p.cylinder.wetted_length_m / beta_eff;
    C_l  = A_po * (1.0 - p.cylinder.high_side_fraction) * p.cylinder.wetted_length_m / beta_eff;
    // Isothermal gas: V = m R T / p, so C = -dV/dp = m R T / p^2 = V_gas / p_bias (Table 3.6).
    C_acc = p.accumulator.gas_volume_m3 / p.fluid.bias_pressure_Pa;

    R3 = R4 = R5 = R6 = p.lines.resistance_Pa_s_per_m3(p.fluid.viscosity_Pa_s); // eq. 3.28
    R_ideal_open = p.valves.ideal_open_resistance_Pa_s_per_m3;
    p_bias       = p.fluid.bias_pressure_Pa;
    out_of_range = maps::parse_out_of_range(p.valves.out_of_range);

    V_ch   = V_c;
    V_h    = A_po * p.cylinder.high_side_fraction * p.cylinder.wetted_length_m;
    V_l    = A_po * (1.0 - p.cylinder.high_side_fraction) * p.cylinder.wetted_length_m;
    R_coil          = p.transducer.coil_resistance_ohm;
    second_mode     = ReedSecondMode::make(p, reed);
    components = make_components(p, scenario, *this);
    for (const auto &component : components)
      component->adjust(*this);
  }

  nlohmann::json ModelConstants::to_json() const
  {
    nlohmann::json j = {{"force_per_ampere_N_per_A", force_per_ampere},
            {"rod_stiffness_N_per_m", k_td},
            {"transducer_stiffness_N_per_m", k_eff},
            {"transducer_damping_N_s_per_m", b_eff},
            {"fluid_stiffness_N_per_m", k_f},
            {"fluid_mass_kg", m_f},
            {"fluid_damping_N_s_per_m", b_f},
            {"effective_bulk_modulus_Pa", beta_eff},
            {"reed_damping_N_s_per_m", reed.damping},
            {"reed_natural_frequency_Hz", std::sqrt(reed.stiffness / reed.mass) / (2 * M_PI)},
            {"load_mass_kg", m_l},
            {"chamber_capacitance_m3_per_Pa", C_ch},
            {"accumulator_capacitance_m3_per_Pa", C_acc},
            {"high_side_capacitance_m3_per_Pa", C_h},
            {"low_side_capacitance_m3_per_Pa", C_l},
            {"line_resistance_Pa_s_per_m3", R3},
            {"bias_pressure_Pa", p_bias}};
    for (const auto &c : components)
      c->constants_json(j);
    return j;
  }

  Model::Model(const SystemParameters &parameters, std::array<maps::MapSet, 2> valve_maps, ValveModel valves,
               Scenario scenario, Drive drive)
    : c_(parameters, scenario)
    , maps_(std::move(valve_maps))
    , valves_(valves)
    , scenario_(scenario)
    , drive_(std::move(drive))
  {
    volumes_ = {{state::chamber_p, c_.C_ch, c_.V_ch, "chamber", false},
                {state::high_p, c_.C_h, c_.V_h, "high side", true},
                {state::low_p, c_.C_l, c_.V_l, "low side", false}};
    for (const auto &component : c_.components)
      if (component->acts(drive_))
        {
          components_.push_back(component);
          extra_states_ += component->extra_states();
          for (auto &v : component->volumes())
            volumes_.push_back(std::move(v));
          if (const auto node = component->outlet_node(); node && !outlet_element_)
            {
              outlet_element_ = component.get();
              outlet_node_    = *node;
            }
        }
    stop_lift_ = parameters.reed.stop == "on" && valves_ == ValveModel::dynamic ?
                   parameters.reed.stop_lift_m :
                   std::numeric_limits<double>::infinity();
    stop_restitution_ = parameters.reed.stop_restitution;
    limits_           = {parameters.material,
                         parameters.reed.large_deflection_opening_m,
                         parameters.reed.stop_lift_m,
                         parameters.fluid.cavitation_pressure_Pa,
                         stop_lift_ < std::numeric_limits<double>::infinity(),
                         parameters.fluid.cavitates(),
                         parameters.reed.stress_source};
    stress1_          = parameters.reed.root_stress_per_opening_Pa_per_m;
    stress_extrema_   = parameters.reed.stop == "on" || parameters.fluid.cavitates();
    if (parameters.fluid.cavitates())
      {
        p_cavitation_ = parameters.fluid.cavitation_pressure_Pa - c_.p_bias;
        for (const auto &v : volumes_)
          cavity_nodes_.push_back(v.state);
      }
    cavitating_.assign(cavity_nodes_.size(), 0);
    loading_ = parameters.reed.fluid_loading == "map" && valves_ == ValveModel::dynamic;
    if (!loading_)
      return;
    seat_film_           = parameters.reed.seat_film_m;
    suction_limit_       = parameters.reed.film_suction_limit == "cavitation";
    cavitation_pressure_ = parameters.reed.film_cavitation_pressure_Pa;
    if (c_.second_mode)
      throw InputError("[reed] fluid_loading = \"map\" takes the reed's first mode only; second_mode_frequency_Hz = " +
                       format_number(parameters.reed.second_mode_frequency_Hz) + " is not supported with it");
    for (std::size_t v = 0; v < 2; ++v)
      {
        if (!maps_[v].loading())
          throw InputError(std::string("[reed] fluid_loading = \"map\": the ") + (v == 0 ? "outlet" : "inlet") +
                           " valve's map set '" + maps_[v].name() +
                           "' has no loading table (loading.csv; made with [flow] reed_loading = \"skip\", by an "
                           "older rectify, or not a `rectify design` map set): run `rectify design` with "
                           "reed_loading = \"solve\", or use fluid_loading = \"thesis\"");
        // The map's masses and damping are referred to the tip (the shape's
        // generalised coordinate), the model's k_r and A_eff to a total
        // port load: their ratio gamma = A_m / A_eff (the shape's mean under
        // the pressure) converts one into the other (docs/fluid-loading.md).
        double sum = 0;
        for (const auto &r : maps_[v].loading()->rows())
          sum += r.A_modal_m2 / maps_[v].area().evaluate(r.opening_m).area;
        loading_scale_[v] = sum / static_cast<double>(maps_[v].loading()->rows().size());
        if (!(loading_scale_[v] > 0 && loading_scale_[v] <= 1.5))
          throw InputError("map set '" + maps_[v].name() + "': the loading's modal area over A_eff is " +
                           format_number(loading_scale_[v]) + " on average (expected in (0, 1.5])");
        structural_damping_[v] = c_.reed.damping / std::sqrt(loading_scale_[v]); // 2 zeta sqrt(k m / gamma)
        if (suction_limit_)
          {
            const auto area = maps_[v].loading()->film_modal_area_m2();
            if (!area)
              throw InputError("[reed] film_suction_limit = \"cavitation\": the " +
                               std::string(v == 0 ? "outlet" : "inlet") + " valve's map set '" + maps_[v].name() +
                               "' has no film modal area in loading.csv (made by an older rectify): run `rectify "
                               "design` again, or set film_suction_limit = \"none\"");
            film_area_[v] = *area;
          }
      }
  }

  double Model::film_suction_cap(std::size_t v, std::span<const double> y, const Flows &f) const
  {
    if (!loading_ || !suction_limit_)
      return std::numeric_limits<double>::infinity();
    // The film opens into the pocket: the outlet valve's is the pressure
    // behind it, the inlet valve's the chamber. Absolute: the states are
    // relative to the bias pressure, taken as absolute (as the free air's
    // gas law takes it, common/fluid.h).
    const double p_pocket = (v == 0 ? f.p_outlet : y[state::chamber_p]) + c_.p_bias;
    return system::film_suction_cap(p_pocket, cavitation_pressure_, film_area_[v]) / loading_scale_[v];
  }

  double Model::film_force(std::size_t v, std::span<const double> y, const Flows &f) const
  {
    const auto &l = f.loading[v];
    if (!l)
      return 0.0;
    const double u = y[v == 0 ? state::outlet_reed_v : state::inlet_reed_v];
    return system::film_force(l->damping / loading_scale_[v], u, film_suction_cap(v, y, f));
  }

  std::optional<maps::LoadingMap::Value> Model::loading(std::size_t v, std::span<const double> y) const
  {
    if (!loading_ || closed_[v])
      return std::nullopt;
    return maps_[v].loading()->evaluate(opening(v, y) + seat_film_);
  }

  double Model::displaced_flow(std::size_t v, std::span<const double> y) const
  {
    const auto l = loading(v, y);
    return l ? l->A_modal * y[v == 0 ? state::outlet_reed_v : state::inlet_reed_v] : 0.0;
  }

  Model::Model(const SystemParameters &parameters, maps::ResistanceMap map, ValveModel valves,
               Scenario scenario, Drive drive)
    : Model(parameters,
            {maps::map_set_from_resistance(map, parameters.reed.pressure_area_m2),
             maps::map_set_from_resistance(map, parameters.reed.pressure_area_m2)},
            valves, scenario, std::move(drive))
  {}

  const Component *Model::component(std::string_view name) const
  {
    for (const auto &c : components_)
      if (c->name() == name)
        return c.get();
    return nullptr;
  }

  maps::AreaMap::Value Model::force_area(std::size_t v, std::span<const double> y) const
  {
    if (valves_ == ValveModel::ideal || closed_[v])
      return {maps_[v].seated_area_m2(), 0.0};
    return maps_[v].area().evaluate(opening(v, y));
  }

  void Model::reset()
  {
    closed_         = {true, true};
    at_stop_        = {false, false};
    n_impacts_      = 0;
    n_stop_impacts_ = 0;
    events_.clear();
    std::fill(cavitating_.begin(), cavitating_.end(), 0);
  }

  void Model::sync_cavitation(std::span<const double> y)
  {
    for (std::size_t k = 0; k < cavity_nodes_.size(); ++k)
      cavitating_[k] = y[cavity_nodes_[k]] < p_cavitation_;
  }

  double Model::gas_compliance(double p) const
  {
    double C = 0.0;
    for (const auto &c : components_)
      C += c->gas_compliance_per_volume(p);
    return C;
  }

  double Model::gas_volume_change(double p) const
  {
    double v = 0.0;
    for (const auto &c : components_)
      v += c->gas_volume_change_per_volume(p);
    return v;
  }

  double Model::node_compliance(std::size_t k, double p) const
  {
    return volumes_[k].compliance + volumes_[k].oil_volume * gas_compliance(p);
  }

  double Model::cavity_volume(std::size_t k, std::span<const double> y) const
  {
    return system::cavity_volume(y[cavity_nodes_[k]], p_cavitation_, node_compliance(k, p_cavitation_));
  }

  template <typename F>
  void Model::with_physical(std::span<const double> y, const F &f) const
  {
    bool any = false;
    for (std::size_t i : cavity_nodes_)
      any = any || y[i] < p_cavitation_;
    if (!any)
      return f(y);
    std::array<double, 64> local;
    std::vector<double>    heap;
    double                *d = local.data();
    if (y.size() > local.size())
      d = (heap.resize(y.size()), heap.data());
    std::copy(y.begin(), y.end(), d);
    for (std::size_t i : cavity_nodes_)
      d[i] = cavity_pressure(d[i], p_cavitation_);
    f(std::span<const double>(d, y.size()));
  }

  std::vector<double> Model::physical_state(std::span<const double> y) const
  {
    std::vector<double> p(y.begin(), y.end());
    for (std::size_t i : cavity_nodes_)
      p[i] = cavity_pressure(p[i], p_cavitation_);
    return p;
  }

  Flows Model::flows(std::span<const double> y) const
  {
    Flows f;
    with_physical(y, [&](std::span<const double> p) { f = flows_at(p); });
    return f;
  }

  void Model::rhs(double t, std::span<const double> y, std::span<double> ydot) const
  {
    with_physical(y, [&](std::span<const double> p) { rhs_at(t, p, ydot); });
  }

  void Model::jacobian(double, std::span<const double> y, DenseView J) const
  {
    with_physical(y, [&](std::span<const double> p) { jacobian_at(p, J); });
    // A held pressure does not move with its state: its column is zero.
    for (std::size_t k = 0; k < cavity_nodes_.size(); ++k)
      if (cavitating_[k] || y[cavity_nodes_[k]] < p_cavitation_)
        for (std::size_t row = 0; row < J.n; ++row)
          J(row, cavity_nodes_[k]) = 0.0;
  }

  double Model::root_stress(std::size_t v, std::span<const double> y) const
  {
    const std::size_t ix = v == 0 ? state::outlet_reed_x : state::inlet_reed_x;
    if (!c_.second_mode)
      return stress1_ * y[ix];
    return c_.second_mode->stress(v, y, stress1_);
  }

  double Model::root_stress_rate(std::size_t v, std::span<const double> y) const
  {
    const std::size_t ix = v == 0 ? state::outlet_reed_x : state::inlet_reed_x;
    if (valves_ == ValveModel::ideal)
      return 0.0;
    if (!c_.second_mode)
      return closed_[v] || at_stop_[v] ? 0.0 : stress1_ * y[ix + 1];
    return c_.second_mode->stress_rate(v, y, stress1_);
  }

  void Model::log_event(double t, std::size_t v, ReedEvent::Kind kind, double velocity, std::span<const double> y)
  {
    if (record_events_)
      events_.push_back({t, v, kind, velocity, opening(v, y), root_stress(v, y)});
  }

  std::vector<double> Model::initial_state() const
  {
    std::vector<double> y(n_states(), 0.0);
    for (const auto &c : components_)
      c->initial_state(y, drive_);
    return y;
  }

  bool Model::needs_difference_jacobian() const
  {
    return !components_.empty() || c_.second_mode || loading_;
  }

  int Model::max_bdf_order() const
  {
    int order = 0;
    for (const auto &c : components_)
      if (const int k = c->max_bdf_order(); k > 0 && (order == 0 || k < order))
        order = k;
    return order;
  }

  double Model::opening(std::size_t v, std::span<const double> y) const
  {
    if (!c_.second_mode) // one mode: the analytic Jacobian's case
      return y[v == 0 ? state::outlet_reed_x : state::inlet_reed_x];
    return ReedSecondMode::tip(v, y);
  }

  double Model::current_A(double t, std::span<const double> y) const
  {
    if (!drive_.is_voltage())
      return drive_.value(t);
    for (const auto &c : components_)
      if (const auto I = c->current(t, y, drive_))
        return *I;
    return drive_.value(t) / c_.R_coil;
  }

  double Model::component_stored_volume(std::span<const double> y) const
  {
    double v = 0.0;
    for (std::size_t k = 3; k < volumes_.size(); ++k)
      if (volumes_[k].state < y.size())
        v += stored_volume(k, y[volumes_[k].state]);
    return v;
  }

  double Model::stored_volume(std::size_t node, double p) const
  {
    const auto liquid = [&](double q) {
      return volumes_[node].compliance * q + volumes_[node].oil_volume * gas_volume_change(q);
    };
    if (cavity_nodes_.empty() || !(p < p_cavitation_))
      return liquid(p);
    // cavitating: the liquid holds what it held at p_c, less the cavity
    return liquid(p_cavitation_) + node_compliance(node, p_cavitation_) * (p - p_cavitation_);
  }

  namespace
  {
    /// Flow q through R q + K q|q| = dp (R > 0, K >= 0), and dq/d(dp).
    std::pair<double, double> branch_flow(double R, double K, double dp)
    {
      if (K == 0.0)
        return {(1.0 / R) * dp, 1.0 / R}; // as g dp: the thesis model bit for bit
      const double root = std::sqrt(R * R + 4.0 * K * std::abs(dp));
      const double q    = 2.0 * dp / (R + root); // stable form of (-R + root) / (2K)
      return {q, 1.0 / root};                    // 1 / (R + 2 K |q|)
    }

    struct LeakyBranch
    {
      double q;  ///< flow through the branch
      double dq; ///< dq / d(dp)
      double u;  ///< drop across the valve and its leak
    };

    /// Flow through a turbulent leak orifice, K q|q| = u, and dq/du. A pure
    /// square root has an infinite conductance at u = 0 (a stiff
    /// integrator's Jacobian); real leak paths turn laminar at small flows:
    /// q = u / sqrt(K sqrt(u^2 + u_t^2)), u_t = 1 kPa, which is the square
    /// root to (u_t / u)^2 / 4 (2.5e-3 at 10 kPa) and has the conductance
    /// 1 / sqrt(K u_t) at u = 0.
    std::pair<double, double> turbulent_leak_flow(double K, double u)
    {
      constexpr double u_t = 1e3;
      const double     s   = u * u + u_t * u_t;
      const double     r   = std::sqrt(s);
      const double     q   = u / std::sqrt(K * r);
      return {q, (0.5 * u * u + u_t * u_t) / (s * std::sqrt(K * r))};
    }

    /// The root of an increasing function in [lo, hi] (negative at lo,
    /// positive at hi) by Newton from u, bisecting where a step would leave
    /// the bracket; stops when a step or the bracket is within tol.
    /// value_and_slope(u) gives {F(u), F'(u)}.
    template <typename ValueAndSlope>
    double bracketed_newton(const ValueAndSlope &value_and_slope, double u, double lo, double hi, double tol)
    {
      for (int it = 0; it < 100; ++it)
        {
          const auto [F, dF] = value_and_slope(u);
          if (F == 0.0)
            break;
          (F > 0 ? hi : lo) = u;
          double next       = u - F / dF;
          if (!(next > lo && next < hi))
            next = 0.5 * (lo + hi);
          const bool done = std::abs(next - u) <= tol || hi - lo <= tol;
          u               = next;
          if (done)
            break;
        }
      return u;
    }

    /// A valve (R q + K q|q| = u) and its leak paths side by side, a
    /// laminar one (q = u / R_L; R_L = 0: none) and a turbulent orifice
    /// (turbulent_leak_flow, K_L): their flow at the drop u, and dq/du.
    std::pair<double, double> valve_and_leaks(double R, double K, double R_L, double K_L, double u)
    {
      const double G_L      = R_L > 0 ? 1.0 / R_L : 0.0;
      const auto [qv, gv]   = branch_flow(R, K, u);
      const auto [qt, gt]   = turbulent_leak_flow(K_L, u);
      return {qv + G_L * u + qt, gv + G_L + gt};
    }

    /// A valve (R q + K q|q| = u) and its leak paths side by side - a
    /// laminar one (q = u / R_L; R_L = 0: none) and a turbulent orifice
    /// (turbulent_leak_flow, K_L) - in series with a line of resistance
    /// R_s: the flow for the drop dp across all. u + R_s q(u) = dp is
    /// increasing in u: Newton, bracketed by 0 and dp.
    LeakyBranch leaky_branch_flow(double R, double K, double R_L, double K_L, double R_s, double dp)
    {
      const auto pair = [&](double u) { return valve_and_leaks(R, K, R_L, K_L, u); };
      double u = dp;
      if (R_s > 0 && dp != 0.0)
        {
          const double guess = dp / (1.0 + R_s * pair(0.0).second); // the linearised guess
          u = bracketed_newton(
            [&](double v) {
              const auto [q, g] = pair(v);
              return std::pair{v + R_s * q - dp, 1.0 + R_s * g};
            },
            guess, std::min(0.0, dp), std::max(0.0, dp), 1e-14 * std::abs(dp));
        }
      const auto [q, g] = pair(u);
      return {q, g / (1.0 + R_s * g), u};
    }
    /// The inlet branch (junction -> inlet line R4 -> valve R2 with a
    /// quadratic drop K2 q|q| and its leaks -> chamber; s2 the moving
    /// reed's source) meeting the accumulator's (g5) and the low side's (g6)
    /// lines at the junction, which has no capacitance.
    struct InletBranch
    {
      double R2, R4, K2, R_L, K_L, s2, g5, g6, p_bias;
    };
    struct InletSolution
    {
      double p_junction = 0, q = 0, u = 0; ///< u: the drop across the valve and its leaks (turbulent leak)
    };

    /// Kirchhoff at the junction for the inlet branch b: its pressure and
    /// the branch's flow (quadratic: a turbulent leak beside the valve).
    InletSolution inlet_junction(const InletBranch &b, double p_ch, double p_acc, double p_l, bool quadratic)
    {
      const double g5 = b.g5, g6 = b.g6, s2 = b.s2, K2 = b.K2;
      InletSolution out;
      // the inlet branch without a turbulent leak, junction -> chamber: flow and its derivative
      const auto inlet_branch = [&](double dp) { return branch_flow(b.R2 + b.R4, K2, dp + s2); };
      if (K2 == 0.0 && !quadratic)
        {
          const double g24 = 1.0 / (b.R2 + b.R4);
          out.p_junction   = (g24 * (p_ch - s2) + g5 * p_acc + g6 * p_l) / (g24 + g5 + g6);
          out.q            = g24 * (out.p_junction - p_ch + s2);
        }
      else if (quadratic)
        {
          // One equation in the drop u across the inlet valve and its leaks,
          // q = Q(u) through them: the branch gives the junction's pressure,
          // p_a = p_ch - s2 + u + R4 Q(u), and Kirchhoff there,
          // g5 (p_a - p_acc) + g6 (p_a - p_l) + Q(u) = 0, becomes
          //   F(u) = G u + (1 + G R4) Q(u) + c0 = 0,  G = g5 + g6,
          //   c0 = g5 (p_ch - s2 - p_acc) + g6 (p_ch - s2 - p_l),
          // increasing in u, its root between 0 and -c0 / G (Q has u's sign):
          // Newton, bracketed (one solve, not one per step of an outer one).
          const double G  = g5 + g6;
          const double c0 = g5 * (p_ch - s2 - p_acc) + g6 * (p_ch - s2 - p_l);
          const auto   Q  = [&](double u) { return valve_and_leaks(b.R2, K2, b.R_L, b.K_L, u); };
          double       u  = 0.0;
          if (c0 != 0.0)
            {
              const double end = -c0 / G;
              const double A   = 1.0 + G * b.R4;
              u                = bracketed_newton(
                [&](double v) {
                  const auto [q, dq] = Q(v);
                  return std::pair{G * v + A * q + c0, G + A * dq};
                },
                end / (1.0 + A * Q(0.0).second / G), // the linearised guess
                std::min(0.0, end), std::max(0.0, end), 1e-14 * std::abs(end));
            }
          out.u          = u;
          out.q          = Q(u).first;
          out.p_junction = p_ch - s2 + u + b.R4 * out.q;
        }
      else
        { // Kirchhoff at the junction, g5 (p_a - p_acc) + g6 (p_a - p_l) + q_in(p_a - p_ch) = 0,
          // monotone in p_a: Newton from the linear solution, bracketed.
          const double g24 = 1.0 / (b.R2 + b.R4);
          double       p_a = (g24 * p_ch + g5 * p_acc + g6 * p_l) / (g24 + g5 + g6);
          double       lo = std::min({p_ch, p_acc, p_l}), hi = std::max({p_ch, p_acc, p_l});
          for (int it = 0; it < 60; ++it)
            {
              const auto [q, dq] = inlet_branch(p_a - p_ch);
              const double F     = g5 * (p_a - p_acc) + g6 * (p_a - p_l) + q;
              (F > 0 ? hi : lo)  = p_a;
              double next        = p_a - F / (g5 + g6 + dq);
              if (!(next > lo && next < hi))
                next = 0.5 * (lo + hi);
              if (std::abs(next - p_a) <= 1e-13 * (std::abs(p_a) + b.p_bias) || hi - lo <= 0)
                {
                  p_a = next;
                  break;
                }
              p_a = next;
            }
          out.p_junction = p_a;
          out.q          = inlet_branch(p_a - p_ch).first;
        }
      return out;
    }
    /// The mechanics' rows of the thesis model's Jacobian (eqs. 3.6-3.8):
    /// piston, chamber fluid, output piston; constant.
    void mechanics_jacobian(const ModelConstants &c, DenseView J)
    {
      using namespace state;
      J(piston_x, piston_v) = 1.0;
      J(piston_v, piston_x) = -(c.k_eff + c.k_f) / c.m_eff;
      J(piston_v, piston_v) = -(c.b_f + c.b_eff) / c.m_eff;
      J(piston_v, fluid_x)  = c.k_f / c.m_eff;
      J(piston_v, fluid_v)  = c.b_f / c.m_eff;
      J(fluid_x, fluid_v)   = 1.0;
      J(fluid_v, piston_x)  = c.k_f / c.m_f;
      J(fluid_v, piston_v)  = c.b_f / c.m_f;
      J(fluid_v, fluid_x)   = -c.k_f / c.m_f;
      J(fluid_v, fluid_v)   = -c.b_f / c.m_f;
      J(fluid_v, chamber_p) = -c.A_pi / c.m_f;
      J(actuator_x, actuator_v) = 1.0;
      J(actuator_v, actuator_x) = -c.k_l / c.m_l;
      J(actuator_v, actuator_v) = -c.b_l / c.m_l;
      J(actuator_v, high_p)     = c.A_po / c.m_l;
      J(actuator_v, low_p)      = -c.A_po / c.m_l;
    }
  } // namespace

  std::vector<double> Model::typical_sizes() const
  {
    std::vector<double> s(state::count);
    const double        x = 1e-5, v = 1e-2, p = 1e6;
    s[state::piston_x] = s[state::fluid_x] = s[state::actuator_x] = x;
    s[state::outlet_reed_x] = s[state::inlet_reed_x] = x;
    // Velocities of the fast oscillators are sized by how fast they ring.
    // With 0.01 m/s for all of them, CVODE followed the chamber fluid mass's
    // ringing (about 145 kHz, against the piston and the chamber's oil) to
    // 1e-6 m/s, which in that mode's energy is 0.7 Pa of chamber pressure
    // against the pressure's own 100 Pa: that ringing set 60 % of the steps
    // of a loaded run. Now 1 m/s for the fluid mass (its tolerance, 1e-4
    // m/s, is 70 Pa in that energy), 0.1 m/s for the piston, 0.04 m/s for the reed tips,
    // each at or below its position's size times its mode's angular
    // frequency (9, 0.4, 0.04 m/s). The case's rtol then still gives a tight
    // run's mean velocity within 0.02 % where that has one answer
    // (Model.TheCaseToleranceGivesTheAnswerOfATightRunWhereTheAnswerIsDefined),
    // in 1.5-1.9 times fewer steps (docs/benchmarks.md).
    s[state::fluid_v]        = 100 * v;
    s[state::piston_v]       = 10 * v;
    s[state::actuator_v]     = v;
    s[state::outlet_reed_v] = s[state::inlet_reed_v] = 4 * v;
    s[state::chamber_p] = s[state::accumulator_p] = s[state::high_p] = s[state::low_p] = p;
    s[state::outlet_volume] = s[state::inlet_volume] = c_.A_pi * x;
    s[state::outlet_pressure_integral] = p * 1e-3;
    s[state::line_flow]      = c_.A_pi * v;
    s[state::coil_current]   = 1.0;
    s[state::outlet_reed2_x] = s[state::inlet_reed2_x] = 0.1 * x;
    s[state::outlet_reed2_v] = s[state::inlet_reed2_v] = v;
    s[state::line_node_p]    = p;
    s.resize(n_states());
    if (n_states() > state::thesis_count)
      for (const auto &c : components_)
        c->typical_sizes(s, c_.A_pi * v, p);
    return s;
  }

  maps::ResistanceMap::Value Model::valve_resistance(std::size_t v,
                                                     std::span<const double> y) const
  {
    if (valves_ == ValveModel::ideal)
      return {closed_[v] ? maps_[v].resistance().closed_resistance() : c_.R_ideal_open, 0.0, false};
    if (closed_[v])
      return {maps_[v].resistance().closed_resistance(), 0.0, false};
    return maps_[v].resistance().evaluate(opening(v, y));
  }

  Flows Model::flows_at(std::span<const double> y) const
  {
    const double p_ch = y[state::chamber_p], p_acc = y[state::accumulator_p];
    const double p_h = y[state::high_p], p_l = y[state::low_p];
    Flows        f;
    f.R1 = valve_resistance(0, y).resistance;
    f.R2 = valve_resistance(1, y).resistance;
    // Each valve's branch law from the components (BranchLaw): a quadratic
    // drop K q|q| through the open valve, leak paths beside it. A laminar
    // leak alone is one parallel resistance, the thesis model's algebra;
    // with a turbulent one the valve and its leaks share one drop u, solved
    // for by leaky_branch_flow.
    const BranchLaw law1 = branch_law(0, y), law2 = branch_law(1, y);
    const bool      quadratic1 = law1.leak_K > 0, quadratic2 = law2.leak_K > 0;
    if (law1.leak_resistance > 0 && !quadratic1)
      f.R1 = f.R1 * law1.leak_resistance / (f.R1 + law1.leak_resistance);
    if (law2.leak_resistance > 0 && !quadratic2)
      f.R2 = f.R2 * law2.leak_resistance / (f.R2 + law2.leak_resistance);
    const double K1 = law1.series_K, K2 = law2.series_K;
    const double g5 = 1.0 / c_.R5, g6 = 1.0 / c_.R6;
    // A moving reed draws q_d = A_m(x) v through its valve at a fixed drop
    // (fluid loading "map"): the valve's drop is R (q - q_d), a pressure
    // source R q_d in the branch. (With a turbulent leak the source stands
    // in the shared drop as well: exact for the laminar parts.)
    f.loading             = {loading(0, y), loading(1, y)};
    const auto   velocity = [&](std::size_t v) { return y[v == 0 ? state::outlet_reed_v : state::inlet_reed_v]; };
    const double q_d1     = f.loading[0] ? f.loading[0]->A_modal * velocity(0) : 0.0;
    const double q_d2     = f.loading[1] ? f.loading[1]->A_modal * velocity(1) : 0.0;
    const double s1 = f.R1 * q_d1, s2 = f.R2 * q_d2;

    // Each valve's branch, its line R_s in series: the flow for a drop dp
    // (and, with a turbulent leak, the drop u across valve and leak).
    double     u_outlet = 0, u_inlet = 0;
    const auto outlet_branch = [&](double R_s, double dp) {
      dp += s1;
      if (!quadratic1)
        return branch_flow(f.R1 + R_s, K1, dp).first;
      const auto b = leaky_branch_flow(f.R1, K1, law1.leak_resistance, law1.leak_K, R_s, dp);
      u_outlet     = b.u;
      return b.q;
    };
    if (outlet_element_) // valve into its node, the element out of it
      {
        f.q_outlet = outlet_branch(0.0, p_ch - y[outlet_node_]);
        f.q_line   = outlet_element_->high_side_inflow(y); // into the high side
      }
    else
      f.q_outlet = f.q_line = outlet_branch(c_.R3, p_ch - p_h);
    const auto inlet = inlet_junction({f.R2, c_.R4, K2, law2.leak_resistance, law2.leak_K, s2, g5, g6, c_.p_bias},
                                      p_ch, p_acc, p_l, quadratic2);
    f.p_junction     = inlet.p_junction;
    f.q_inlet        = inlet.q;
    u_inlet          = inlet.u;
    f.q_accumulator = g5 * (f.p_junction - p_acc);
    f.q_low         = g6 * (f.p_junction - p_l);
    // valve pressure drops: R q + K q|q| (p_o = (R1 p_h + R3 p_ch)/(R1 + R3) when linear)
    // (with a turbulent leak the valve carries only part of q: its drop is u)
    f.p_outlet = quadratic1 ? p_ch - u_outlet
                                : p_ch - f.R1 * (f.q_outlet - q_d1) - K1 * f.q_outlet * std::abs(f.q_outlet);
    f.p_inlet  = quadratic2 ? p_ch + u_inlet
                                : p_ch + f.R2 * (f.q_inlet - q_d2) + K2 * f.q_inlet * std::abs(f.q_inlet);
    f.outlet_force  = force_area(0, y).area * (p_ch - f.p_outlet);
    f.inlet_force   = force_area(1, y).area * (f.p_inlet - p_ch);
    return f;
  }

  BranchLaw Model::branch_law(std::size_t v, std::span<const double> y) const
  {
    BranchLaw law;
    if (components_.empty())
      return law;
    const auto x = valves_ == ValveModel::ideal || closed_[v] ? std::nullopt : std::optional<double>(opening(v, y));
    for (const auto &c : components_)
      c->add_to_branch(v, x, law);
    return law;
  }

  void Model::rhs_at(double t, std::span<const double> y, std::span<double> ydot) const
  {
    using namespace state;
    const Flows  f    = flows_at(y);
    const double F_td = c_.force_per_ampere * current_A(t, y); // eq. 3.1

    ydot[piston_x] = y[piston_v];
    ydot[piston_v] = (F_td - (c_.b_f + c_.b_eff) * y[piston_v] + c_.b_f * y[fluid_v] -
                      (c_.k_eff + c_.k_f) * y[piston_x] + c_.k_f * y[fluid_x]) /
                     c_.m_eff;
    ydot[fluid_x] = y[fluid_v];
    ydot[fluid_v] = (c_.b_f * (y[piston_v] - y[fluid_v]) + c_.k_f * (y[piston_x] - y[fluid_x]) -
                     y[chamber_p] * c_.A_pi) /
                    c_.m_f;
    ydot[actuator_x] = y[actuator_v];
    double load_force = (y[high_p] - y[low_p]) * c_.A_po - c_.b_l * y[actuator_v] - c_.k_l * y[actuator_x];
    for (const auto &c : components_)
      load_force -= c->actuator_force(y);
    ydot[actuator_v] = load_force / c_.m_l;

    const std::array<double, 2> force{f.outlet_force, f.inlet_force};
    for (std::size_t v = 0; v < 2; ++v)
      {
        const std::size_t ix  = v == 0 ? outlet_reed_x : inlet_reed_x;
        const std::size_t ix2 = ReedSecondMode::x_state(v);
        if (ydot.size() > ix2 + 1)
          ydot[ix2] = ydot[ix2 + 1] = 0.0;
        const bool held = closed_[v] || at_stop_[v];
        const auto &two = c_.second_mode;
        if (valves_ == ValveModel::ideal || (held && !two))
          {
            ydot[ix] = ydot[ix + 1] = 0.0; // on the seat or the stop: held by its reaction
            continue;
          }
        // Two modes: a held tip's reaction acts on both (reed_second_mode.h)
        const double reaction = held ? two->seat_reaction(c_.reed, force[v], v, y) : 0.0;
        ydot[ix] = y[ix + 1];
        if (const auto &l = f.loading[v])
          { // Lagrange with the mass M(x) = (m_r + m_a(x)) / gamma: M x'' + M'(x) x'^2 / 2 = F - b_s x' - F_film - k x,
            // F_film = c(x) x' / gamma, its suction limited (film_force)
            const double x = y[ix], u = y[ix + 1], g = loading_scale_[v];
            ydot[ix + 1] = (force[v] + reaction - structural_damping_[v] * u - film_force(v, y, f) -
                            0.5 * l->added_mass_slope / g * u * u - c_.reed.stiffness * x) /
                           ((c_.reed.mass + l->added_mass) / g);
          }
        else
          ydot[ix + 1] = reed_acceleration(c_.reed, y[ix], y[ix + 1], force[v] + reaction);
        if (two)
          two->rhs(v, y, force[v] + reaction, c_.reed.mass, ydot);
      }

    // Compliances, with the free air's pressure dependence.
    const double C_ch = c_.C_ch + c_.V_ch * gas_compliance(y[chamber_p]);
    const double C_h  = c_.C_h + c_.V_h * gas_compliance(y[high_p]);
    const double C_l  = c_.C_l + c_.V_l * gas_compliance(y[low_p]);
    ydot[chamber_p]     = (c_.A_pi * y[piston_v] + f.q_inlet - f.q_outlet) / C_ch;
    ydot[accumulator_p] = f.q_accumulator / c_.C_acc;
    ydot[high_p]        = (f.q_line - c_.A_po * y[actuator_v]) / C_h;
    ydot[low_p]         = (f.q_low + c_.A_po * y[actuator_v]) / C_l;
    ydot[outlet_volume] = f.q_outlet;
    ydot[inlet_volume]  = f.q_inlet;
    ydot[outlet_pressure_integral] = f.p_outlet;

    if (ydot.size() == thesis_count)
      return;
    ydot[line_flow] = ydot[line_node_p] = 0.0; // the outlet line's, where it is off
    ydot[coil_current] = 0.0;
    for (const auto &c : components_)
      c->own_rhs(t, y, *this, f, ydot);
  }

  std::vector<std::vector<std::size_t>> Model::rhs_reads() const
  {
    using namespace state;
    const std::size_t                     n = n_states();
    std::vector<std::vector<std::size_t>> r(n);
    // flows(): the pressures, each valve's opening (its second mode with
    // two modes), the reeds' velocities with fluid loading (displaced flow,
    // film), and the outlet line's first node and last segment.
    std::vector<std::size_t> flow{chamber_p, accumulator_p, high_p, low_p, outlet_reed_x, inlet_reed_x};
    if (c_.second_mode)
      flow.insert(flow.end(), {outlet_reed2_x, inlet_reed2_x});
    if (loading_)
      flow.insert(flow.end(), {outlet_reed_v, inlet_reed_v});
    for (const auto &c : components_)
      for (std::size_t i : c->flow_reads())
        flow.push_back(i);
    const auto with_flows = [&](std::initializer_list<std::size_t> own) {
      std::vector<std::size_t> v = flow;
      v.insert(v.end(), own);
      return v;
    };
    r[piston_x]   = {piston_v};
    r[piston_v]   = {piston_x, piston_v, fluid_x, fluid_v};
    r[fluid_x]    = {fluid_v};
    r[fluid_v]    = {piston_x, piston_v, fluid_x, fluid_v, chamber_p};
    r[actuator_x] = {actuator_v};
    r[actuator_v] = {actuator_x, actuator_v, high_p, low_p};
    for (std::size_t ix : {outlet_reed_x, inlet_reed_x})
      {
        r[ix] = {ix + 1};
        // force, loading, film, the seat's reaction on both modes
        r[ix + 1] = with_flows({ix, ix + 1});
      }
    if (n > outlet_reed2_x) // its rows with any effect on (0 where it is off)
      ReedSecondMode::reads(r, flow);
    r[chamber_p]     = with_flows({piston_v});
    r[accumulator_p] = flow;
    r[high_p]        = with_flows({actuator_v});
    r[low_p]         = with_flows({actuator_v});
    r[outlet_volume] = r[inlet_volume] = r[outlet_pressure_integral] = flow;
    if (n == thesis_count)
      return r;
    for (const auto &c : components_)
      c->own_reads(r, flow);
    return r;
  }

  void Model::jacobian_at(std::span<const double> y, DenseView J) const
  {
    using namespace state;
    const double p_ch = y[chamber_p], p_h = y[high_p];
    const auto   r1 = valve_resistance(0, y), r2 = valve_resistance(1, y);
    const double R1 = r1.resistance, R2 = r2.resistance;
    const double R13 = R1 + c_.R3, R24 = R2 + c_.R4;
    const double g13 = 1.0 / R13, g24 = 1.0 / R24, g5 = 1.0 / c_.R5, g6 = 1.0 / c_.R6;
    const double G   = g24 + g5 + g6;
    const Flows  f   = flows_at(y);
    const double p_a = f.p_junction;

    mechanics_jacobian(c_, J);

    // Flow gradients. Columns: the four pressures and the two reed openings.
    // dp_a/dp_ch = g24/G etc.; g13, g24 depend on the reed openings through R1, R2.
    const double a_ch = g24 / G, a_acc = g5 / G, a_l = g6 / G;
    const double dg13_dxo = -r1.slope * g13 * g13;
    const double dg24_dxi = -r2.slope * g24 * g24;
    const double dpa_dg24 = (p_ch - p_a) / G;

    struct Gradient
    {
      double ch = 0, acc = 0, h = 0, l = 0, xo = 0, xi = 0;
    };
    Gradient q_out{g13, 0.0, -g13, 0.0, dg13_dxo * (p_ch - p_h), 0.0};
    Gradient q_in{g24 * (a_ch - 1.0), g24 * a_acc, 0.0, g24 * a_l, 0.0,
                  dg24_dxi * (p_a - p_ch) * (1.0 - g24 / G)};
    Gradient q_acc{g5 * a_ch, g5 * (a_acc - 1.0), 0.0, g5 * a_l, 0.0, g5 * dpa_dg24 * dg24_dxi};
    Gradient q_low{g6 * a_ch, g6 * a_acc, 0.0, g6 * (a_l - 1.0), 0.0, g6 * dpa_dg24 * dg24_dxi};

    const auto put = [&](std::size_t row, const Gradient &g, double scale) {
      J(row, chamber_p) += scale * g.ch;
      J(row, accumulator_p) += scale * g.acc;
      J(row, high_p) += scale * g.h;
      J(row, low_p) += scale * g.l;
      J(row, outlet_reed_x) += scale * g.xo;
      J(row, inlet_reed_x) += scale * g.xi;
    };

    // Reeds: F_o = A(x_o) R1 q_out, F_i = A(x_i) R2 q_in (A = A_r, or A_eff(x) of a map set).
    if (valves_ == ValveModel::dynamic)
      {
        if (!closed_[0] && !at_stop_[0])
          {
            const auto A = force_area(0, y);
            J(outlet_reed_x, outlet_reed_v) = 1.0;
            J(outlet_reed_v, outlet_reed_x) = -c_.reed.stiffness / c_.reed.mass;
            J(outlet_reed_v, outlet_reed_v) = -c_.reed.damping / c_.reed.mass;
            Gradient F{A.area * R1 * g13, 0.0, -A.area * R1 * g13, 0.0,
                       A.area * (p_ch - p_h) * r1.slope * c_.R3 * g13 * g13, 0.0};
            if (A.slope != 0.0) // dA/dx times the valve's pressure drop R1 q_out
              F.xo += A.slope * R1 * f.q_outlet;
            put(outlet_reed_v, F, 1.0 / c_.reed.mass);
          }
        if (!closed_[1] && !at_stop_[1])
          {
            const auto A = force_area(1, y);
            J(inlet_reed_x, inlet_reed_v) = 1.0;
            J(inlet_reed_v, inlet_reed_x) = -c_.reed.stiffness / c_.reed.mass;
            J(inlet_reed_v, inlet_reed_v) = -c_.reed.damping / c_.reed.mass;
            Gradient F{A.area * R2 * q_in.ch, A.area * R2 * q_in.acc, 0.0,
                       A.area * R2 * q_in.l, 0.0,
                       A.area * (r2.slope * f.q_inlet + R2 * q_in.xi)};
            if (A.slope != 0.0)
              F.xi += A.slope * R2 * f.q_inlet;
            put(inlet_reed_v, F, 1.0 / c_.reed.mass);
          }
      }

    // Pressures and integrals.
    J(chamber_p, piston_v) = c_.A_pi / c_.C_ch;
    put(chamber_p, q_in, 1.0 / c_.C_ch);
    put(chamber_p, q_out, -1.0 / c_.C_ch);
    put(accumulator_p, q_acc, 1.0 / c_.C_acc);
    put(high_p, q_out, 1.0 / c_.C_h);
    J(high_p, actuator_v) = -c_.A_po / c_.C_h;
    put(low_p, q_low, 1.0 / c_.C_l);
    J(low_p, actuator_v) = c_.A_po / c_.C_l;
    put(outlet_volume, q_out, 1.0);
    put(inlet_volume, q_in, 1.0);
    // p_o = p_ch - R1 q_out
    Gradient p_o{1.0 - R1 * g13, 0.0, R1 * g13, 0.0,
                 -(r1.slope * f.q_outlet + R1 * q_out.xo), 0.0};
    put(outlet_pressure_integral, p_o, 1.0);
  }

  double Model::driving_pressure(std::size_t v, std::span<const double> y, const Flows &f)
  {
    return v == 0 ? y[state::chamber_p] - y[state::high_p] : f.p_junction - y[state::chamber_p];
  }

  namespace
  {
    /// An ideal valve switches when its pressure difference passes
    /// +-switch_pressure (not 0: see reed_lift_force).
    constexpr double switch_pressure = 1e-6; // [Pa]
  } // namespace

  void Model::roots(double, std::span<const double> y, std::span<double> g) const
  {
    const Flows f = flows(y);
    for (std::size_t v = 0; v < 2; ++v)
      {
        const std::size_t ix = v == 0 ? state::outlet_reed_x : state::inlet_reed_x;
        g[2 * v + 1] = g[4 + 2 * v] = g[5 + 2 * v] = 1.0;
        if (valves_ == ValveModel::ideal)
          {
            double dp = 0;
            with_physical(y, [&](std::span<const double> p) { dp = driving_pressure(v, p, f); });
            // opens when dp rises past +switch_pressure, shuts when it falls past -switch_pressure
            g[2 * v] = closed_[v] ? switch_pressure - dp : dp + switch_pressure;
            continue;
          }
        const double      F   = v == 0 ? f.outlet_force : f.inlet_force;
        const auto       &two = c_.second_mode;
        const double      R   = two ? two->seat_reaction(c_.reed, F, v, y) : 0.0;
        if (at_stop_[v]) // held: leaves when the stop would have to pull
          g[2 * v] = two ? reed_lift_force - R : stop_root(true, y[ix], stop_lift_, F - c_.reed.stiffness * stop_lift_);
        else // seated with two modes: lifts off when the seat would have to pull
          g[2 * v] = reed_root(closed_[v], closed_[v] ? y[ix] : opening(v, y), closed_[v] && two ? -R : F);
        if (!closed_[v] && !at_stop_[v] && stop_lift_ < std::numeric_limits<double>::infinity())
          g[2 * v + 1] = stop_root(false, opening(v, y), stop_lift_, 0.0);
        if (record_events_ && stress_extrema_)
          if (const double rate = root_stress_rate(v, y); rate != 0.0)
            {
              g[4 + 2 * v] = rate;  // falls through 0 at a maximum
              g[5 + 2 * v] = -rate; // and at a minimum
            }
      }
    for (std::size_t k = 0; k < cavity_nodes_.size(); ++k)
      g[8 + k] = cavity_root(cavitating_[k] != 0, y[cavity_nodes_[k]], p_cavitation_);
  }

  bool Model::handle_events(double t, std::span<double> y, std::span<const int> found)
  {
    bool changed = false;
    for (std::size_t v = 0; v < 2; ++v)
      {
        const bool contact = found[2 * v] != 0, stop = found[2 * v + 1] != 0;
        if (contact || stop)
          {
            changed = true;
            if (valves_ == ValveModel::ideal)
              closed_[v] = !closed_[v];
            else if (c_.second_mode)
              two_mode_contact_event(v, t, y, stop && !contact);
            else
              contact_event(v, t, y, stop && !contact);
            continue;
          }
        if (found[4 + 2 * v] != 0 || found[5 + 2 * v] != 0)
          log_event(t, v, found[4 + 2 * v] != 0 ? ReedEvent::stress_maximum : ReedEvent::stress_minimum, 0.0, y);
      }
    for (std::size_t k = 0; k < cavity_nodes_.size(); ++k)
      if (found[8 + k] != 0)
        {
          cavitating_[k] = !cavitating_[k];
          changed        = true;
        }
    return changed;
  }

  void Model::contact_event(std::size_t v, double t, std::span<double> y, bool stop_impact)
  {
    const std::size_t ix = v == 0 ? state::outlet_reed_x : state::inlet_reed_x;
    double           &x = y[ix], &u = y[ix + 1];
    if (stop_impact) // a free reed arrives at its stop
      {
        ++n_stop_impacts_;
        const double speed = u;
        x                  = stop_lift_;
        log_event(t, v, ReedEvent::stop_impact, speed, y);
        const Flows  f   = flows(y);
        const double net = (v == 0 ? f.outlet_force : f.inlet_force) - c_.reed.stiffness * stop_lift_;
        at_stop_[v]      = reed_on_stop(stop_restitution_, false, net, stop_lift_, x, u);
        return;
      }
    if (at_stop_[v]) // released from the stop
      {
        at_stop_[v] = reed_on_stop(stop_restitution_, true, 0.0, stop_lift_, x, u);
        return;
      }
    if (!closed_[v])
      {
        ++n_impacts_;
        x = 0.0; // the force at impact is the force with the reed at x = 0
        log_event(t, v, ReedEvent::seat_impact, -u, y);
      }
    const Flows f = flows(y);
    closed_[v]    = reed_on_root(c_.reed, closed_[v], v == 0 ? f.outlet_force : f.inlet_force, x, u);
  }

  void Model::two_mode_contact_event(std::size_t v, double t, std::span<double> y, bool stop_impact)
  {
    // Two modes: seat and stop hold the tip, not the reed (reed_second_mode.h).
    // At impact the tip rebounds; the modes' difference keeps ringing while
    // the tip is held (rhs). It leaves when its contact would have to pull
    // (roots).
    const auto       &two = *c_.second_mode;
    const std::size_t ix  = ReedSecondMode::first(v), ix2 = ReedSecondMode::x_state(v);
    double           &x1 = y[ix], &x2 = y[ix2];
    if (closed_[v])
      {
        x1 += reed_seat_tolerance - (x1 + x2); // a hair above the seat (reed.h)
        closed_[v] = false;
        return;
      }
    if (at_stop_[v])
      {
        x1 += stop_lift_ - reed_seat_tolerance - (x1 + x2); // a hair below the stop
        at_stop_[v] = false;
        return;
      }
    const double level = stop_impact ? stop_lift_ : 0.0;
    ++(stop_impact ? n_stop_impacts_ : n_impacts_);
    double       rebound = 0;
    const double tip_v   = ReedSecondMode::impact(v, y, level, [&](double tip) {
      return rebound = stop_impact ? -stop_restitution_ * std::max(tip, 0.0) : c_.reed.restitution * std::max(-tip, 0.0);
    });
    // (the event's opening and stress are the positions', set before the rebound)
    log_event(t, v, stop_impact ? ReedEvent::stop_impact : ReedEvent::seat_impact, stop_impact ? tip_v : -tip_v, y);
    if (std::abs(rebound) >= 1e-6)
      return;
    const Flows  f = flows(y);
    const double R = two.seat_reaction(c_.reed, v == 0 ? f.outlet_force : f.inlet_force, v, y);
    if (stop_impact ? R <= reed_lift_force : -R <= reed_lift_force)
      (stop_impact ? at_stop_[v] : closed_[v]) = true; // held
    else
      x1 += stop_impact ? -reed_seat_tolerance : reed_seat_tolerance; // leaves again at once
  }
} // namespace rectify::system
