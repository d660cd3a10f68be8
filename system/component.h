// An optional physical effect of the lumped model as one unit: its
// constants (from the case's parameters), the states it adds, and the terms
// it puts into the model's equations. `Model` composes the components that
// make_components() returns for a case; each enters only through the hooks
// below, so the thesis's model (no component) is computed exactly as
// without them.
//
// Hooks, in the order the model meets them:
//   adjust         the model's derived constants (a compliance added to a volume)
//   add_to_branch  a valve's branch law: leak paths beside it, a quadratic drop through it
//   current        the coil's current (instead of the drive's own, or V / R)
//   actuator_force a force against the output piston's motion
//   gas_...        free gas in the oil: every volume's compliance per unit of its oil
//   outlet_node    an element between the outlet valve and the high side
//                  (the outlet line): the state the valve discharges into,
//                  the flow it delivers, the states flows() then reads
//   extra_states, volumes, typical_sizes, max_bdf_order
//                  its states beyond the fixed layout, the oil volumes
//                  among them (cavitation, stored volume, validity), their
//                  scales, what the integrator must respect
//   own_rhs        the derivatives of the component's own states
//   own_reads      the states those derivatives and its terms read (the
//                  coloured difference-quotient Jacobian's pattern)
//   constants_json its derived constants in the summary's model constants
// No component has an analytic Jacobian part yet: a model with one on asks
// CVODE for difference quotients (Model::needs_difference_jacobian).
//
// Adding one: docs/adding-an-effect.md.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <span>
#include <string_view>
#include <vector>

namespace rectify::system
{
  class Drive;
  class Model;
  struct Flows;
  struct ModelConstants;
  struct SystemParameters;
  enum class Scenario;

  /// What the components add to one valve's branch: the valve's R(x) with a
  /// quadratic drop series_K q|q| through it while open, and beside it a
  /// laminar leak (leak_resistance, 0 for none) and a turbulent orifice
  /// (drop leak_K q|q|, 0 for none).
  struct BranchLaw
  {
    double series_K        = 0.0;
    double leak_resistance = 0.0;
    double leak_K          = 0.0;
  };

  /// An oil volume of the model: its pressure state, its oil's compliance
  /// and volume (free gas adds per unit of the latter).
  struct OilVolume
  {
    std::size_t state;
    double      compliance, oil_volume;
    std::string name;
    bool        high_side; ///< on the outlet's high-pressure side (a record's start sets it to the outlet pressure)
  };

  class Component
  {
  public:
    virtual ~Component() = default;
    /// The effect's name, as the diagnosis names it.
    virtual std::string_view name() const = 0;
    /// False where this drive leaves the effect without work (the coil's
    /// inductance under a current drive): the model then leaves it out.
    virtual bool acts(const Drive &) const { return true; }

    /// Applied by ModelConstants for every component the case switches on,
    /// whatever the drive (ModelConstants knows none): a component whose
    /// acts() can be false must not adjust constants.
    virtual void adjust(ModelConstants &) const {}
    /// Valve `valve` (0 outlet, 1 inlet); `opening`: its tip opening while
    /// its reed is off the seat, none when shut or an ideal valve.
    virtual void add_to_branch(std::size_t /*valve*/, std::optional<double> /*opening*/, BranchLaw &) const {}
    /// The coil current at t, if this component gives it.
    virtual std::optional<double> current(double /*t*/, std::span<const double> /*y*/, const Drive &) const
    {
      return std::nullopt;
    }
    /// Force against the output piston's motion at state y [N].
    virtual double actuator_force(std::span<const double> /*y*/) const { return 0.0; }
    /// Free gas in the oil: the compliance it adds per unit oil volume at
    /// gauge pressure p [1/Pa], and the gas volume per oil volume it loses
    /// from the bias state to p (the integral of the former from 0).
    virtual double gas_compliance_per_volume(double /*p_gauge*/) const { return 0.0; }
    virtual double gas_volume_change_per_volume(double /*p_gauge*/) const { return 0.0; }

    /// The state of the pressure the outlet valve discharges into, where
    /// this component stands between it and the high side (instead of R3).
    virtual std::optional<std::size_t> outlet_node() const { return std::nullopt; }
    /// Then: the flow it delivers into the high side at y.
    virtual double high_side_inflow(std::span<const double> /*y*/) const { return 0.0; }
    /// The states the model's flows() reads through this component.
    virtual std::vector<std::size_t> flow_reads() const { return {}; }

    /// Its states beyond the model's fixed layout (state::count on).
    virtual std::size_t extra_states() const { return 0; }
    /// The oil volumes among its states.
    virtual std::vector<OilVolume> volumes() const { return {}; }
    /// The highest BDF order its states allow (0: no limit).
    virtual int max_bdf_order() const { return 0; }
    /// Its states' typical magnitudes, given a flow's and a pressure's.
    virtual void typical_sizes(std::span<double> /*s*/, double /*flow*/, double /*pressure*/) const {}
    /// Its own states' start (the model's initial_state()).
    virtual void initial_state(std::span<double> /*y*/, const Drive &) const {}
    /// Its own states' derivatives at y; `f`: the model's flows at y.
    virtual void own_rhs(double /*t*/, std::span<const double> /*y*/, const Model &, const Flows & /*f*/,
                         std::span<double> /*ydot*/) const
    {}
    /// Adds to r[i] the states row i reads through this component; `flow`:
    /// the states the model's flows() reads.
    virtual void own_reads(std::vector<std::vector<std::size_t>> & /*r*/,
                           const std::vector<std::size_t> & /*flow*/) const
    {}
    /// Adds its derived constants to the model's (ModelConstants::to_json).
    virtual void constants_json(nlohmann::json &) const {}
  };

  using Components = std::vector<std::shared_ptr<const Component>>;

  /// The components the case's parameters switch on, in a fixed order (the
  /// order their terms are summed in and their adjust()s applied);
  /// `thesis`: the model's constants before any adjust(). Made once, by
  /// ModelConstants. system/components.cpp lists them.
  Components make_components(const SystemParameters &p, Scenario scenario, const ModelConstants &thesis);
} // namespace rectify::system
