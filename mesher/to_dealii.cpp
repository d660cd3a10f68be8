#include "mesher/to_dealii.h"

#include <deal.II/grid/tria.h>

#include "mesher/mesher.h"

namespace rectify::mesher
{
  void fill_triangulation(const TetMesh &mesh, dealii::Triangulation<3, 3> &tria)
  {
    using namespace dealii;
    std::vector<Point<3>> vertices;
    vertices.reserve(mesh.vertices.size());
    for (const auto &p : mesh.vertices)
      vertices.emplace_back(p[0], p[1], p[2]);
    std::vector<CellData<3>> cells;
    cells.reserve(mesh.cells.size());
    for (std::size_t c = 0; c < mesh.cells.size(); ++c)
      {
        CellData<3> cell(4);
        for (unsigned k = 0; k < 4; ++k)
          cell.vertices[k] = mesh.cells[c][k];
        cell.material_id = mesh.region[c];
        cells.push_back(std::move(cell));
      }
    SubCellData faces;
    faces.boundary_quads.reserve(mesh.boundary.size());
    for (const auto &f : mesh.boundary)
      {
        CellData<2> face(3);
        for (unsigned k = 0; k < 3; ++k)
          face.vertices[k] = f.vertices[k];
        face.boundary_id = f.id;
        faces.boundary_quads.push_back(std::move(face));
      }
    tria.create_triangulation(vertices, cells, faces);

    for (const auto &cell : tria.active_cell_iterators())
      {
        const Tensor<1, 3> a = cell->vertex(1) - cell->vertex(0);
        const Tensor<1, 3> b = cell->vertex(2) - cell->vertex(0);
        const Tensor<1, 3> c = cell->vertex(3) - cell->vertex(0);
        if (!(determinant(Tensor<2, 3>({{a[0], a[1], a[2]}, {b[0], b[1], b[2]}, {c[0], c[1], c[2]}})) > 0))
          throw MeshError("deal.II sees an inverted cell at (" + std::to_string(cell->vertex(0)[0]) + ", " +
                          std::to_string(cell->vertex(0)[1]) + ", " + std::to_string(cell->vertex(0)[2]) + ")");
      }
  }
} // namespace rectify::mesher
