// Internal to the mesher: the domain's layout at one opening and the stages
// of mesh_valve (mesher.h), one file each:
//   floor.cpp     the floor triangulation (CGAL) and its parts
//   layers.cpp    the layered slab and the extruded port
//   pocket.cpp    the pocket above the slab (CGAL walls, TetGen)
//   assembly.cpp  orientation, boundary ids, removal of the reed and the closed gap
#pragma once

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "mesher/parameters.h"
#include "mesher/planar.h"
#include "mesher/tet_mesh.h"

namespace rectify::mesher::detail
{
  /// Cell tags while building: the fluid regions, and the solids removed at the end.
  enum Tag : std::uint8_t
  {
    tag_gap = gap, tag_slab = slab, tag_port = port, tag_bulk = bulk,
    tag_reed_solid = 10,  ///< inside the reed: removed, its faces are the reed's surface
    tag_closed_solid = 11 ///< the gap under the reed thinner than the cut-off: removed
  };
  inline bool is_fluid(std::uint8_t tag) { return tag < n_regions; }

  /// A port's mouth as the floor holds it: a vertex wherever a station line
  /// crosses its edge (so station lines end on it). A circle: more vertices
  /// where those are further apart than 2 pi / n ([mesh] port_segments, or
  /// about one per size_reed_m of its circumference, at least 16), the radius chosen so
  /// that the polygon's area is pi r^2 exactly. A polygon port: its own
  /// corners. Counter-clockwise.
  struct PortPolygon
  {
    std::vector<Point2>      points;
    std::vector<std::size_t> station; ///< per point: station index, or npos
    double                   R = 0;   ///< a circle's circumradius
    double                   inradius = 0;
    double                   length = 0; ///< the bore, inlet face at z = -length
    bool contains(double x, double y) const;
    /// True if (x, y) lies on the polygon's edge, within `tol`.
    bool on_edge(double x, double y, double tol) const;
    double area() const;
  };

  /// The domain's dimensions at one opening, and the layer structure.
  struct Layout
  {
    const ValveGeometry &g;
    const MeshSettings  &s;
    SampledShape         shape;
    double               opening;
    double               L, W, t, Lp, Wp, Hp;
    geometry::Polygon    outline;   ///< the reed's boundary (fillets drawn), counter-clockwise
    bool                 rectangle; ///< the shorthand's rectangle [0, L] x [-W/2, W/2]
    std::vector<Port>    ports;
    std::size_t          j_closed = 0;
    double               x_closed = 0, h_cut = 0;
    long                 Ng, Nr, Na, N;

    Layout(const MeshParameters &p, double x_tip)
      : g(p.geometry), s(p.settings), shape(p.sampled_shape()),
        opening(x_tip), L(g.reed_length_m), W(g.reed_width_m), t(g.reed_thickness_m),
        Lp(g.pocket_length_m), Wp(g.pocket_width_m), Hp(g.pocket_height_m),
        outline(g.reed_boundary()), rectangle(g.is_shorthand()), ports(g.ports()),
        Ng(s.gap_layers), Nr(s.reed_layers), Na(s.above_layers), N(Ng + Nr + Na)
    {
      const auto &phi = shape.values();
      j_closed        = cutoff_station(shape, s.gap_cutoff_ratio, opening, t);
      x_closed = shape.stations()[j_closed];
      h_cut    = opening * phi[j_closed];
    }

    double sampled_h(double x) const { return opening * shape(std::min(x, L)); }

    /// Distance from (x, y) to the reed's footprint (0 on and under it).
    double distance_to_reed(double x, double y) const
    {
      if (rectangle)
        {
          const double dx = std::max(0.0, x - L), dy = std::max(0.0, std::abs(y) - 0.5 * W);
          return std::hypot(dx, dy);
        }
      if (geometry::side_of(outline, {x, y}) != geometry::Side::outside)
        return 0.0;
      return geometry::distance_to_boundary(outline, {x, y});
    }

