// Geometries with exact flow solutions, meshed like the valve (a planar
// CGAL triangulation extruded in layers), for verifying the flow solver.
// Boundary ids as the valve's: inlet 1, outlet 2, walls 3, reed 4.
#pragma once

#include "mesher/tet_mesh.h"

namespace rectify::mesher
{
  /// A straight pipe along z from the inlet z = 0 to the outlet z = length;
  /// its section is a polygon of `sides` sides with the area of the circle
  /// of diameter `diameter`. In-plane size `size`, layers `layer` thick.
  TetMesh pipe_mesh(double diameter, double length, double size, double layer, long sides = 64);

  /// Radial flow between parallel discs: a port of `port_diameter` from the
  /// inlet z = -port_length to z = 0 opens into the gap 0 < z < gap between
  /// two discs of radius `outer_radius`; the outlet is the cylinder at
  /// outer_radius. The in-plane size grows from `size` at the port's rim in
  /// proportion to the radius (the pressure varies as ln r). The upper disc
  /// carries the reed's id 4, so that the force on it can be checked.
  TetMesh radial_gap_mesh(double port_diameter, double port_length, double outer_radius, double gap,
                          long gap_layers, double size, double port_layer, long sides = 64);

  /// A strip squeeze film: a slot port of `slot_width` (|x| < slot_width/2,
  /// 0 < y < strip_length) from the inlet z = -port_length opens into the
  /// gap 0 < z < gap under a plate |x| < strip_width/2 (the "reed", id 4);
  /// the outlet is the two long sides |x| = strip_width/2, the ends y = 0
  /// and y = strip_length are walls.
  TetMesh slot_gap_mesh(double slot_width, double port_length, double strip_width, double strip_length, double gap,
                        long gap_layers, double size, double port_layer);

  /// The half space z > 0 above a disc of `radius` (id 4, on the floor),
  /// truncated at a cylinder of `far_radius` and `height`: the rest of the
  /// floor, the cylinder and its top carry the outlet's id 2 (for a disc
  /// moving broadside, the potential is odd in z, so zero on the floor
  /// outside the disc). Sizes grow from `size` at the disc's edge by
  /// `growth` per unit distance (in-plane) and per layer (upwards).
  TetMesh disc_half_space_mesh(double radius, double far_radius, double height, double size, double growth,
                               long sides = 64);
} // namespace rectify::mesher
