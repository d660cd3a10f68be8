// The reed valve's fluid domain at one tip opening, as a tetrahedral mesh.
//
// Construction (docs/mesher.md):
//  1. the seat's floor (the pocket floor z = 0) is triangulated in 2D with
//     CGAL: lines along the reed's edges, at its shape stations and at the
//     cut-off, and the port's polygon (area-preserving: its area is pi r^2);
//  2. a layered slab is extruded from the floor: in every column, gap_layers
//     across the gap, reed_layers beside the reed, above_layers over it, the
//     levels relaxing to uniform away from the reed; each prism is split into
//     three tetrahedra (diagonals by vertex number, so neighbours conform);
//  3. the port is extruded downwards from the floor triangles inside it;
//  4. TetGen (libtet, -pYq) fills the pocket above the slab, keeping the
//     slab's top surface, so its tetrahedra conform to the slab's;
//  5. prisms inside the reed, and under it where the gap is thinner than the
//     cut-off, are removed; boundary faces get their ids; every cell's
//     orientation, the boundary's closure (CGAL) and the volumes are checked.
#pragma once

#include <array>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "mesher/parameters.h"
#include "mesher/quality.h"
#include "mesher/tet_mesh.h"

namespace rectify::mesher
{
  /// The mesher could not build a valid mesh (TetGen failed, a check failed).
  class MeshError : public std::runtime_error
  {
  public:
    using std::runtime_error::runtime_error;
  };

  struct MeshInfo
  {
    double opening_m = 0;
    double fluid_volume_m3 = 0, exact_fluid_volume_m3 = 0;
    double gap_volume_m3 = 0, exact_gap_volume_m3 = 0;
    /// Per boundary id (index 1..4): faces and area; exact areas for inlet and outlet.
    std::array<std::size_t, 5> boundary_faces{};
    std::array<double, 5>      boundary_area_m2{};
    double exact_inlet_area_m2 = 0, exact_outlet_area_m2 = 0;
    /// The gap under the reed is treated as closed from the clamp line to
    /// x = closed_to_m, where it is thinner than cutoff_thickness_m.
    double closed_to_m = 0, cutoff_thickness_m = 0; ///< the latter is also the thinnest open gap
    double slab_margin_m = 0; ///< the slab's margin above the reed's top at this opening
    double shape_sampling_error = 0; ///< max |phi - sampled phi|
    long   gap_layers = 0;
    std::size_t port_segments = 0, n_stations = 0, n_floor_triangles = 0;
    std::size_t n_bulk_cells = 0, n_vertices = 0;
    std::string shape, tetgen_switches;
    MeshQuality  quality;
    SurfaceCheck surface;
    std::vector<std::pair<std::string, double>> timings_s; ///< per stage
    double wall_time_s = 0;
  };

  struct ValveMesh
  {
    TetMesh  mesh;
    MeshInfo info;
  };

  /// Meshes the fluid domain at tip opening `opening_m`. Throws InputError
  /// for an opening the geometry cannot take (reed through the ceiling,
  /// non-positive) before any meshing, MeshError if meshing fails.
  ValveMesh mesh_valve(const MeshParameters &parameters, double opening_m, bool verbose = false);

  nlohmann::json to_json(const MeshInfo &info);
} // namespace rectify::mesher