    /// z of level m (0..N) in the column at floor point (x, y).
    double level(double x, double y, long m) const
    {
      const double h  = sampled_h(x);
      const double hb = std::max(h, h_cut);
      const double ht = h + t;
      const double zs = ht + s.slab_margin_m;
      double       reed_pattern;
      if (m <= Ng)
        reed_pattern = hb * static_cast<double>(m) / static_cast<double>(Ng);
      else if (m <= Ng + Nr)
        reed_pattern = hb + (ht - hb) * static_cast<double>(m - Ng) / static_cast<double>(Nr);
      else
        reed_pattern = ht + s.slab_margin_m * static_cast<double>(m - Ng - Nr) / static_cast<double>(Na);
      if (m == N)
        return zs;
      const double uniform = zs * static_cast<double>(m) / static_cast<double>(N);
      const double u = std::clamp(distance_to_reed(x, y) / s.blend_distance_m, 0.0, 1.0);
      const double w = u * u * (3 - 2 * u);
      return (1 - w) * reed_pattern + w * uniform;
    }

    double size_at(const Point2 &p) const
    {
      const double d = distance_to_reed(p[0], p[1]);
      return d == 0 ? s.size_reed_m : std::min(s.size_far_m, s.size_reed_m + s.size_growth * d);
    }

    /// Every port's mouth, in the order of ports().
    std::vector<PortPolygon> port_polygons() const;
  };

  /// Where a floor triangle lies.
  enum class FloorPart
  {
    outside, ///< beside or beyond the reed
    open,    ///< under the reed, open gap
    closed,  ///< under the reed, gap thinner than the cut-off
    port     ///< under the reed, over the port
  };

  PlanarMesh             mesh_floor(const Layout &layout, const std::vector<PortPolygon> &ports);
  /// Each floor triangle's part; `port_of` gets, per triangle, the index of
  /// the port it lies over (or -1).
  std::vector<FloorPart> classify_floor(const Layout &layout, const PlanarMesh &floor,
                                        const std::vector<PortPolygon> &ports, std::vector<int> &port_of);
  double                 min_angle_deg(const PlanarMesh &mesh);

  /// Splits the prism between two levels (lo, hi points of the floor
  /// triangle tri's vertices) into three tetrahedra tagged `tag`. The diagonal
  /// of each side face runs from the lower-numbered floor vertex's `lo` point
  /// to the higher-numbered one's `hi` point: neighbouring prisms conform.
  void split_prism(std::array<std::uint32_t, 3> tri, const std::array<std::uint32_t, 3> &lo,
                   const std::array<std::uint32_t, 3> &hi, std::uint8_t tag, TetMesh &mesh);

  /// Orients every cell positively and lists the faces of exactly one cell
  /// as boundary faces (outward), with the id `classify` gives them. For the
  /// benchmark geometries, whose cells are all fluid.
  void orient_and_label(TetMesh &mesh,
                        const std::function<std::uint8_t(const std::array<Point3, 3> &face)> &classify);

  /// Slab vertex of floor point i at level m: i * (N + 1) + m; the slab's
  /// vertices come first in `all`.
  void build_slab(const Layout &layout, const PlanarMesh &floor, const std::vector<FloorPart> &parts,
                  TetMesh &all);
  void build_port(const Layout &layout, const PlanarMesh &floor, const std::vector<FloorPart> &parts,
                  const std::vector<int> &port_of, const std::vector<PortPolygon> &ports, TetMesh &all);
  /// TetGen's tetrahedra between the slab's top and the ceiling, added to `all`;
  /// returns TetGen's switches.
  std::string build_pocket(const Layout &layout, const PlanarMesh &floor, TetMesh &all);
  /// Orients the cells, finds the boundary faces and their ids, and returns
  /// the fluid cells with the vertices they use. Throws MeshError for a
  /// degenerate cell or a mesh that does not conform.
  TetMesh assemble_fluid(TetMesh &all, const Layout &layout, const std::vector<PortPolygon> &ports);

  /// "(x, y, z) mm" for messages.
  std::string where(const Point3 &p);
} // namespace rectify::mesher::detail
