#include "stokes_solver/thin_gap.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>

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
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper, Eigen::IncompleteCholesky<double>> cg;
    cg.setTolerance(1e-12);
    cg.setMaxIterations(static_cast<Eigen::Index>(10 * n + 100));
    cg.compute(A);
    Eigen::VectorXd pressure = n > 0 ? Eigen::VectorXd(cg.solve(rhs)) : Eigen::VectorXd();
    if (n > 0 && cg.info() != Eigen::Success)
      throw std::runtime_error("thin-gap theory: the conjugate gradient solver did not converge");
    double flux = source_flux_if_zero;
    for (const auto &[i, g] : source_links)
      flux += g * (1 - pressure[i]);
    if (!(flux > 0) || !std::isfinite(flux))
      throw std::runtime_error("thin-gap theory: no flow leaves the source");
    ThinGapResult r;
    r.R_Pa_s_per_m3 = 1 / flux;
    r.n_unknowns    = static_cast<std::size_t>(n);
    r.iterations    = static_cast<unsigned>(cg.iterations());
    return r;
  }

  double thin_gap_valve_R(const ValveGeometry &g, const std::function<double(double)> &phi, double opening_m,
                          double closed_to_m, double viscosity_Pa_s, double spacing_m)
  {
    ThinGapProblem p;
    p.x0 = 0, p.x1 = g.reed_length_m, p.y0 = -g.reed_width_m / 2, p.y1 = g.reed_width_m / 2;
    p.spacing        = spacing_m;
    p.viscosity_Pa_s = viscosity_Pa_s;
    p.height         = [&](double x, double) { return opening_m * phi(x); };
    const double r1  = g.port_diameter_m / 2;
    p.kind           = [&](double x, double y) {
      if (std::hypot(x - g.port_center_x_m, y) < r1)
        return GapCell::source;
      return x < closed_to_m ? GapCell::closed : GapCell::open;
    };
    p.x0_is_sink = false; // the clamp
    const double port = 128 * viscosity_Pa_s * g.port_length_m / (M_PI * std::pow(g.port_diameter_m, 4));
    // The staircase port makes the error first order in the spacing:
    // Richardson extrapolation from the spacing and twice it.
    const double fine = solve_thin_gap(p).R_Pa_s_per_m3;
    p.spacing *= 2;
    const double coarse = solve_thin_gap(p).R_Pa_s_per_m3;
    return 2 * fine - coarse + port;
  }
} // namespace rectify::stokes
