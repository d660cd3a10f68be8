#include "system/validity.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/case_file.h"
#include "system/cavitation.h"

namespace rectify::system
{
  namespace
  {
    const char *valve_name(std::size_t v) { return v == 0 ? "outlet" : "inlet"; }

    std::string mm(double x)
    {
      char buf[32];
      std::snprintf(buf, sizeof(buf), "%.3g mm", x * 1e3);
      return buf;
    }

    std::string mpa(double p)
    {
      char buf[32];
      std::snprintf(buf, sizeof(buf), "%.3g MPa", p * 1e-6);
      return buf;
    }

    /// JSON has no infinity: an unbounded number is null.
    nlohmann::json finite_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); }

    /// The states that are a volume's pressure, with its name and cavity index.
    struct VolumeState
    {
      std::string name;
      std::size_t state;
      std::size_t cavity; ///< index into Model::cavity_nodes(), or npos
    };

    std::vector<VolumeState> volume_states(const Model &model)
    {
      std::vector<VolumeState> v{{"chamber", state::chamber_p, std::string::npos},
                                 {"high side", state::high_p, std::string::npos},
                                 {"low side", state::low_p, std::string::npos},
                                 {"accumulator", state::accumulator_p, std::string::npos}};
      for (std::size_t k = 3; k < model.volumes().size(); ++k) // the components'
        v.push_back({model.volumes()[k].name, model.volumes()[k].state, std::string::npos});
      const auto &nodes = model.cavity_nodes();
      for (auto &vs : v)
        for (std::size_t k = 0; k < nodes.size(); ++k)
          if (nodes[k] == vs.state)
            vs.cavity = k;
      return v;
    }
  } // namespace

  nlohmann::json ValveStatistics::to_json() const
  {
    const bool any = std::isfinite(max_root_stress_Pa);
    return {{"max_opening_m", max_opening_m},
            {"min_opening_m", finite_or_null(min_opening_m)},
            {"max_root_stress_Pa", any ? nlohmann::json(max_root_stress_Pa) : nlohmann::json()},
            {"min_root_stress_Pa", any ? nlohmann::json(min_root_stress_Pa) : nlohmann::json()},
            {"mean_root_stress_Pa", any ? nlohmann::json(mean_root_stress_Pa()) : nlohmann::json()},
            {"alternating_root_stress_Pa", any ? nlohmann::json(alternating_root_stress_Pa()) : nlohmann::json()},
            {"goodman_factor", finite_or_null(goodman_factor)},
            {"seat_impacts", seat_impacts},
            {"stop_impacts", stop_impacts},
            {"max_seat_impact_velocity_m_per_s", max_seat_impact_m_per_s},
            {"max_stop_impact_velocity_m_per_s", max_stop_impact_m_per_s}};
  }

  nlohmann::json VolumeStatistics::to_json() const
  {
    return {{"volume", name},
            {"min_absolute_pressure_Pa", finite_or_null(min_absolute_pressure_Pa)},
            {"max_cavity_volume_m3", max_cavity_volume_m3},
            {"cavitating_fraction", samples ? static_cast<double>(cavitating_samples) / static_cast<double>(samples) : 0.0}};
  }

  std::string Validity::line() const
  {
    std::string s = valid() ? "valid" : "NOT VALID: ";
    for (std::size_t i = 0; i < reasons.size(); ++i)
      s += (i ? "; " : "") + reasons[i];
    if (!notes.empty())
      {
        s += valid() ? " (" : " (also: ";
        for (std::size_t i = 0; i < notes.size(); ++i)
          s += (i ? "; " : "") + notes[i];
        s += ")";
      }
    return s;
  }

  nlohmann::json Validity::to_json() const
  {
    return {{"valid", valid()},
            {"beyond_map", beyond_map},
            {"beyond_stop", beyond_stop},
            {"below_cavitation_pressure", below_cavitation_pressure},
            {"goodman_below_1", goodman_below_1},
            {"at_stop", at_stop},
            {"cavitating", cavitating},
            {"large_deflection", large_deflection},
            {"reasons", reasons},
            {"notes", notes}};
  }

  WindowMonitor::WindowMonitor(const Model &model)
    : model_(model)
  {
    for (const auto &v : volume_states(model))
      {
        volumes_.push_back({v.name});
        volume_state_.push_back(v.state);
        volume_cavity_.push_back(v.cavity);
      }
  }

  void WindowMonitor::sample(std::span<const double> y)
  {
    for (std::size_t v = 0; v < 2; ++v)
      {
        auto        &s = valves_[v];
        const double x = model_.opening(v, y), sigma = model_.root_stress(v, y);
        s.max_opening_m      = std::max(s.max_opening_m, x);
        s.min_opening_m      = std::min(s.min_opening_m, x);
        s.max_root_stress_Pa = std::max(s.max_root_stress_Pa, sigma);
        s.min_root_stress_Pa = std::min(s.min_root_stress_Pa, sigma);
      }
    const double p_bias = model_.constants().p_bias, p_c = model_.cavitation_gauge_pressure();
    for (std::size_t i = 0; i < volumes_.size(); ++i)
      {
        const double psi    = y[volume_state_[i]];
        const bool   cavity = volume_cavity_[i] != std::string::npos;
        auto        &vol    = volumes_[i];
        vol.min_absolute_pressure_Pa = std::min(vol.min_absolute_pressure_Pa, p_bias + (cavity ? cavity_pressure(psi, p_c) : psi));
        ++vol.samples;
        if (cavity && psi < p_c)
          {
            ++vol.cavitating_samples;
            vol.max_cavity_volume_m3 = std::max(vol.max_cavity_volume_m3, model_.cavity_volume(volume_cavity_[i], y));
          }
      }
  }

  void WindowMonitor::add(const std::vector<Model::ReedEvent> &events)
  {
    for (const auto &e : events)
      {
        auto &s = valves_[e.valve];
        s.max_opening_m      = std::max(s.max_opening_m, e.opening);
        s.min_opening_m      = std::min(s.min_opening_m, e.opening);
        s.max_root_stress_Pa = std::max(s.max_root_stress_Pa, e.root_stress);
        s.min_root_stress_Pa = std::min(s.min_root_stress_Pa, e.root_stress);
        if (e.kind == Model::ReedEvent::seat_impact)
          {
            ++s.seat_impacts;
            s.max_seat_impact_m_per_s = std::max(s.max_seat_impact_m_per_s, e.velocity);
          }
        else if (e.kind == Model::ReedEvent::stop_impact)
          {
            ++s.stop_impacts;
            s.max_stop_impact_m_per_s = std::max(s.max_stop_impact_m_per_s, e.velocity);
          }
      }
  }

  void WindowMonitor::finish(std::array<ValveStatistics, 2> &valves, std::vector<VolumeStatistics> &volumes,
                             Validity &validity) const
  {
    valves  = valves_;
    volumes = volumes_;
    for (auto &s : valves)
      if (std::isfinite(s.max_root_stress_Pa))
        // the surface in tension on average: its mean is |mean| (the other's is compressive)
        s.goodman_factor = model_.limits().material.goodman_factor(std::abs(s.mean_root_stress_Pa()),
                                                                   s.alternating_root_stress_Pa());
    validity = {};
    valve_validity(valves, validity);
    volume_validity(volumes, validity);
  }

  void WindowMonitor::valve_validity(const std::array<ValveStatistics, 2> &valves, Validity &val) const
  {
    const auto &lim = model_.limits();
    for (std::size_t v = 0; v < 2; ++v)
      {
        const auto  &s       = valves[v];
        const double map_end = model_.valve_map(v).resistance().max_opening();
        const std::string who = std::string("the ") + valve_name(v) + " reed";
        if (model_.valve_model() == ValveModel::ideal)
          continue;
        if (s.max_opening_m > map_end)
          {
            val.beyond_map = true;
            val.reasons.push_back(who + " opened to " + mm(s.max_opening_m) + ", beyond its map's last opening (" +
                                  mm(map_end) + ")");
          }
        if (!lim.stop_on && s.max_opening_m > lim.geometric_stop_lift_m)
          {
            val.beyond_stop = true;
            val.reasons.push_back(who + " opened to " + mm(s.max_opening_m) + ", through its stop at " +
                                  mm(lim.geometric_stop_lift_m) + " ([reed] stop = \"off\")");
          }
        if (s.goodman_factor < 1.0)
          {
            val.goodman_below_1 = true;
            val.reasons.push_back(who + "'s Goodman factor is " + format_number(std::round(s.goodman_factor * 100) / 100) +
                                  " (root stress " + mpa(s.min_root_stress_Pa) + " to " + mpa(s.max_root_stress_Pa) +
                                  "): it would not survive");
          }
        if (s.stop_impacts > 0)
          {
            val.at_stop = true;
            val.notes.push_back(who + " met its stop (" + std::to_string(s.stop_impacts) + " impacts, up to " +
                                format_number(std::round(s.max_stop_impact_m_per_s * 1000) / 1000) + " m/s)");
          }
        if (s.max_opening_m > lim.large_deflection_opening_m)
          {
            val.large_deflection = true;
            val.notes.push_back(who + " opened to " + mm(s.max_opening_m) + ", beyond linear elasticity's " +
                                mm(lim.large_deflection_opening_m));
          }
      }
  }

  void WindowMonitor::volume_validity(const std::vector<VolumeStatistics> &volumes, Validity &val) const
  {
    const auto &lim = model_.limits();
    for (const auto &vol : volumes)
      {
        if (vol.cavitating_samples > 0)
          {
            val.cavitating = true;
            char buf[64];
            std::snprintf(buf, sizeof(buf), "%.0f %% of the time", 100.0 * static_cast<double>(vol.cavitating_samples) /
                                                                       static_cast<double>(vol.samples));
            val.notes.push_back("the " + vol.name + " cavitated " + buf);
          }
        // a held pressure is p_c to round-off: below by more is a volume that does not cavitate
        if (vol.min_absolute_pressure_Pa < lim.cavitation_pressure_Pa - 1e-9 * model_.constants().p_bias)
          {
            val.below_cavitation_pressure = true;
            val.reasons.push_back("the " + vol.name + "'s pressure fell to " + mpa(vol.min_absolute_pressure_Pa) +
                                  " absolute, below the oil's cavitation pressure (" +
                                  mpa(lim.cavitation_pressure_Pa) + ")" +
                                  (lim.cavitation_on ? "" : ": [fluid] cavitation = \"none\""));
          }
      }
  }
} // namespace rectify::system
