#include "system/parameters.h"

#include "common/io.h"
#include "common/real_keys.h"
#include "maps/reed_map.h"

#include <cmath>
#include <numbers>
#include <filesystem>
#include <optional>

#include "common/reed_material.h"
#include "common/valve_geometry.h"

namespace rectify::system
{
  namespace
  {
    const Bounds positive     = Bounds::positive();
    const Bounds non_negative = Bounds::non_negative();

    /// InputError naming the case file, [table] key, its value and where it
    /// was looked for, unless `path` (the value resolved) exists as a file
    /// (or, with `folder`, a folder). `maker`: the command that writes one.
    void require_existing(const CaseFile &f, const std::string &table, const std::string &key,
                          const std::filesystem::path &path, bool folder, const std::string &maker = "")
    {
      if (folder ? std::filesystem::is_directory(path) : std::filesystem::is_regular_file(path))
        return;
      throw InputError(f.where(table, key) + " = '" + f.text(table, key, "") + "': no such " +
                       (folder ? "folder" : "file") + " ('" + path.string() +
                       "', relative to the case file's folder)" + (maker.empty() ? "" : "; `" + maker + "` writes one"));
    }
  } // namespace

  const RealKeys<SolverParameters> &solver_keys()
  {
    using T = SolverParameters;
    static const RealKeys<T> keys{
      {"relative_tolerance", &T::relative_tolerance, Bounds::closed(1e-12, 1e-2), false},
      {"absolute_tolerance_factor", &T::absolute_tolerance_factor, Bounds::closed(1e-6, 1e6), false},
      {"samples_per_cycle", &T::samples_per_cycle, Bounds::closed(4, 1e5), false},
      {"max_steps_per_cycle", &T::max_steps_per_cycle, Bounds::closed(100, 1e9), false}};
    return keys;
  }

  // Each struct's real case keys, declared once (common/real_keys.h).
  namespace
  {
    const RealKeys<TransducerParameters> &transducer_keys()
    {
      using T = TransducerParameters;
      static const RealKeys<T> keys{
        {"rod_youngs_modulus_Pa", &T::rod_youngs_modulus_Pa, positive},
        {"rod_area_m2", &T::rod_area_m2, positive},
        {"rod_length_m", &T::rod_length_m, positive},
        {"diaphragm_stiffness_N_per_m", &T::diaphragm_stiffness_N_per_m, non_negative},
        {"effective_mass_kg", &T::effective_mass_kg, positive},
        {"damping_ratio", &T::damping_ratio, non_negative},
        {"coil_turns", &T::coil_turns, positive},
        {"piezomagnetic_coefficient_m_per_A", &T::piezomagnetic_coefficient_m_per_A, positive},
        {"coil_resistance_ohm", &T::coil_resistance_ohm, positive},
        {"coil_inductance_H", &T::coil_inductance_H, positive}};
      return keys;
    }

    const RealKeys<ChamberParameters> &chamber_keys()
    {
      using T = ChamberParameters;
      static const RealKeys<T> keys{{"height_m", &T::height_m, positive},
                                    {"piston_area_m2", &T::piston_area_m2, positive},
                                    {"fluid_damping_ratio", &T::fluid_damping_ratio, non_negative}};
      return keys;
    }

    /// The reed's: k_r and m_r first (a reed map or a map set may replace
    /// them), then those read after the reed's properties are known.
    const RealKeys<ReedParameters> &reed_keys()
    {
      using T = ReedParameters;
      static const RealKeys<T> keys{
        {"stiffness_N_per_m", &T::stiffness_N_per_m, positive},
        {"effective_mass_kg", &T::effective_mass_kg, positive},
        {"damping_ratio", &T::damping_ratio, non_negative},
        {"pressure_area_m2", &T::pressure_area_m2, positive},
        {"restitution", &T::restitution, Bounds{0.0, 1.0, true, false}},
        {"second_mode_frequency_Hz", &T::second_mode_frequency_Hz, non_negative},
        // the map's squeeze film: read and summarised, not among the keys [uncertain] may name
        {"structural_damping_ratio", &T::structural_damping_ratio, Bounds{0.0, 1.0, true, false}, false},
        {"seat_film_m", &T::seat_film_m, ReedParameters::seat_film_bounds(), false},
        {"film_cavitation_pressure_Pa", &T::film_cavitation_pressure_Pa, Bounds::closed(0.0, 1e8), false},
        {"stop_restitution", &T::stop_restitution, Bounds{0.0, 1.0, true, false}}};
      return keys;
    }
    constexpr std::size_t reed_properties = 2; ///< reed_keys()' first two: k_r, m_r

