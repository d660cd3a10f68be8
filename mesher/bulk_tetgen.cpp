#define TETLIBRARY
#include <tetgen.h>

#include "mesher/bulk_tetgen.h"
#include "mesher/mesher.h"
#include "mesher/quality.h"

#include <cstdio>
#include <cstring>
#include <vector>

namespace rectify::mesher
{
  namespace
  {
    std::string tetgen_cause(int code)
    {
      switch (code)
        {
          case 1:
            return "out of memory";
          case 2:
            return "internal error";
          case 3:
            return "the input surface intersects itself";
          case 4:
            return "a very small input feature (below TetGen's tolerance)";
          case 5:
            return "two input facets are very close to each other";
          case 10:
            return "invalid input";
          default:
            return "error code " + std::to_string(code);
        }
    }
  } // namespace

  TetgenResult tetrahedralize_closed_surface(const std::vector<Point3>                        &points,
                                             const std::vector<std::array<std::uint32_t, 3>> &triangles,
                                             const TetgenOptions                              &o)
  {
    // TetGen may crash rather than fail on a surface that is not closed or
    // intersects itself: check it first (CGAL).
    const SurfaceCheck check = check_surface(points, triangles, true);
    if (!check.closed)
      throw MeshError("the surface given to TetGen (" + std::to_string(triangles.size()) +
                      " triangles) is not a closed manifold surface");
    if (check.self_intersecting)
      throw MeshError("the surface given to TetGen (" + std::to_string(triangles.size()) +
                      " triangles) intersects itself");

    tetgenio in, out;
    in.firstnumber    = 0;
    in.numberofpoints = static_cast<int>(points.size());
    in.pointlist      = new REAL[3 * points.size()];
    for (std::size_t i = 0; i < points.size(); ++i)
      for (int d = 0; d < 3; ++d)
        in.pointlist[3 * i + d] = points[i][d];
    in.numberoffacets  = static_cast<int>(triangles.size());
    in.facetlist       = new tetgenio::facet[triangles.size()];
    in.facetmarkerlist = new int[triangles.size()];
    for (std::size_t f = 0; f < triangles.size(); ++f)
      {
        tetgenio::facet &facet = in.facetlist[f];
        facet.numberofpolygons = 1;
        facet.polygonlist      = new tetgenio::polygon[1];
        facet.numberofholes    = 0;
        facet.holelist         = nullptr;
        tetgenio::polygon &p   = facet.polygonlist[0];
        p.numberofvertices     = 3;
        p.vertexlist           = new int[3];
        for (int k = 0; k < 3; ++k)
          p.vertexlist[k] = static_cast<int>(triangles[f][k]);
        in.facetmarkerlist[f] = 1;
      }

    char switches[160];
    if (o.max_volume_m3 > 0)
      std::snprintf(switches, sizeof(switches), "pYzQq%.6g/%.6ga%.9g", o.radius_edge_ratio,
                    o.min_dihedral_deg, o.max_volume_m3);
    else
      std::snprintf(switches, sizeof(switches), "pYzQq%.6g/%.6g", o.radius_edge_ratio,
                    o.min_dihedral_deg);
    try
      {
        tetrahedralize(switches, &in, &out);
      }
    catch (int code)
      {
        throw MeshError(std::string("TetGen (") + switches + ") failed meshing the pocket above the slab: " +
                        tetgen_cause(code));
      }
    catch (const std::bad_alloc &)
      {
        throw MeshError(std::string("TetGen (") + switches + ") ran out of memory");
      }
    if (out.numberoftetrahedra <= 0 || out.numberofcorners != 4)
      throw MeshError(std::string("TetGen (") + switches + ") returned no linear tetrahedra");
    if (out.numberofpoints < in.numberofpoints)
      throw MeshError("TetGen merged input points: the pocket's surface has duplicate vertices");
    for (int i = 0; i < in.numberofpoints; ++i)
      for (int d = 0; d < 3; ++d)
        if (out.pointlist[3 * i + d] != in.pointlist[3 * i + d])
          throw MeshError("TetGen moved or reordered input point " + std::to_string(i));

    TetgenResult r;
    r.switches = switches;
    for (int i = in.numberofpoints; i < out.numberofpoints; ++i)
      r.new_points.push_back({out.pointlist[3 * i], out.pointlist[3 * i + 1], out.pointlist[3 * i + 2]});
    r.cells.resize(static_cast<std::size_t>(out.numberoftetrahedra));
    for (int t = 0; t < out.numberoftetrahedra; ++t)
      for (int k = 0; k < 4; ++k)
        r.cells[t][k] = static_cast<std::uint32_t>(out.tetrahedronlist[4 * t + k]);
    return r;
  }
} // namespace rectify::mesher
