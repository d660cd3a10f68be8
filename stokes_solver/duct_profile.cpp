#include "stokes_solver/duct_profile.h"

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

namespace rectify::stokes
{
  DuctProfile::DuctProfile(std::vector<Point2> points, const std::vector<std::array<std::size_t, 3>> &triangles)
    : points_(std::move(points))
  {
    if (triangles.empty())
      throw std::invalid_argument("a duct's section needs at least one triangle");
    // Number the edges' midpoints after the vertices; count each edge's triangles.
    std::map<std::pair<std::size_t, std::size_t>, std::pair<std::size_t, int>> edges; // -> (node, triangles)
    const std::size_t                                                          n_vertices = points_.size();
    for (const auto &t : triangles)
      {
        for (const auto v : t)
          if (v >= n_vertices)
            throw std::invalid_argument("a duct's triangle names vertex " + std::to_string(v) + " of " +
                                        std::to_string(n_vertices));
        Triangle tri;
        tri.vertex = t;
        const auto &a = points_[t[0]], &b = points_[t[1]], &c = points_[t[2]];
        tri.area = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
        if (tri.area < 0) // counter-clockwise
          {
            std::swap(tri.vertex[1], tri.vertex[2]);
            tri.area = -tri.area;
          }
        for (int i = 0; i < 3; ++i)
          {
            auto       u = tri.vertex[(i + 1) % 3], w = tri.vertex[(i + 2) % 3];
            const auto key = std::minmax(u, w);
            auto [it, added] = edges.try_emplace({key.first, key.second}, n_vertices + edges.size(), 0);
            ++it->second.second;
            tri.midpoint[i] = it->second.first;
          }
        area_ += tri.area;
        triangles_.push_back(tri);
      }
    for (const auto &t : triangles_)
      if (!(t.area > 1e-12 * area_))
        throw std::invalid_argument("a duct's section has a degenerate triangle (vertices " +
                                    std::to_string(t.vertex[0]) + ", " + std::to_string(t.vertex[1]) + ", " +
                                    std::to_string(t.vertex[2]) + ")");
    scale_ = std::sqrt(area_);

    // The edge's nodes (vertices and midpoints of edges with one triangle) are zero.
    const std::size_t n = n_vertices + edges.size();
    std::vector<bool> on_edge(n, false);
    for (const auto &[key, e] : edges)
      if (e.second == 1)
        on_edge[key.first] = on_edge[key.second] = on_edge[e.first] = true;
    std::vector<long> unknown(n, -1);
    long              n_unknowns = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (!on_edge[i])
        unknown[i] = n_unknowns++;
    values_.assign(n, 0.0);

    // Each triangle: P2 shapes in barycentric coordinates, lambda_i (2 lambda_i - 1)
    // at the vertices, 4 lambda_i lambda_j at the midpoints; the edge-midpoint
    // rule integrates the stiffness (degree 2) and the load exactly.
    std::vector<Eigen::Triplet<double>> entries;
    Eigen::VectorXd                     rhs = Eigen::VectorXd::Zero(n_unknowns);
    for (const auto &t : triangles_)
      {
        std::array<Point2, 3> grad; // of lambda_i: the opposite edge turned inwards / (2 area)
        for (int i = 0; i < 3; ++i)
          {
            const auto &b = points_[t.vertex[(i + 1) % 3]], &c = points_[t.vertex[(i + 2) % 3]];
            grad[i] = {(b[1] - c[1]) / (2 * t.area), (c[0] - b[0]) / (2 * t.area)};
          }
        std::array<std::size_t, 6> node{t.vertex[0], t.vertex[1], t.vertex[2], t.midpoint[0], t.midpoint[1], t.midpoint[2]};
        double                     K[6][6] = {};
        for (int q = 0; q < 3; ++q) // the midpoint of the edge opposite vertex q
          {
            std::array<double, 3> l{0.5, 0.5, 0.5};
            l[q] = 0;
            std::array<Point2, 6> g;
            for (int i = 0; i < 3; ++i)
              g[i] = {(4 * l[i] - 1) * grad[i][0], (4 * l[i] - 1) * grad[i][1]};
            for (int i = 0; i < 3; ++i) // midpoint opposite i: between j and k
              {
                const int j = (i + 1) % 3, k = (i + 2) % 3;
                g[3 + i]    = {4 * (l[j] * grad[k][0] + l[k] * grad[j][0]), 4 * (l[j] * grad[k][1] + l[k] * grad[j][1])};
              }
            for (int a = 0; a < 6; ++a)
              for (int b = 0; b < 6; ++b)
                K[a][b] += (g[a][0] * g[b][0] + g[a][1] * g[b][1]) * t.area / 3;
          }
        for (int a = 0; a < 6; ++a)
          {
            const long ua = unknown[node[a]];
            if (ua < 0)
              continue;
            if (a >= 3)
              rhs[ua] += t.area / 3; // the integral of 4 lambda_j lambda_k; a vertex's shape integrates to zero
            for (int b = 0; b < 6; ++b)
              if (const long ub = unknown[node[b]]; ub >= 0)
                entries.emplace_back(ua, ub, K[a][b]);
          }
      }
    if (n_unknowns > 0)
      {
        Eigen::SparseMatrix<double> A(n_unknowns, n_unknowns);
        A.setFromTriplets(entries.begin(), entries.end());
        Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A);
        if (ldlt.info() != Eigen::Success)
          throw std::runtime_error("the duct profile's matrix could not be factorised");
        const Eigen::VectorXd w = ldlt.solve(rhs);
        for (std::size_t i = 0; i < n; ++i)
          if (unknown[i] >= 0)
            values_[i] = w[unknown[i]];
      }
    // The flux: vertex shapes integrate to zero, midpoint shapes to area / 3.
    for (const auto &t : triangles_)
      for (const auto m : t.midpoint)
        flux_ += values_[m] * t.area / 3;
  }

  double DuctProfile::value(double x, double y) const
  {
    for (const auto &t : triangles_)
      {
        std::array<double, 3> l;
        for (int i = 0; i < 3; ++i)
          {
            const auto &b = points_[t.vertex[(i + 1) % 3]], &c = points_[t.vertex[(i + 2) % 3]];
            l[i] = 0.5 * ((c[0] - b[0]) * (y - b[1]) - (c[1] - b[1]) * (x - b[0])) / t.area;
          }
        const double tolerance = 1e-9 * scale_ * scale_ / t.area; // a distance of ~1e-9 of the section
        if (std::min({l[0], l[1], l[2]}) < -tolerance)
          continue;
        double w = 0;
        for (int i = 0; i < 3; ++i)
          {
            const int j = (i + 1) % 3, k = (i + 2) % 3;
            w += values_[t.vertex[i]] * l[i] * (2 * l[i] - 1) + values_[t.midpoint[i]] * 4 * l[j] * l[k];
          }
        return w;
      }
    return 0.0;
  }
} // namespace rectify::stokes