    const RealKeys<ValveParameters> &valve_keys()
    {
      using T = ValveParameters;
      static const RealKeys<T> keys{
        {"ideal_open_resistance_Pa_s_per_m3", &T::ideal_open_resistance_Pa_s_per_m3, positive},
        {"leak_resistance_Pa_s_per_m3", &T::leak_resistance_Pa_s_per_m3, non_negative},
        {"leak_area_m2", &T::leak_area_m2, non_negative},
        {"orifice_discharge_coefficient", &T::orifice_discharge_coefficient, Bounds::closed(0.0, 10.0)},
        {"orifice_perimeter_m", &T::orifice_perimeter_m, non_negative}};
      return keys;
    }

    const RealKeys<LineParameters> &line_keys()
    {
      using T = LineParameters;
      static const RealKeys<T> keys{
        {"diameter_m", &T::diameter_m, positive},
        {"length_m", &T::length_m, positive},
        {"outlet_inertance_Pa_s2_per_m3", &T::outlet_inertance_Pa_s2_per_m3, non_negative}};
      return keys;
    }

    const RealKeys<CylinderParameters> &cylinder_keys()
    {
      using T = CylinderParameters;
      static const RealKeys<T> keys{{"piston_area_m2", &T::piston_area_m2, positive},
                                    {"wetted_length_m", &T::wetted_length_m, positive},
                                    {"high_side_fraction", &T::high_side_fraction, Bounds::open(0.0, 1.0)},
                                    {"seal_compliance_m3_per_Pa", &T::seal_compliance_m3_per_Pa, non_negative}};
      return keys;
    }

    const RealKeys<AccumulatorParameters> &accumulator_keys()
    {
      using T = AccumulatorParameters;
      static const RealKeys<T> keys{{"gas_volume_m3", &T::gas_volume_m3, positive}};
      return keys;
    }

    const RealKeys<LoadParameters> &load_keys()
    {
      using T = LoadParameters;
      static const RealKeys<T> keys{
        {"mass_kg", &T::mass_kg, positive},
        {"damping_N_s_per_m", &T::damping_N_s_per_m, non_negative},
        {"stiffness_N_per_m", &T::stiffness_N_per_m, non_negative},
        {"no_flow_mass_kg", &T::no_flow_mass_kg, positive},
        {"coulomb_friction_N", &T::coulomb_friction_N, non_negative},
        {"friction_velocity_scale_m_per_s", &T::friction_velocity_scale_m_per_s, positive},
        {"static_friction_ratio", &T::static_friction_ratio, Bounds::closed(1.0, 100.0)},
        {"stribeck_velocity_m_per_s", &T::stribeck_velocity_m_per_s, positive}};
      return keys;
    }

    const RealKeys<DriveParameters> &drive_keys()
    {
      using T = DriveParameters;
      static const RealKeys<T> keys{{"current_pp_A", &T::current_pp_A, DriveParameters::current_pp_bounds()},
                                    {"current_bias_A", &T::current_bias_A, DriveParameters::current_bias_bounds()}};
      return keys;
    }

    /// Reads keys [first, last) of a table into p.
  } // namespace

  double TransducerParameters::rod_stiffness_N_per_m() const
  {
    return rod_youngs_modulus_Pa * rod_area_m2 / rod_length_m;
  }

  double TransducerParameters::force_per_ampere_N_per_A() const
  {
    return coil_turns * piezomagnetic_coefficient_m_per_A * rod_stiffness_N_per_m();
  }

