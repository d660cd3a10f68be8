#include "mesher/writers.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "common/io.h"

namespace rectify::mesher
{
  namespace
  {
    void append(std::string &out, const char *format, auto... args)
    {
      char buf[160];
      const int n = std::snprintf(buf, sizeof(buf), format, args...);
      out.append(buf, static_cast<std::size_t>(n));
    }

    std::string vtu(const std::vector<Point3> &points, std::size_t n_cells, int corners, int vtk_type,
                    auto cell_vertex, const char *data_name, auto cell_value)
    {
      std::string out;
      out.reserve(points.size() * 60 + n_cells * 50);
      out += "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" "
             "byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n";
      append(out, "<Piece NumberOfPoints=\"%zu\" NumberOfCells=\"%zu\">\n", points.size(), n_cells);
      out += "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
      for (const auto &p : points)
        append(out, "%.17g %.17g %.17g\n", p[0], p[1], p[2]);
      out += "</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" "
             "format=\"ascii\">\n";
      for (std::size_t c = 0; c < n_cells; ++c)
        {
          for (int k = 0; k < corners; ++k)
            append(out, k ? " %u" : "%u", cell_vertex(c, k));
          out += '\n';
        }
      out += "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
      for (std::size_t c = 0; c < n_cells; ++c)
        append(out, "%zu\n", (c + 1) * static_cast<std::size_t>(corners));
      out += "</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n";
      for (std::size_t c = 0; c < n_cells; ++c)
        append(out, "%d\n", vtk_type);
      append(out, "</DataArray>\n</Cells>\n<CellData Scalars=\"%s\">\n", data_name);
      append(out, "<DataArray type=\"Int32\" Name=\"%s\" format=\"ascii\">\n", data_name);
      for (std::size_t c = 0; c < n_cells; ++c)
        append(out, "%d\n", cell_value(c));
      out += "</DataArray>\n</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
      return out;
    }
  } // namespace

  void write_vtu(const std::filesystem::path &path, const TetMesh &m)
  {
    write_file_atomic(path, vtu(
                              m.vertices, m.cells.size(), 4, 10,
                              [&](std::size_t c, int k) { return m.cells[c][k]; }, "region",
                              [&](std::size_t c) { return static_cast<int>(m.region[c]); }));
  }

  void write_boundary_vtu(const std::filesystem::path &path, const TetMesh &m)
  {
    write_file_atomic(path, vtu(
                              m.vertices, m.boundary.size(), 3, 5,
                              [&](std::size_t f, int k) { return m.boundary[f].vertices[k]; },
                              "boundary_id",
                              [&](std::size_t f) { return static_cast<int>(m.boundary[f].id); }));
  }

  std::vector<Segment2> section(const TetMesh &m, double y0)
  {
    std::vector<Segment2> out;
    for (const auto &cell : m.cells)
      {
        // Points where the cell's edges cross the plane.
        std::vector<std::array<double, 2>> cut;
        for (int i = 0; i < 4; ++i)
          for (int j = i + 1; j < 4; ++j)
            {
              const auto  &a = m.vertices[cell[i]], &b = m.vertices[cell[j]];
              const double da = a[1] - y0, db = b[1] - y0;
              if ((da < 0) != (db < 0))
                {
                  const double w = da / (da - db);
                  cut.push_back({a[0] + w * (b[0] - a[0]), a[2] + w * (b[2] - a[2])});
                }
            }
        if (cut.size() < 3)
          continue;
        // a triangle or a quadrilateral: order its corners around their centroid
        double cx = 0, cz = 0;
        for (const auto &p : cut)
          cx += p[0] / static_cast<double>(cut.size()), cz += p[1] / static_cast<double>(cut.size());
        std::sort(cut.begin(), cut.end(), [&](const auto &p, const auto &q) {
          return std::atan2(p[1] - cz, p[0] - cx) < std::atan2(q[1] - cz, q[0] - cx);
        });
        for (std::size_t k = 0; k < cut.size(); ++k)
          {
            const auto &p = cut[k], &q = cut[(k + 1) % cut.size()];
            out.push_back({p[0], p[1], q[0], q[1]});
          }
      }
    return out;
  }

  void write_msh(const std::filesystem::path &path, const TetMesh &m)
  {
    std::string out;
    out.reserve(m.vertices.size() * 70 + (m.cells.size() + m.boundary.size()) * 50);
    out += "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n5\n"
           "2 1 \"inlet\"\n2 2 \"outlet\"\n2 3 \"walls\"\n2 4 \"reed\"\n3 10 \"fluid\"\n"
           "$EndPhysicalNames\n$Nodes\n";
    append(out, "%zu\n", m.vertices.size());
    for (std::size_t i = 0; i < m.vertices.size(); ++i)
      append(out, "%zu %.17g %.17g %.17g\n", i + 1, m.vertices[i][0], m.vertices[i][1], m.vertices[i][2]);
    out += "$EndNodes\n$Elements\n";
    append(out, "%zu\n", m.boundary.size() + m.cells.size());
    std::size_t n = 0;
    for (const auto &f : m.boundary)
      append(out, "%zu 2 2 %d %d %u %u %u\n", ++n, f.id, f.id, f.vertices[0] + 1, f.vertices[1] + 1,
             f.vertices[2] + 1);
    for (std::size_t c = 0; c < m.cells.size(); ++c)
      append(out, "%zu 4 2 10 %d %u %u %u %u\n", ++n, m.region[c] + 1, m.cells[c][0] + 1,
             m.cells[c][1] + 1, m.cells[c][2] + 1, m.cells[c][3] + 1);
    out += "$EndElements\n";
    write_file_atomic(path, out);
  }
} // namespace rectify::mesher
