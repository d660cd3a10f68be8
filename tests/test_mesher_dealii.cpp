// The mesher's in-memory path into deal.II: a Triangulation<3> with the same
// cells, volume and boundary ids, every cell positively oriented.
#include <gtest/gtest.h>

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_fe.h>
#include <deal.II/grid/tria.h>

#include <map>

#include "common/case_file.h"
#include "mesher/mesher.h"
#include "mesher/to_dealii.h"

using namespace rectify;
using namespace rectify::mesher;

TEST(MesherDealii, TriangulationHasTheMeshsCellsVolumeAndBoundaryIds)
{
  const auto p = MeshParameters::from_case(CaseFile::load(reference_case_path()));
  const auto r = mesh_valve(p, 20e-6);
  dealii::Triangulation<3> tria;
  fill_triangulation(r.mesh, tria);
  EXPECT_EQ(tria.n_active_cells(), r.mesh.cells.size());
  EXPECT_EQ(tria.n_vertices(), r.mesh.vertices.size());
  // The volume as a solver integrates it: sum of JxW with simplex
  // quadrature. (GridTools::volume of deal.II 9.4 uses a hypercube quadrature
  // and reports 6x the volume of a tetrahedral mesh.)
  const dealii::FE_SimplexP<3>   fe(1);
  const dealii::MappingFE<3>     mapping(fe);
  dealii::FEValues<3>            values(mapping, fe, dealii::QGaussSimplex<3>(1), dealii::update_JxW_values);
  double                         volume = 0;
  for (const auto &cell : tria.active_cell_iterators())
    {
      values.reinit(cell);
      for (unsigned q = 0; q < values.n_quadrature_points; ++q)
        volume += values.JxW(q);
    }
  EXPECT_NEAR(volume / r.info.exact_fluid_volume_m3, 1.0, 1e-6);

  std::map<int, double>      area;
  std::map<int, std::size_t> count;
  for (const auto &cell : tria.active_cell_iterators())
    {
      EXPECT_EQ(cell->reference_cell(), dealii::ReferenceCells::Tetrahedron);
      for (const auto f : cell->face_indices())
        if (cell->face(f)->at_boundary())
          {
            const auto face = cell->face(f);
            const auto u = face->vertex(1) - face->vertex(0), v = face->vertex(2) - face->vertex(0);
            area[face->boundary_id()] += 0.5 * dealii::cross_product_3d(u, v).norm();
            ++count[face->boundary_id()];
          }
    }
  EXPECT_EQ(count.size(), 4u); // exactly the ids 1..4, none left at deal.II's default 0
  for (int id = inlet; id <= reed; ++id)
    {
      EXPECT_EQ(count[id], r.info.boundary_faces[id]) << id;
      EXPECT_NEAR(area[id] / r.info.boundary_area_m2[id], 1.0, 1e-12) << id;
    }
  EXPECT_NEAR(area[inlet] / r.info.exact_inlet_area_m2, 1.0, 1e-6);
  EXPECT_NEAR(area[outlet] / r.info.exact_outlet_area_m2, 1.0, 1e-6);
}
