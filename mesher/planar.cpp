// CGAL's 2D constrained Delaunay triangulation and Delaunay refinement (Mesh_2)
// with a local size field.
#include "mesher/planar.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_size_criteria_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Delaunay_mesher_no_edge_refinement_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <cmath>
#include <map>
#include <stdexcept>

namespace rectify::mesher
{
  namespace
  {
    using K   = CGAL::Exact_predicates_inexact_constructions_kernel;
    using Vb  = CGAL::Delaunay_mesh_vertex_base_2<K>;
    using Fb  = CGAL::Delaunay_mesh_face_base_2<K>;
    using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
    using CDT = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;
    using SizeCriteria = CGAL::Delaunay_mesh_size_criteria_2<CDT>;

    /// CGAL's size criterion with a size field: a triangle is too big when its
    /// longest edge exceeds the target size at its centroid.
    class LocalSizeCriteria : public SizeCriteria
    {
    public:
      using Field = std::function<double(const Point2 &)>;
      LocalSizeCriteria(double aspect_bound, Field field)
        : SizeCriteria(aspect_bound, 1.0), field_(std::move(field))
      {}

      class Is_bad : public SizeCriteria::Is_bad
      {
      public:
        Is_bad(double aspect_bound, const Field *field, const K &traits)
          : SizeCriteria::Is_bad(aspect_bound, 1.0, traits), field_(field)
        {}
        using SizeCriteria::Is_bad::operator();
        CGAL::Mesh_2::Face_badness operator()(const CDT::Face_handle &fh, Quality &q) const
        {
          const auto  &a = fh->vertex(0)->point(), &b = fh->vertex(1)->point(),
                     &c = fh->vertex(2)->point();
          const double la = CGAL::to_double(CGAL::squared_distance(b, c));
          const double lb = CGAL::to_double(CGAL::squared_distance(c, a));
          const double lc = CGAL::to_double(CGAL::squared_distance(a, b));
          double       l[3] = {la, lb, lc};
          std::sort(l, l + 3);
          const Point2 centroid{(a.x() + b.x() + c.x()) / 3, (a.y() + b.y() + c.y()) / 3};
          const double h = (*field_)(centroid);
          q.second       = l[2] / (h * h);
          if (q.size() > 1)
            {
              q.first = 1;
              return CGAL::Mesh_2::IMPERATIVELY_BAD;
            }
          const double area2 = 2 * CGAL::to_double(CGAL::area(a, b, c));
          q.first            = area2 * area2 / (l[2] * l[1]);
          return q.sine() < this->B ? CGAL::Mesh_2::BAD : CGAL::Mesh_2::NOT_BAD;
        }

      private:
        const Field *field_;
      };
      Is_bad is_bad_object() const { return Is_bad(this->bound(), &field_, this->traits); }

    private:
      Field field_;
    };
  } // namespace

  PlanarMesh mesh_planar(const PlanarInput &in)
  {
    CDT                                 cdt;
    std::vector<CDT::Vertex_handle>     handles;
    for (const auto &p : in.points)
      handles.push_back(cdt.insert(K::Point_2(p[0], p[1])));
    for (const auto &s : in.segments)
      cdt.insert_constraint(handles[s[0]], handles[s[1]]);

    const double sine = std::sin(in.min_angle_deg * M_PI / 180.0);
    LocalSizeCriteria criteria(sine * sine, in.size);
    if (in.refine_segments)
      {
        CGAL::Delaunay_mesher_2<CDT, LocalSizeCriteria> mesher(cdt, criteria);
        mesher.refine_mesh();
      }
    else
      {
        CGAL::Delaunay_mesher_no_edge_refinement_2<CDT, LocalSizeCriteria> mesher(cdt, criteria);
        // CGAL 5.5's constructor leaves the seeds' mark uninitialised and
        // refine_mesh() reads it (UndefinedBehaviorSanitizer: "load of value
        // 80, which is not a valid value for type 'bool'"); with no seeds its
        // value does not matter, but reading it is undefined: set it.
        mesher.clear_seeds();
        mesher.refine_mesh();
      }

    PlanarMesh                                 out;
    std::map<CDT::Vertex_handle, std::uint32_t> index;
    for (std::size_t i = 0; i < handles.size(); ++i)
      if (index.emplace(handles[i], static_cast<std::uint32_t>(i)).second)
        out.points.push_back(in.points[i]);
      else
        throw std::logic_error("mesh_planar: duplicate input point");
    for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v)
      if (index.emplace(v, static_cast<std::uint32_t>(out.points.size())).second)
        out.points.push_back({v->point().x(), v->point().y()});
    out.on_segment.assign(out.points.size(), false);
    for (auto e = cdt.finite_edges_begin(); e != cdt.finite_edges_end(); ++e)
      if (cdt.is_constrained(*e))
        for (int k : {1, 2})
          out.on_segment[index.at(e->first->vertex((e->second + k) % 3))] = true;
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f)
      if (f->is_in_domain())
        out.triangles.push_back({index.at(f->vertex(0)), index.at(f->vertex(1)),
                                 index.at(f->vertex(2))});
    return out;
  }
} // namespace rectify::mesher