  TransducerParameters TransducerParameters::from_case(const CaseFile &f)
  {
    TransducerParameters p;
    read_reals(f, "transducer", transducer_keys(), p);
    return p;
  }

  ChamberParameters ChamberParameters::from_case(const CaseFile &f)
  {
    ChamberParameters p;
    read_reals(f, "chamber", chamber_keys(), p);
    return p;
  }

  ReedParameters ReedParameters::from_case(const CaseFile &f)
  {
    ReedParameters    p;
    const std::string t = "reed";
    read_reals(f, t, reed_keys(), p, 0, reed_properties);
    const std::string map = f.text(t, "properties_map", "");
    const double      thickness =
      f.real(t, "properties_thickness_m", 0.127e-3, positive);
    p.properties_mass = f.text(t, "properties_mass", p.properties_mass, {"eq321", "modal-in-fluid"});
    const std::string mass_column =
      p.properties_mass == "eq321" ? "effective_mass_eq321_kg" : "modal_mass_in_fluid_kg";
    if (!map.empty())
      {
        if (f.has(t, "stiffness_N_per_m") || f.has(t, "effective_mass_kg"))
          throw InputError(f.where(t, "properties_map") +
                           ": give either properties_map or stiffness_N_per_m and "
                           "effective_mass_kg, not both");
        const auto path = f.resolve(map);
        require_existing(f, t, "properties_map", path, false, "rectify map-stiffness");
        const auto at   = maps::ReedMap::read(path).at(thickness, mass_column, f.where(t, "properties_thickness_m"));
        if (!at.has_stress())
          throw InputError(f.where(t, "properties_map") + " = \"" + map +
                           "\": the reed map has no root_stress_per_opening_Pa_per_m column: it gives the reed's "
                           "stiffness and mass but not its root stress, which the run's Goodman factor needs; "
                           "rebuild it with this version's rectify map-stiffness");
        p.stiffness_N_per_m = at.stiffness_N_per_m;
        p.effective_mass_kg = at.mass_kg;
        p.source = path.string() + " at " + format_number(thickness) + " m (" + mass_column + ")";
        p.root_stress_per_opening_Pa_per_m             = at.root_stress_per_opening_Pa_per_m;
        p.second_mode_root_stress_per_opening_Pa_per_m = at.second_mode_root_stress_per_opening_Pa_per_m;
        p.stress_source = "FE root stress of reed map " + path.string() + " at " + format_number(thickness) +
                          " m (width mean; its corners " + format_number(at.root_stress_concentration) +
                          " x that, four thicknesses off the clamp)";
      }
    else if (f.has(t, "properties_thickness_m"))
      throw InputError(f.where(t, "properties_thickness_m") + ": read only with properties_map (the "
                       "reed map it picks a thickness from); without one, give stiffness_N_per_m and "
                       "effective_mass_kg");
    // The reed's own frequency: above 1 MHz (1e30 N/m on the reference mass:
    // 7e17 Hz) no step CVODE can take resolves it; the model's fastest
    // physical mode, the chamber's oil, is about 145 kHz.
    const double f_reed = p.natural_frequency_Hz();
    if (!(f_reed <= 1e6))
      throw InputError(f.where(t, map.empty() ? "stiffness_N_per_m" : "properties_map") + ": k_r = " +
                       format_number(p.stiffness_N_per_m) + " N/m with m_r = " +
                       format_number(p.effective_mass_kg) + " kg gives the reed a natural frequency of " +
                       format_number(f_reed) + " Hz; at most 1e6 Hz");
    read_reals(f, t, reed_keys(), p, reed_properties);
    p.fluid_loading = f.text(t, "fluid_loading", p.fluid_loading, {"thesis", "map"});
    if (p.fluid_loading == "thesis" && f.has(t, "structural_damping_ratio"))
      throw InputError(f.where(t, "structural_damping_ratio") +
                       ": read only with fluid_loading = \"map\" (the thesis's damping_ratio holds all of it)");
    p.film_suction_limit = f.text(t, "film_suction_limit", p.film_suction_limit, {"cavitation", "none"});
    for (const char *key : {"seat_film_m", "film_suction_limit", "film_cavitation_pressure_Pa"})
      if (p.fluid_loading == "thesis" && f.has(t, key))
        throw InputError(f.where(t, key) + ": read only with fluid_loading = \"map\" (the squeeze film comes "
                         "from the map sets' loading tables)");
    if (p.second_mode_frequency_Hz > 0.0 &&
        p.second_mode_frequency_Hz <= p.natural_frequency_Hz())
      throw InputError(f.where(t, "second_mode_frequency_Hz") + " = " +
                       format_number(p.second_mode_frequency_Hz) +
                       ": must be above the first mode's " +
                       format_number(p.natural_frequency_Hz()) +
                       " Hz (or 0 for none)");
    p.stop = f.text(t, "stop", p.stop, {"on", "off"});
    return p;
  }

