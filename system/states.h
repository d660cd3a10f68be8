// The lumped model's state layout (system/model.h): the thesis's states,
// then the fixed states of the optional effects (constant 0 where off),
// then the components' own (the outlet line's later segments).
#pragma once

#include <cstddef>

namespace rectify::system
{
  namespace state
  {
    enum : std::size_t
    {
      piston_x,
      piston_v,
      fluid_x,
      fluid_v,
      actuator_x,
      actuator_v,
      outlet_reed_x,
      outlet_reed_v,
      inlet_reed_x,
      inlet_reed_v,
      chamber_p,
      accumulator_p,
      high_p,
      low_p,
      outlet_volume,
      inlet_volume,
      outlet_pressure_integral,
      // states of the optional effects (docs/diagnosis.md); constant 0 when off
      line_flow,      ///< flow in the outlet line, with line inertance
      coil_current,   ///< coil current, with a voltage drive and coil dynamics
      outlet_reed2_x, ///< second bending mode of each reed
      outlet_reed2_v,
      inlet_reed2_x,
      inlet_reed2_v,
      line_node_p,    ///< pressure between the outlet valve and the line, with line inertance
      count
    };
    /// States of the thesis model alone: a model with no effect on has only
    /// these (the extra states would dilute CVODE's error norm).
    inline constexpr std::size_t thesis_count = outlet_pressure_integral + 1;
    /// An inertial outlet line of n segments ([lines] outlet_line_segments):
    /// segment k's flow and the pressure at its upstream node (node 0: between
    /// the valve and the line); segments 1.. follow the fixed states.
    inline std::size_t line_segment_flow(std::size_t k) { return k == 0 ? line_flow : count + 2 * (k - 1); }
    inline std::size_t line_segment_node(std::size_t k) { return k == 0 ? line_node_p : count + 2 * (k - 1) + 1; }
  } // namespace state
} // namespace rectify::system
