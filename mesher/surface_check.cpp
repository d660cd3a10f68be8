// The fluid's boundary as a closed surface, checked with CGAL's polygon mesh
// processing: closed, no self-intersection, outward orientation, volume.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include "mesher/quality.h"

namespace rectify::mesher
{
  SurfaceCheck check_surface(const std::vector<Point3>                        &in_points,
                             const std::vector<std::array<std::uint32_t, 3>> &triangles, bool orient)
  {
    using K    = CGAL::Exact_predicates_inexact_constructions_kernel;
    using Mesh = CGAL::Surface_mesh<K::Point_3>;
    namespace PMP = CGAL::Polygon_mesh_processing;

    std::vector<K::Point_3>               points;
    std::vector<std::vector<std::size_t>> faces;
    std::vector<std::int64_t>             index(in_points.size(), -1);
    for (const auto &t : triangles)
      {
        std::vector<std::size_t> face;
        for (auto v : t)
          {
            if (index[v] < 0)
              {
                index[v] = static_cast<std::int64_t>(points.size());
                points.emplace_back(in_points[v][0], in_points[v][1], in_points[v][2]);
              }
            face.push_back(static_cast<std::size_t>(index[v]));
          }
        faces.push_back(std::move(face));
      }
    SurfaceCheck out;
    out.n_faces = faces.size();
    if (orient && !PMP::orient_polygon_soup(points, faces))
      return out; // non-manifold: closed = false
    if (!PMP::is_polygon_soup_a_polygon_mesh(faces))
      return out;
    Mesh surface;
    PMP::polygon_soup_to_polygon_mesh(points, faces, surface);
    out.closed = CGAL::is_closed(surface);
    if (!out.closed)
      return out;
    out.self_intersecting = PMP::does_self_intersect(surface);
    if (orient)
      return out;
    out.outward   = PMP::is_outward_oriented(surface);
    out.volume_m3 = PMP::volume(surface);
    return out;
  }

  SurfaceCheck check_surface(const TetMesh &m)
  {
    std::vector<std::array<std::uint32_t, 3>> triangles;
    triangles.reserve(m.boundary.size());
    for (const auto &f : m.boundary)
      triangles.push_back(f.vertices);
    return check_surface(m.vertices, triangles, false);
  }
} // namespace rectify::mesher