  ValveParameters ValveParameters::from_case(const CaseFile &f)
  {
    ValveParameters   p;
    const std::string t = "valves";
    const std::string both = f.text(t, "map_set", "");
    for (std::size_t v = 0; v < 2; ++v)
      {
        const std::string key = v == 0 ? "outlet_map_set" : "inlet_map_set";
        const std::string one = f.text(t, key, "");
        if (!one.empty() && !both.empty())
          throw InputError(f.where(t, key) + ": give map_set (both valves) or " + key + ", not both");
        const std::string dir = one.empty() ? both : one;
        p.map_set[v]          = dir.empty() ? "" : f.resolve(dir).string();
      }
    for (const char *key : {"resistance_map", "interpolation"})
      if (!p.map_set[0].empty() && !p.map_set[1].empty() && f.has(t, key))
        throw InputError(f.where(t, key) + ": both valves read their map sets, which give R(x) and its "
                         "interpolation; remove " + key);
    p.resistance_map =
      f.resolve(f.text(t, "resistance_map", "thesis-resistance.csv")).string();
    // A valve without a map set reads the R(x) map: a missing one that the
    // case names is reported with the case file and the key, before any work
    // (the default is looked for only by the commands that read it).
    if ((p.map_set[0].empty() || p.map_set[1].empty()) && f.has(t, "resistance_map"))
      require_existing(f, t, "resistance_map", p.resistance_map, false);
    p.interpolation = f.text(t, "interpolation", p.interpolation, {"monotone-cubic", "log-linear", "linear", "log-log"});
    p.out_of_range  = f.text(t, "out_of_range", p.out_of_range, {"hold", "error"});
    read_reals(f, t, valve_keys(), p);
    return p;
  }

  double LineParameters::resistance_Pa_s_per_m3(double viscosity_Pa_s) const
  {
    return 128.0 * viscosity_Pa_s * length_m / (std::numbers::pi * std::pow(diameter_m, 4));
  }

  LineParameters LineParameters::from_case(const CaseFile &f)
  {
    LineParameters    p;
    const std::string t = "lines";
    read_reals(f, t, line_keys(), p);
    p.outlet_line_segments = f.integer(t, "outlet_line_segments", p.outlet_line_segments, 1, 64);
    return p;
  }

  CylinderParameters CylinderParameters::from_case(const CaseFile &f)
  {
    CylinderParameters p;
    read_reals(f, "cylinder", cylinder_keys(), p);
    return p;
  }

  AccumulatorParameters AccumulatorParameters::from_case(const CaseFile &f)
  {
    AccumulatorParameters p;
    read_reals(f, "accumulator", accumulator_keys(), p);
    return p;
  }

  LoadParameters LoadParameters::from_case(const CaseFile &f)
  {
    LoadParameters p;
    read_reals(f, "load", load_keys(), p);
    return p;
  }

  DriveParameters DriveParameters::from_case(const CaseFile &f)
  {
    DriveParameters   p;
    const std::string t = "drive";
    read_reals(f, t, drive_keys(), p);
    p.waveform       = f.text(t, "waveform", p.waveform);
    if (p.waveform != "sine")
      {
        p.waveform = f.resolve(p.waveform).string();
        require_existing(f, t, "waveform", p.waveform, false); // "sine" or a CSV
      }
    p.coil_dynamics = f.text(t, "coil_dynamics", p.coil_dynamics, {"off", "on"});
    return p;
  }

