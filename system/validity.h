// What a run's measured window reached, and whether hardware can reach it:
// each reed's openings, root stress (its Goodman factor against the
// material's fatigue data) and seat and stop impacts; each oil volume's
// lowest pressure and cavity; and the validity flags every summary and
// sweep row carries (docs/stress.md, docs/system-model.md).
//
// A run is valid when no number comes from a state the hardware cannot
// reach or the model cannot describe: no reed beyond its map (R held at the
// map's last node) or beyond its stop (a model without the stop), no
// pressure below the cavitation pressure (a model without cavitation), no
// Goodman factor below 1 (the reed would not survive its cycles). The
// other flags describe states hardware does reach (at the stop,
// cavitating) or where the linear reed is approximate (large deflection).
#pragma once

#include <array>
#include <limits>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "system/model.h"

namespace rectify::system
{
  struct ValveStatistics
  {
    double      max_opening_m = 0, min_opening_m = std::numeric_limits<double>::infinity();
    double      max_root_stress_Pa = -std::numeric_limits<double>::infinity();
    double      min_root_stress_Pa = std::numeric_limits<double>::infinity();
    std::size_t seat_impacts = 0, stop_impacts = 0;
    double      max_seat_impact_m_per_s = 0, max_stop_impact_m_per_s = 0;
    /// Over the window's cycle: mean and alternating root stress, and
    /// Goodman's factor of the surface whose mean is tensile.
    double mean_root_stress_Pa() const { return 0.5 * (max_root_stress_Pa + min_root_stress_Pa); }
    double alternating_root_stress_Pa() const { return 0.5 * (max_root_stress_Pa - min_root_stress_Pa); }
    double goodman_factor = std::numeric_limits<double>::infinity();
    nlohmann::json to_json() const;
  };

  struct VolumeStatistics
  {
    std::string name;
    double      min_absolute_pressure_Pa = std::numeric_limits<double>::infinity();
    double      max_cavity_volume_m3     = 0;
    std::size_t samples = 0, cavitating_samples = 0;
    nlohmann::json to_json() const;
  };

  struct Validity
  {
    bool beyond_map = false;                ///< a reed opened beyond its map's last node
    bool beyond_stop = false;               ///< a reed passed its stop (the model without one)
    bool below_cavitation_pressure = false; ///< a pressure below the cavitation pressure (without cavitation)
    bool goodman_below_1 = false;           ///< the reed's root stress cycle beyond its fatigue strength
    bool at_stop = false;                   ///< a reed met its stop
    bool cavitating = false;                ///< a volume cavitated
    bool large_deflection = false;          ///< a tip opening beyond linear elasticity's range
    /// What makes it not valid, and what else holds, as phrases with numbers.
    std::vector<std::string> reasons, notes;
    bool valid() const { return !beyond_map && !beyond_stop && !below_cavitation_pressure && !goodman_below_1; }
    /// "valid" or "NOT VALID: ...", with the notes: the console's one line.
    std::string line() const;
    nlohmann::json to_json() const;
  };

  /// Gathers a run's measured window: every sample and every reed event.
  class WindowMonitor
  {
  public:
    explicit WindowMonitor(const Model &model);
    /// The reed events since the last sample (impacts, and the stress's
    /// extrema where the model finds them), then that sample: the
    /// integrator's state y (liquid pressures: the model's states).
    void add(const std::vector<Model::ReedEvent> &events);
    void sample(std::span<const double> y);
    /// The window's statistics and flags.
    void finish(std::array<ValveStatistics, 2> &valves, std::vector<VolumeStatistics> &volumes,
                Validity &validity) const;

  private:
    void valve_validity(const std::array<ValveStatistics, 2> &valves, Validity &validity) const;
    void volume_validity(const std::vector<VolumeStatistics> &volumes, Validity &validity) const;

    const Model                    &model_;
    std::array<ValveStatistics, 2>  valves_;
    std::vector<VolumeStatistics>   volumes_;
    std::vector<std::size_t>        volume_state_, volume_cavity_; ///< per volume: its state, its cavity (or npos)
  };
} // namespace rectify::system
