#include <algorithm>
#include <cmath>

#include "mesher/layout.h"
#include "mesher/mesher.h"

namespace rectify::mesher::detail
{
  namespace
  {
    struct FaceRecord
    {
      std::array<std::uint32_t, 3> key;
      std::uint32_t                cell;
      std::uint32_t                opposite;
    };

    /// Every face of every cell (sorted vertex triple, cell, opposite vertex),
    /// sorted so that a face's records are adjacent.
    std::vector<FaceRecord> sorted_faces(const TetMesh &m)
    {
      std::vector<FaceRecord> faces;
      faces.reserve(m.cells.size() * 4);
      for (std::uint32_t c = 0; c < m.cells.size(); ++c)
        for (int k = 0; k < 4; ++k)
          {
            std::array<std::uint32_t, 3> key;
            int                          n = 0;
            for (int j = 0; j < 4; ++j)
              if (j != k)
                key[n++] = m.cells[c][j];
            std::sort(key.begin(), key.end());
            faces.push_back({key, c, m.cells[c][k]});
          }
      std::sort(faces.begin(), faces.end(), [](const FaceRecord &a, const FaceRecord &b) { return a.key < b.key; });
      return faces;
    }
  } // namespace

  void orient_and_label(TetMesh &m, const std::function<std::uint8_t(const std::array<Point3, 3> &)> &classify)
  {
    for (std::size_t c = 0; c < m.cells.size(); ++c)
      if (cell_volume(m, c) < 0)
        std::swap(m.cells[c][2], m.cells[c][3]);
    const std::vector<FaceRecord> faces = sorted_faces(m);
    m.boundary.clear();
    for (std::size_t i = 0; i < faces.size(); ++i)
      {
        const bool single = (i == 0 || faces[i - 1].key != faces[i].key) &&
                            (i + 1 == faces.size() || faces[i + 1].key != faces[i].key);
        if (!single)
          continue;
        auto        key = faces[i].key;
        const auto &a = m.vertices[key[0]], &b = m.vertices[key[1]], &c = m.vertices[key[2]];
        if (signed_volume(a, b, c, m.vertices[faces[i].opposite]) > 0)
          std::swap(key[1], key[2]);
        m.boundary.push_back({key, classify({a, b, c})});
      }
  }

  TetMesh assemble_fluid(TetMesh &all, const Layout &lay, const std::vector<PortPolygon> &ports)
  {
    const auto  &g  = lay.g;
    const double hp = 0.5 * lay.Wp;
    for (std::size_t c = 0; c < all.cells.size(); ++c)
      {
        auto        &v  = all.cells[c];
        double       vol = cell_volume(all, c);
        if (vol < 0)
          {
            std::swap(v[2], v[3]);
            vol = -vol;
          }
        double longest = 0;
        for (int i = 0; i < 4; ++i)
          for (int j = i + 1; j < 4; ++j)
            {
              const auto &p = all.vertices[v[i]], &q = all.vertices[v[j]];
              longest = std::max(longest, std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]));
            }
        const double rel = vol / (longest * longest * longest);
        if (!(rel > 1e-13))
          throw MeshError("a degenerate or inverted cell (" + region_name(all.region[c]) + ") at " +
                          where(all.vertices[v[0]]) + ": volume / edge^3 = " + format_number(rel));
      }

    const std::vector<FaceRecord> faces = sorted_faces(all);

    const double tol  = 1e-9 * lay.Lp;
    auto         on   = [&](const std::array<std::uint32_t, 3> &f, int axis, double value) {
      for (auto v : f)
        if (std::abs(all.vertices[v][axis] - value) > tol)
          return false;
      return true;
    };
    const int    outlet_axis  = g.outlet_face == "ceiling" ? 2 : g.outlet_face == "x-max" ? 0 : 1;
    const double outlet_value = g.outlet_face == "ceiling" ? lay.Hp
                                : g.outlet_face == "x-max" ? lay.Lp
                                : g.outlet_face == "y-min" ? -hp
                                                           : hp;
    // A face on a port's side wall: every vertex on its mouth's edge, within its bore.
    auto on_port_side = [&](const std::array<std::uint32_t, 3> &f) {
      for (const auto &port : ports)
        {
          bool all_on = true;
          for (auto v : f)
            {
              const auto &p = all.vertices[v];
              all_on = all_on && p[2] <= tol && p[2] >= -port.length - tol && port.on_edge(p[0], p[1], tol);
            }
          if (all_on)
            return true;
        }
      return false;
    };
    auto classify_outer = [&](const std::array<std::uint32_t, 3> &f) -> std::uint8_t {
      for (const auto &port : ports)
        if (on(f, 2, -port.length))
          return inlet;
      if (on(f, outlet_axis, outlet_value))
        return outlet;
      if (on(f, 0, 0) || on(f, 0, lay.Lp) || on(f, 1, -hp) || on(f, 1, hp) || on(f, 2, lay.Hp) ||
          on(f, 2, 0) || on_port_side(f))
        return walls;
      const auto &p = all.vertices[f[0]];
      throw MeshError("the mesh does not conform: a boundary face inside the domain near " + where(p) +
                      " (TetGen changed the slab's top surface?)");
    };

    std::vector<BoundaryFace> boundary;
    for (std::size_t i = 0; i < faces.size();)
      {
        std::size_t j = i + 1;
        while (j < faces.size() && faces[j].key == faces[i].key)
          ++j;
        if (j - i > 2)
          throw MeshError("the mesh does not conform: a face shared by " + std::to_string(j - i) +
                          " cells near " + where(all.vertices[faces[i].key[0]]));
        const FaceRecord *fluid_side = nullptr;
        std::uint8_t      id         = 0;
        if (j - i == 1)
          {
            if (is_fluid(all.region[faces[i].cell]))
              {
                fluid_side = &faces[i];
                id         = classify_outer(faces[i].key);
              }
          }
        else
          {
            const bool f0 = is_fluid(all.region[faces[i].cell]);
            const bool f1 = is_fluid(all.region[faces[i + 1].cell]);
            if (f0 != f1)
              {
                fluid_side = f0 ? &faces[i] : &faces[i + 1];
                const auto other = all.region[(f0 ? faces[i + 1] : faces[i]).cell];
                id = other == tag_reed_solid ? reed : walls;
              }
          }
        if (fluid_side)
          {
            auto        key = fluid_side->key;
            const auto &o   = all.vertices[fluid_side->opposite];
            if (signed_volume(all.vertices[key[0]], all.vertices[key[1]], all.vertices[key[2]], o) > 0)
              std::swap(key[1], key[2]);
            boundary.push_back({key, id});
          }
        i = j;
      }
    std::vector<std::int64_t> new_index(all.vertices.size(), -1);
    TetMesh                   mesh;
    auto                      keep = [&](std::uint32_t v) {
      if (new_index[v] < 0)
        {
          new_index[v] = static_cast<std::int64_t>(mesh.vertices.size());
          mesh.vertices.push_back(all.vertices[v]);
        }
      return static_cast<std::uint32_t>(new_index[v]);
    };
    for (std::size_t c = 0; c < all.cells.size(); ++c)
      if (is_fluid(all.region[c]))
        {
          const auto &v = all.cells[c];
          mesh.cells.push_back({keep(v[0]), keep(v[1]), keep(v[2]), keep(v[3])});
          mesh.region.push_back(all.region[c]);
        }
    for (const auto &f : boundary)
      mesh.boundary.push_back({{keep(f.vertices[0]), keep(f.vertices[1]), keep(f.vertices[2])}, f.id});

    return mesh;
  }
} // namespace rectify::mesher::detail