  SolverParameters SolverParameters::from_case(const CaseFile &f)
  {
    SolverParameters  p;
    const std::string t = "solver";
    read_reals(f, t, solver_keys(), p);
    p.samples_per_cycle = std::round(p.samples_per_cycle);
    p.jacobian          = f.text(t, "jacobian", p.jacobian, {"analytic", "finite-difference"});
    return p;
  }

  namespace
  {
    /// Checks each valve's map set against the case and takes the reed's
    /// stiffness and mass from it (the same reed for both valves).
    void apply_map_sets(const CaseFile &f, SystemParameters &p, bool override_case = false)
    {
      if (p.valves.map_set[0].empty() && p.valves.map_set[1].empty())
        return;
      const nlohmann::json tables =
        maps::physical_tables(ValveGeometry::from_case(f), p.fluid, ReedMaterial::from_case(f));
      std::optional<maps::ReedProperties> reed;
      std::string                         reed_from;
      for (std::size_t v = 0; v < 2; ++v)
        {
          if (p.valves.map_set[v].empty())
            continue;
          if (!override_case) // --map-set: MapSet::read names the folder
            require_existing(f, "valves",
                             f.has("valves", "map_set") ? "map_set" : v == 0 ? "outlet_map_set" : "inlet_map_set",
                             p.valves.map_set[v], true, "rectify design");
          const auto set = maps::MapSet::read(p.valves.map_set[v]);
          set.check_matches(tables, f.name());
          if (!set.reed())
            continue;
          if (reed && std::abs(reed->stiffness_N_per_m / set.reed()->stiffness_N_per_m - 1) > 1e-12)
            throw InputError("the outlet's map set '" + reed_from + "' and the inlet's '" + p.valves.map_set[v] +
                             "' hold different reeds (k_r " + format_number(reed->stiffness_N_per_m) + " and " +
                             format_number(set.reed()->stiffness_N_per_m) +
                             " N/m); the model has one reed for both valves");
          reed      = set.reed();
          reed_from = p.valves.map_set[v];
        }
      if (!override_case && f.has("reed", "pressure_area_m2") && !p.valves.map_set[0].empty() &&
          !p.valves.map_set[1].empty())
        throw InputError(f.where("reed", "pressure_area_m2") +
                         ": the map sets give the force on the reeds (A_eff(x), and the seated area); remove it");
      if (!reed)
        return;
      for (const char *key : {"stiffness_N_per_m", "effective_mass_kg", "properties_map"})
        if (!override_case && f.has("reed", key))
          throw InputError(f.where("reed", key) + ": the map set '" + reed_from +
                           "' gives the reed's stiffness and mass; remove " + key);
      if (!reed->has_stress())
        throw InputError("map set '" + reed_from + "' (manifest.json, reed): no root_stress_per_opening_Pa_per_m: "
                         "it gives the reed but not its root stress, which the run's Goodman factor needs; "
                         "rebuild it with this version's rectify design");
      p.reed.root_stress_per_opening_Pa_per_m             = reed->root_stress_per_opening_Pa_per_m;
      p.reed.second_mode_root_stress_per_opening_Pa_per_m = reed->second_mode_root_stress_per_opening_Pa_per_m;
      p.reed.stress_source = "FE root stress of map set " + reed_from + " (width mean; its corners " +
                             format_number(reed->root_stress_concentration) + " x that, four thicknesses off the clamp)";
      const bool eq321 = p.reed.properties_mass == "eq321";
      p.reed.stiffness_N_per_m = reed->stiffness_N_per_m;
      p.reed.effective_mass_kg = eq321 ? reed->effective_mass_eq321_kg : reed->modal_mass_in_fluid_kg;
      p.reed.source = "map set " + reed_from + (eq321 ? " (mass: eq. 3.21)" : " (mass: FE mode in oil)");
      if (p.reed.fluid_loading == "map")
        { // the fluid's share comes from the loading maps
          p.reed.effective_mass_kg = reed->modal_mass_kg;
          p.reed.source            = "map set " + reed_from + " (mass: first mode in vacuum + the map's added mass)";
        }
      const double f1 = p.reed.natural_frequency_Hz();
      if (p.reed.second_mode_frequency_Hz > 0.0 && p.reed.second_mode_frequency_Hz <= f1)
        throw InputError(f.where("reed", "second_mode_frequency_Hz") + " = " +
                         format_number(p.reed.second_mode_frequency_Hz) + ": must be above the first mode's " +
                         format_number(f1) + " Hz (map set " + reed_from + ")");
    }
  } // namespace

