#include "mesher/quality.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace rectify::mesher
{
  namespace
  {
    using Vec = std::array<double, 3>;
    Vec    sub(const Point3 &a, const Point3 &b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
    Vec    cross(const Vec &u, const Vec &v)
    {
      return {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    }
    double dot(const Vec &u, const Vec &v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; }

    template <std::size_t N, std::size_t M>
    void add_to_histogram(std::array<std::size_t, N> &h, const std::array<double, M> &edges,
                          double value)
    {
      std::size_t bin = 0;
      while (bin < edges.size() && value >= edges[bin])
        ++bin;
      ++h[bin];
    }

    void add(RegionQuality &q, double volume, double min_dih, double max_dih, double aspect,
             double rel_volume)
    {
      ++q.n_cells;
      q.volume_m3 += volume;
      q.min_dihedral_deg    = std::min(q.min_dihedral_deg, min_dih);
      q.max_dihedral_deg    = std::max(q.max_dihedral_deg, max_dih);
      q.max_aspect_ratio    = std::max(q.max_aspect_ratio, aspect);
      q.min_relative_volume = std::min(q.min_relative_volume, rel_volume);
      add_to_histogram(q.dihedral_histogram, dihedral_bin_edges_deg, min_dih);
      add_to_histogram(q.aspect_histogram, aspect_bin_edges, aspect);
    }
  } // namespace

  MeshQuality measure_quality(const TetMesh &m)
  {
    MeshQuality q;
    for (std::size_t c = 0; c < m.cells.size(); ++c)
      {
        const auto  &id = m.cells[c];
        const Point3 p[4] = {m.vertices[id[0]], m.vertices[id[1]], m.vertices[id[2]],
                             m.vertices[id[3]]};
        // Outward area normals of the faces opposite each vertex (positive orientation).
        const Vec n[4] = {cross(sub(p[2], p[1]), sub(p[3], p[1])),
                          cross(sub(p[3], p[0]), sub(p[2], p[0])),
                          cross(sub(p[1], p[0]), sub(p[3], p[0])),
                          cross(sub(p[2], p[0]), sub(p[1], p[0]))};
        double       area_sum = 0, norms[4];
        for (int k = 0; k < 4; ++k)
          {
            norms[k] = std::sqrt(dot(n[k], n[k]));
            area_sum += 0.5 * norms[k];
          }
        double min_dih = 180, max_dih = 0;
        for (int k = 0; k < 4; ++k)
          for (int l = k + 1; l < 4; ++l)
            {
              const double cosine = std::clamp(-dot(n[k], n[l]) / (norms[k] * norms[l]), -1.0, 1.0);
              const double angle  = std::acos(cosine) * 180.0 / M_PI;
              min_dih             = std::min(min_dih, angle);
              max_dih             = std::max(max_dih, angle);
            }
        double longest = 0;
        for (int k = 0; k < 4; ++k)
          for (int l = k + 1; l < 4; ++l)
            longest = std::max(longest, std::sqrt(dot(sub(p[k], p[l]), sub(p[k], p[l]))));
        const double volume   = signed_volume(p[0], p[1], p[2], p[3]);
        const double inradius = 3 * volume / area_sum;
        const double aspect   = longest / (2 * std::sqrt(6.0) * inradius);
        const double rel      = volume / (longest * longest * longest);
        add(q.all, volume, min_dih, max_dih, aspect, rel);
        add(q.region.at(m.region[c]), volume, min_dih, max_dih, aspect, rel);
      }
    return q;
  }

  std::string quality_report(const MeshQuality &q)
  {
    std::string out;
    char        line[256];
    const auto  row = [&](const std::string &name, const RegionQuality &r) {
      std::snprintf(line, sizeof(line),
                    "%-6s %9zu cells  volume %.6e m^3  dihedral %7.3f..%7.3f deg  aspect <= %.4g"
                    "  volume/edge^3 >= %.3g\n",
                    name.c_str(), r.n_cells, r.volume_m3, r.n_cells ? r.min_dihedral_deg : 0.0,
                    r.max_dihedral_deg, r.max_aspect_ratio, r.n_cells ? r.min_relative_volume : 0.0);
      out += line;
    };
    out += "# mesh quality per region (rectify mesh)\n";
    for (int r = 0; r < n_regions; ++r)
      row(region_name(static_cast<std::uint8_t>(r)), q.region[r]);
    row("all", q.all);
    std::snprintf(line, sizeof(line), "smallest angle of the floor triangles: %.3f deg\n\n",
                  q.min_floor_angle_deg);
    out += line;
    const auto histogram = [&](const std::string &heading, auto counts) {
      out += heading;
      for (int r = 0; r <= n_regions; ++r)
        {
          const auto &rq = r < n_regions ? q.region[r] : q.all;
          std::snprintf(line, sizeof(line), "%-6s", r < n_regions ? region_name(r).c_str() : "all");
          out += line;
          for (auto n : counts(rq))
            {
              std::snprintf(line, sizeof(line), " %6zu", n);
              out += line;
            }
          out += "\n";
        }
    };
    histogram("cells by smallest dihedral angle [deg]\nregion   <1     1-5    5-10   10-20  20-30  "
              "30-40  >=40\n",
              [](const RegionQuality &r) { return r.dihedral_histogram; });
    histogram("\ncells by aspect ratio\nregion   <2     2-5    5-10   10-100 100-1e3 >=1e3\n",
              [](const RegionQuality &r) { return r.aspect_histogram; });
    out += "\nThe layered cells (gap, slab, port) are thin by design: one gap layer is a third of"
           " the local gap\nunder a floor triangle of size_reed_m; their quality is that of the"
           " floor triangle and the\nlayer grading. TetGen's cells (bulk) are isotropic.\n";
    return out;
  }
} // namespace rectify::mesher
