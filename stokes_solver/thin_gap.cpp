#include "stokes_solver/thin_gap.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace rectify::stokes
{
  ThinGapResult solve_thin_gap(const ThinGapProblem &p)
  {
    if (!(p.spacing > 0) || !(p.x1 > p.x0) || !(p.y1 > p.y0) || !(p.viscosity_Pa_s > 0))
      throw std::invalid_argument("solve_thin_gap: empty rectangle, or non-positive spacing or viscosity");
    const double d  = p.spacing;
    const long   nx = std::lround(std::ceil((p.x1 - p.x0) / d - 1e-9));
    const long   ny = std::lround(std::ceil((p.y1 - p.y0) / d - 1e-9));
    const double dx = (p.x1 - p.x0) / static_cast<double>(nx), dy = (p.y1 - p.y0) / static_cast<double>(ny);
    const auto   cx = [&](long i) { return p.x0 + (static_cast<double>(i) + 0.5) * dx; };
    const auto   cy = [&](long j) { return p.y0 + (static_cast<double>(j) + 0.5) * dy; };
    std::vector<GapCell> kind(static_cast<std::size_t>(nx * ny));
    std::vector<long>    index(kind.size(), -1);
    long                 n = 0;
    for (long j = 0; j < ny; ++j)
      for (long i = 0; i < nx; ++i)
        {
          const auto c = static_cast<std::size_t>(j * nx + i);
          kind[c]      = p.kind(cx(i), cy(j));
          if (kind[c] == GapCell::open)
            index[c] = n++;
        }
    // Conductance of the face between two cells (or a cell and the
    // rectangle's edge, at half the distance): h^3 / (12 mu) at the face's
    // midpoint times face length / distance.
    const double k = 1 / (12 * p.viscosity_Pa_s);
    const auto   conductance = [&](double x, double y, double length, double distance) {
      const double h = p.height(x, y);
      return k * h * h * h * length / distance;
    };
    std::vector<Eigen::Triplet<double>> entries;
    Eigen::VectorXd                     rhs = Eigen::VectorXd::Zero(n);
    double                              source_flux_if_zero = 0; // flux out of the source with p = 0 inside
    std::vector<std::pair<long, double>> source_links;           // (unknown, conductance) next to the source
    const auto link = [&](long a, long b, double g) {            // cell a's equation, neighbour b (-1: sink edge)
      const auto ka = kind[static_cast<std::size_t>(a)];
      const auto kb = b >= 0 ? kind[static_cast<std::size_t>(b)] : GapCell::sink;
      if (ka == GapCell::closed || kb == GapCell::closed)
        return;
      if (ka == GapCell::open)
        {
          const long ia = index[static_cast<std::size_t>(a)];
          entries.emplace_back(ia, ia, g);
          if (kb == GapCell::open)
            entries.emplace_back(ia, index[static_cast<std::size_t>(b)], -g);
          else if (kb == GapCell::source)
            rhs[ia] += g;
        }
      else if (ka == GapCell::source)
        {
          if (kb == GapCell::open)
            source_links.emplace_back(index[static_cast<std::size_t>(b)], g);
          else if (kb == GapCell::sink)
            source_flux_if_zero += g;
        }
    };
    for (long j = 0; j < ny; ++j)
      for (long i = 0; i < nx; ++i)
        {
          const long a = j * nx + i;
          // the four faces: neighbour or the rectangle's edge
          if (i > 0)
            link(a, a - 1, conductance(cx(i) - dx / 2, cy(j), dy, dx));
          else if (p.x0_is_sink)
            link(a, -1, conductance(p.x0, cy(j), dy, dx / 2));
          if (i + 1 < nx)
            link(a, a + 1, conductance(cx(i) + dx / 2, cy(j), dy, dx));
          else if (p.x1_is_sink)
            link(a, -1, conductance(p.x1, cy(j), dy, dx / 2));
          if (j > 0)
            link(a, a - nx, conductance(cx(i), cy(j) - dy / 2, dx, dy));
          else if (p.y0_is_sink)
            link(a, -1, conductance(cx(i), p.y0, dx, dy / 2));
          if (j + 1 < ny)
            link(a, a + nx, conductance(cx(i), cy(j) + dy / 2, dx, dy));
          else if (p.y1_is_sink)
            link(a, -1, conductance(cx(i), p.y1, dx, dy / 2));
        }
    Eigen::SparseMatrix<double> A(n, n);
    A.setFromTriplets(entries.begin(), entries.end());
    // Sparse Cholesky: the grid's 5-point Laplacian is symmetric positive
    // definite; the solution is exact to round-off, and the reference gap's
    // 310 000 cells at two spacings take under a second.
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
    if (n > 0)
      ldlt.compute(A);
    Eigen::VectorXd pressure = n > 0 ? Eigen::VectorXd(ldlt.solve(rhs)) : Eigen::VectorXd();
    if (n > 0 && ldlt.info() != Eigen::Success)
      throw std::runtime_error("thin-gap theory: the sparse Cholesky factorisation failed");
    double flux = source_flux_if_zero;
    for (const auto &[i, g] : source_links)
      flux += g * (1 - pressure[i]);
    if (!(flux > 0) || !std::isfinite(flux))
      throw std::runtime_error("thin-gap theory: no flow leaves the source");
    ThinGapResult r;
    r.R_Pa_s_per_m3 = 1 / flux;
    r.n_unknowns    = static_cast<std::size_t>(n);
    return r;
  }

  namespace
  {
    /// integral(w) over the polygon, -laplace(w) = 1 inside, w = 0 outside,
    /// on squares of side d (cell centres inside the polygon are unknowns).
    double duct_flow_integral(const geometry::Polygon &polygon, double d)
    {
      double x0 = polygon[0][0], x1 = x0, y0 = polygon[0][1], y1 = y0;
      for (const auto &p : polygon)
        x0 = std::min(x0, p[0]), x1 = std::max(x1, p[0]), y0 = std::min(y0, p[1]), y1 = std::max(y1, p[1]);
      const long nx = std::lround(std::ceil((x1 - x0) / d)) + 2, ny = std::lround(std::ceil((y1 - y0) / d)) + 2;
      const double ox = 0.5 * (x0 + x1) - 0.5 * static_cast<double>(nx) * d, oy = 0.5 * (y0 + y1) - 0.5 * static_cast<double>(ny) * d;
      std::vector<long> index(static_cast<std::size_t>(nx * ny), -1);
      long              n = 0;
      for (long j = 0; j < ny; ++j)
        for (long i = 0; i < nx; ++i)
          if (geometry::side_of(polygon, {ox + (static_cast<double>(i) + 0.5) * d, oy + (static_cast<double>(j) + 0.5) * d}) ==
              geometry::Side::inside)
            index[static_cast<std::size_t>(j * nx + i)] = n++;
      if (n == 0)
        throw std::runtime_error("port bore: no cell of the section lies inside it (spacing too coarse)");
      std::vector<Eigen::Triplet<double>> entries;
      for (long j = 0; j < ny; ++j)
        for (long i = 0; i < nx; ++i)
          {
            const long a = index[static_cast<std::size_t>(j * nx + i)];
            if (a < 0)
              continue;
            entries.emplace_back(a, a, 4.0);
            for (const auto &[di, dj] : {std::pair{-1, 0}, std::pair{1, 0}, std::pair{0, -1}, std::pair{0, 1}})
              {
                const long b = index[static_cast<std::size_t>((j + dj) * nx + (i + di))]; // the frame's cells are outside
                if (b >= 0)
                  entries.emplace_back(a, b, -1.0);
              }
          }
      Eigen::SparseMatrix<double> A(n, n);
      A.setFromTriplets(entries.begin(), entries.end());
      Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper, Eigen::IncompleteCholesky<double>> cg;
      cg.setTolerance(1e-12);
      cg.compute(A);
      const Eigen::VectorXd w = cg.solve(Eigen::VectorXd::Constant(n, d * d));
      if (cg.info() != Eigen::Success)
        throw std::runtime_error("port bore: the conjugate gradient solver did not converge");
      return w.sum() * d * d;
    }
  } // namespace

  double port_bore_R(const Port &port, double mu, double spacing_m)
  {
    if (port.circular)
      return 128 * mu * port.length_m / (M_PI * std::pow(port.diameter_m, 4));
    const double fine = duct_flow_integral(port.outline_m, spacing_m), coarse = duct_flow_integral(port.outline_m, 2 * spacing_m);
    return mu * port.length_m / (2 * fine - coarse);
  }

  double ports_bore_R(const ValveGeometry &g, double mu)
  {
    double conductance = 0;
    for (const auto &p : g.ports())
      conductance += 1 / port_bore_R(p, mu, p.circular ? 0.0 : geometry::narrowest_width(p.outline_m) / 40);
    return 1 / conductance;
  }

  double thin_gap_valve_R(const ValveGeometry &g, const std::function<double(double)> &phi, double opening_m,
                          double closed_to_m, double viscosity_Pa_s, double spacing_m)
  {
    const geometry::Polygon boundary = g.reed_boundary();
    const auto              ports    = g.ports();
    ThinGapProblem          p;
    p.x0 = 0, p.x1 = boundary[0][0], p.y0 = boundary[0][1], p.y1 = boundary[0][1];
    for (const auto &q : boundary)
      p.x1 = std::max(p.x1, q[0]), p.y0 = std::min(p.y0, q[1]), p.y1 = std::max(p.y1, q[1]);
    p.spacing        = spacing_m;
    p.viscosity_Pa_s = viscosity_Pa_s;
    p.height         = [&](double x, double) { return opening_m * phi(x); };
    // The frame is the outline's bounding box, its sides sinks but the clamp's;
    // cells outside the outline (beside a taper, a fillet) are sinks too.
    p.kind = [&](double x, double y) {
      for (const auto &port : ports)
        if (port.contains({x, y}))
          return GapCell::source;
      if (geometry::side_of(boundary, {x, y}) == geometry::Side::outside)
        return GapCell::sink;
      return x < closed_to_m ? GapCell::closed : GapCell::open;
    };
    p.x0_is_sink = false; // the clamp
    // The staircase edges make the error first order in the spacing:
    // Richardson extrapolation from the spacing and twice it.
    const double fine = solve_thin_gap(p).R_Pa_s_per_m3;
    p.spacing *= 2;
    const double coarse = solve_thin_gap(p).R_Pa_s_per_m3;
    return 2 * fine - coarse + ports_bore_R(g, viscosity_Pa_s);
  }
} // namespace rectify::stokes