  std::pair<double, double> beam_root_stress_per_opening(const ValveGeometry &g, const ReedMaterial &m)
  {
    const double L = g.reed_length_m, t = g.reed_thickness_m, a = std::min(g.port_center_x_m, L);
    const double beta2 = 4.694091132974175 / L; // the cantilever's second root of cos(bL) cosh(bL) = -1
    return {3.0 * m.youngs_modulus_Pa * t / (a * (3.0 * L - a)), -0.5 * m.youngs_modulus_Pa * t * beta2 * beta2};
  }

  namespace
  {
    /// What bounds the reed's state, from [geometry], [stiffness] and
    /// [reed_material]: the stop's lift, the opening beyond which linear
    /// elasticity fails, and the root stress per opening by beam theory (a
    /// map set's or reed map's FE value replaces it).
    void read_reed_limits(const CaseFile &f, SystemParameters &p)
    {
      const auto geometry   = ValveGeometry::from_case(f);
      p.reed.stop_lift_m    = geometry.stop_lift_m();
      const double ratio    = f.real("stiffness", "max_linear_deflection_ratio", 0.1, Bounds::open(0.0, 1.0));
      p.reed.large_deflection_opening_m = ratio * geometry.reed_length_m;
      if (p.reed.stress_source.empty()) // not a reed map's FE stress
        {
          const auto [s1, s2] = beam_root_stress_per_opening(geometry, p.material);
          p.reed.root_stress_per_opening_Pa_per_m             = s1;
          p.reed.second_mode_root_stress_per_opening_Pa_per_m = s2;
          p.reed.stress_source =
            std::string("beam theory of [geometry]'s reed (a uniform cantilever, loaded at its ") +
            (geometry.is_shorthand() ? "port's centre)" : "first port's centre: approximate for this outline)");
        }
      if (!f.has("reed", "film_cavitation_pressure_Pa"))
        p.reed.film_cavitation_pressure_Pa = p.fluid.cavitation_pressure_Pa;
    }
  } // namespace

  /// [uncertain] "table.key" = [lower, upper]: a real parameter of the
  /// model, 0 < lower < upper, its own value inside (a fit starts there).
  static void read_uncertain(const CaseFile &f, SystemParameters &p)
  {
    for (const std::string &name : f.keys("uncertain"))
      {
        const auto where = f.where("uncertain", "\"" + name + "\"");
        const auto dot   = name.find('.');
        if (dot == std::string::npos)
          throw InputError(where + ": name a parameter as \"table.key\", e.g. \"cylinder.wetted_length_m\"");
        UncertainParameter u{name.substr(0, dot), name.substr(dot + 1), 0, 0};
        double *field = p.real_field(u.table, u.key);
        if (field == nullptr)
          throw InputError(where + ": no real parameter [" + u.table + "] " + u.key + " in the model");
        if (name == "transducer.piezomagnetic_coefficient_m_per_A")
          throw InputError(where + ": the drive's force gain is always fitted (rectify diagnose --gain-range)");
        const auto range = f.reals("uncertain", name, {}, Bounds::positive());
        if (range.size() != 2 || !(range[0] < range[1]))
          throw InputError(where + ": expected [lower, upper] with 0 < lower < upper");
        // a fit moves the parameter over the whole range: each end must be
        // a value the key itself admits (a friction ratio of at least 1, a
        // restitution below 1, ...)
        if (const Bounds *admits = f.bounds_read(u.table, u.key))
          for (const double end : range)
            if (!admits->contains(end))
              throw InputError(where + " = [" + format_number(range[0]) + ", " + format_number(range[1]) +
                               "]: " + format_number(end) + " lies outside what [" + u.table + "] " + u.key +
                               " admits (" + admits->describe() + ")");
        // 0 is a value the case leaves out (the thesis's model has no such
        // term, e.g. the outlet passage's inertance): the data may still
        // ask for one inside the range (UncertainParameter::off_at_zero)
        if (!(*field >= range[0] && *field <= range[1]) && *field != 0.0)
          throw InputError(where + " = [" + format_number(range[0]) + ", " + format_number(range[1]) +
                           "]: the case's own value " + format_number(*field) + " lies outside");
        for (const auto &other : p.uncertain)
          if (other.name() == name)
            throw InputError(where + ": given twice");
        u.lower       = range[0];
        u.upper       = range[1];
        u.off_at_zero = *field == 0.0;
        p.uncertain.push_back(u);
      }
  }

  SystemParameters SystemParameters::from_case(const CaseFile &f, bool read_map_sets)
  {
    SystemParameters p;
    p.fluid       = FluidParameters::from_case(f);
    p.transducer  = TransducerParameters::from_case(f);
    p.chamber     = ChamberParameters::from_case(f);
    p.reed        = ReedParameters::from_case(f);
    p.valves      = ValveParameters::from_case(f);
    p.lines       = LineParameters::from_case(f);
    p.cylinder    = CylinderParameters::from_case(f);
    p.accumulator = AccumulatorParameters::from_case(f);
    p.load        = LoadParameters::from_case(f);
    p.drive       = DriveParameters::from_case(f);
    p.solver      = SolverParameters::from_case(f);
    p.material    = ReedMaterial::from_case(f);
    read_reed_limits(f, p);
    if (read_map_sets)
      apply_map_sets(f, p);
    read_uncertain(f, p);
    return p;
  }

  double *SystemParameters::real_field(const std::string &table, const std::string &key)
  {
    if (table == "fluid")
      return find_real(fluid_keys(), fluid, key);
    if (table == "reed_material")
      return find_real(material_keys(), material, key);
    if (table == "solver")
      return find_real(solver_keys(), solver, key);
    if (table == "transducer")
      return find_real(transducer_keys(), transducer, key);
    if (table == "chamber")
      return find_real(chamber_keys(), chamber, key);
    if (table == "reed")
      return find_real(reed_keys(), reed, key);
    if (table == "valves")
      return find_real(valve_keys(), valves, key);
    if (table == "lines")
      return find_real(line_keys(), lines, key);
    if (table == "cylinder")
      return find_real(cylinder_keys(), cylinder, key);
    if (table == "accumulator")
      return find_real(accumulator_keys(), accumulator, key);
    if (table == "load")
      return find_real(load_keys(), load, key);
    if (table == "drive")
      return find_real(drive_keys(), drive, key);
    return nullptr;
  }

  void use_map_set(SystemParameters &p, const CaseFile &f, const std::string &dir)
  {
    const std::string path = std::filesystem::absolute(dir).string();
    p.valves.map_set       = {path, path};
    apply_map_sets(f, p, true);
  }

  void use_fluid_loading(SystemParameters &p, const CaseFile &f, const std::string &mode)
  {
    if (mode != "thesis" && mode != "map")
      throw InputError("fluid loading '" + mode + "': expected thesis or map");
    p.reed.fluid_loading = mode;
    apply_map_sets(f, p, true);
  }

  void use_seat_film(SystemParameters &p, double seat_film_m, const std::string &suction_limit)
  {
    if (std::isnan(seat_film_m) && suction_limit.empty())
      return;
    if (p.reed.fluid_loading != "map")
      throw InputError("--seat-film-m and --film-suction-limit shape the map's squeeze film: give "
                       "--fluid-loading map (or [reed] fluid_loading = \"map\") as well");
    if (!std::isnan(seat_film_m))
      {
        if (!ReedParameters::seat_film_bounds().contains(seat_film_m))
          throw InputError("--seat-film-m " + format_number(seat_film_m) + ": must be " +
                           ReedParameters::seat_film_bounds().describe() + " (m)");
        p.reed.seat_film_m = seat_film_m;
      }
    if (!suction_limit.empty())
      {
        if (suction_limit != "cavitation" && suction_limit != "none")
          throw InputError("--film-suction-limit '" + suction_limit + "': expected cavitation or none");
        p.reed.film_suction_limit = suction_limit;
      }
  }

  void use_thesis_model(SystemParameters &p)
  {
    p.reed.stop       = "off";
    p.fluid.cavitation = "none";
  }

  std::array<maps::MapSet, 2> load_valve_maps(const SystemParameters &p)
  {
    const auto from_map = [&]() {
      return maps::map_set_from_resistance(
        maps::ResistanceMap::read(p.valves.resistance_map, maps::parse_interpolation(p.valves.interpolation)),
        p.reed.pressure_area_m2);
    };
    const auto valve = [&](std::size_t v) {
      return p.valves.map_set[v].empty() ? from_map() : maps::MapSet::read(p.valves.map_set[v]);
    };
    return {valve(0), valve(1)};
  }
} // namespace rectify::system

namespace rectify::system
{
  nlohmann::json SystemParameters::to_json() const
  {
    using nlohmann::json;
    json j{
      {"fluid", {{"free_air_law", fluid.free_air_law}, {"cavitation", fluid.cavitation}}},
      {"reed",
       {{"fluid_loading", reed.fluid_loading},
        {"film_suction_limit", reed.film_suction_limit},
        {"source", reed.source},
        {"stop", reed.stop},
        {"stop_lift_m", reed.stop_lift_m},
        {"root_stress_per_opening_Pa_per_m", reed.root_stress_per_opening_Pa_per_m},
        {"second_mode_root_stress_per_opening_Pa_per_m", reed.second_mode_root_stress_per_opening_Pa_per_m},
        {"stress_source", reed.stress_source},
        {"large_deflection_opening_m", reed.large_deflection_opening_m}}},
      {"valves",
       {{"outlet_map_set", valves.map_set[0]},
        {"inlet_map_set", valves.map_set[1]},
        {"resistance_map", valves.resistance_map},
        {"interpolation", valves.interpolation},
        {"out_of_range", valves.out_of_range}}},
      {"lines", {{"outlet_line_segments", lines.outlet_line_segments}}},
      {"drive", {{"waveform", drive.waveform}, {"coil_dynamics", drive.coil_dynamics}}},
      {"solver", {{"jacobian", solver.jacobian}}}};
    put_reals(j["fluid"], fluid_keys(), fluid);
    put_reals(j["reed_material"], material_keys(), material);
    put_reals(j["solver"], solver_keys(), solver);
    put_reals(j["transducer"], transducer_keys(), transducer);
    put_reals(j["chamber"], chamber_keys(), chamber);
    put_reals(j["reed"], reed_keys(), reed);
    put_reals(j["valves"], valve_keys(), valves);
    put_reals(j["lines"], line_keys(), lines);
    put_reals(j["cylinder"], cylinder_keys(), cylinder);
    put_reals(j["accumulator"], accumulator_keys(), accumulator);
    put_reals(j["load"], load_keys(), load);
    put_reals(j["drive"], drive_keys(), drive);
    return j;
  }
  void DriveParameters::check_currents(double pp_A, double bias_A, const std::string &pp_name,
                                       const std::string &bias_name)
  {
    if (!current_pp_bounds().contains(pp_A))
      throw InputError(pp_name + " = " + format_number(pp_A) + ": must be " + current_pp_bounds().describe() +
                       " (A peak-to-peak)");
    if (!current_bias_bounds().contains(bias_A))
      throw InputError(bias_name + " = " + format_number(bias_A) + ": must be " +
                       current_bias_bounds().describe() + " (A)");
  }
} // namespace rectify::system
