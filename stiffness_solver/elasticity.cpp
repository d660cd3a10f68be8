// The reed as a 3D linear elastic plate on a hexahedral mesh, after deal.II's
// step-8 (elasticity) and step-36 (eigenvalues, here with ARPACK in
// shift-and-invert mode around 0 and UMFPACK for the inverse).
//
// Domain: the reed's outline extruded through its thickness [0, t]. The
// shorthand's rectangle [0, L] x [-W/2, W/2] is a structured grid; any other
// outline is triangulated (CGAL, mesher/planar.h), each triangle split into
// three quadrilaterals, and extruded into hexahedra. Boundary ids: 0 the
// clamp face x = 0 (u = 0), 1 the tip face (the outline's edge at its
// largest x), 2 the other sides, 4 the underside z = 0, 5 the top.
//
// Weak form: find u with u = 0 on the clamp such that for all v
//   (lambda div u, div v) + (2 mu eps(u), eps(v)) = (t_N, v)_Gamma,
// and the modes solve K phi = omega^2 M phi with M = (rho u, v).
#include "stiffness_solver/elasticity.h"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/symmetric_tensor.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/arpack_solver.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparse_direct.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/vector_tools.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <cmath>
#include <complex>
#include <fstream>
#include <numbers>

#include "common/io.h"
#include "mesher/planar.h"
#include "stiffness_solver/analytic.h"

namespace rectify::stiffness
{
  using namespace dealii;

  namespace
  {
    constexpr unsigned int dim = 3;

    /// The underside's bending stress at the clamp line for a displacement u
    /// (tension positive): the width-mean from the section's moment, and the
    /// peak principal stress one fit station from the clamp over its mean.
    struct RootStress
    {
      double mean_Pa = 0, concentration = 1;
    };

    class ReedElasticity
    {
    public:
      ReedElasticity(const StiffnessParameters &parameters, const SolveOptions &options);
      StiffnessResult run();

    private:
      void make_grid();
      void setup_system();
      void assemble_system();
      void assemble_load();
      void solve();
      void compute_modes();
      void sample_shape();
      void output_results() const;
      void check_large_deflection(double opening_m, double unloaded_to_m);
      double assemble_large_deflection(const Vector<double> &u, double level, SparseMatrix<double> &tangent,
                                       Vector<double> &residual) const;
      unsigned newton(Vector<double> &u, double level, SparseMatrix<double> &tangent) const;

      /// The tip face's mean of u's `component` (z by default); `antisymmetric`:
      /// its halves either side of the tip's centre with opposite signs.
      double tip_face_integral(const Vector<double> &u, bool antisymmetric, unsigned component = 2) const;
      /// `green`: the stress from the Green-Lagrange strain (second
      /// Piola-Kirchhoff) for a large-deflection solution.
      RootStress root_stress(const Vector<double> &u, double fit_to_m, bool green = false) const;
      double value_z(const Vector<double> &u, const Point<dim> &p) const;

      void make_outline_grid();

      const StiffnessParameters &p_;
      const SolveOptions        &options_;
      const double               L_, W_, t_;
      const geometry::Polygon    outline_;  ///< the reed's boundary, fillets drawn
      const std::vector<Port>    ports_;
      double                     tip_area_ = 0; ///< area of the tip face
      double                     tip_y_    = 0; ///< centre of the tip edge

      Triangulation<dim>        triangulation_;
      FESystem<dim>             fe_;
      DoFHandler<dim>           dof_handler_;
      AffineConstraints<double> constraints_;
      SparsityPattern           sparsity_;
      SparseMatrix<double>      stiffness_matrix_;
      SparseMatrix<double>      mass_matrix_;
      SparseDirectUMFPACK       stiffness_inverse_;
      Vector<double>            load_;     // for a unit load level
      Vector<double>            solution_; // displacement for a unit load level
      std::vector<Vector<double>> mode_shapes_;
      StiffnessResult           result_;
    };

    ReedElasticity::ReedElasticity(const StiffnessParameters &parameters, const SolveOptions &options)
      : p_(parameters)
      , options_(options)
      , L_(parameters.geometry.reed_length_m)
      , W_(parameters.geometry.reed_width_m)
      , t_(parameters.geometry.reed_thickness_m)
      , outline_(parameters.geometry.reed_boundary())
      , ports_(parameters.geometry.ports())
      , fe_(FE_Q<dim>(parameters.settings.fe_degree), dim)
      , dof_handler_(triangulation_)
    {}

    void ReedElasticity::make_grid()
    {
      const auto &s = p_.settings;
      if (p_.geometry.is_shorthand())
        GridGenerator::subdivided_hyper_rectangle(
          triangulation_,
          {s.cells_along_length, s.cells_across_width, s.cells_through_thickness},
          Point<dim>(0, -W_ / 2, 0), Point<dim>(L_, W_ / 2, t_), /*colorize=*/true);
      else
        make_outline_grid();
      // The tip face: its area and the centre of its edge.
      tip_area_ = 0;
      double y_moment = 0;
      for (const auto &cell : triangulation_.active_cell_iterators())
        for (const auto f : cell->face_indices())
          if (cell->face(f)->at_boundary() && cell->face(f)->boundary_id() == 1)
            {
              tip_area_ += cell->face(f)->measure();
              y_moment += cell->face(f)->measure() * cell->face(f)->center()[1];
            }
      if (!(tip_area_ > 0))
        throw InputError("the stiffness solver measures the tip opening on the reed's tip edge, the outline's edge at "
                         "its largest x (" + format_number(L_) + " m); this outline ends in a point there: give it a "
                         "straight tip edge (a fillet radius below half the tip's width)");
      tip_y_ = y_moment / tip_area_;
    }

    void ReedElasticity::make_outline_grid()
    {
      const auto &s = p_.settings;
      // Triangles three times the structured grid's cell: split in three,
      // quadrilaterals of about 1.5 cells; the reference rectangle drawn so is
      // within 0.12 % of the converged k (docs/geometry.md), the structured
      // grid 0.21 %.
      const double          h = 3 * std::min(L_ / s.cells_along_length, W_ / s.cells_across_width);
      mesher::PlanarInput   in;
      for (const auto &p : outline_)
        in.points.push_back({p[0], p[1]});
      for (std::uint32_t i = 0; i < in.points.size(); ++i)
        in.segments.push_back({i, static_cast<std::uint32_t>((i + 1) % in.points.size())});
      in.size          = [h](const mesher::Point2 &) { return h; };
      in.min_angle_deg = 28;
      const auto tri   = mesher::mesh_planar(in);

      std::vector<Point<2>> vertices;
      for (const auto &p : tri.points)
        vertices.emplace_back(p[0], p[1]);
      std::map<std::pair<std::uint32_t, std::uint32_t>, unsigned int> midpoint;
      const auto mid = [&](std::uint32_t a, std::uint32_t b) {
        const auto key = std::minmax(a, b);
        auto       it  = midpoint.find(key);
        if (it == midpoint.end())
          {
            it = midpoint.emplace(key, vertices.size()).first;
            vertices.push_back(0.5 * (vertices[a] + vertices[b]));
          }
        return it->second;
      };
      std::vector<CellData<2>> cells;
      for (const auto &t : tri.triangles)
        {
          const unsigned int c = vertices.size();
          vertices.push_back((vertices[t[0]] + vertices[t[1]] + vertices[t[2]]) / 3.0);
          for (int k = 0; k < 3; ++k)
            {
              const std::uint32_t corner = t[k], next = t[(k + 1) % 3], prev = t[(k + 2) % 3];
              CellData<2>         cell;
              // counter-clockwise corner, mid(next), centre, mid(prev) in deal.II's order 0, 1, 3, 2
              cell.vertices = {corner, mid(corner, next), mid(corner, prev), c};
              cells.push_back(cell);
            }
        }
      GridTools::consistently_order_cells(cells);
      Triangulation<2> plane;
      plane.create_triangulation(vertices, cells, SubCellData());
      GridGenerator::extrude_triangulation(plane, s.cells_through_thickness + 1, t_, triangulation_);
      const double tol = 1e-9 * L_;
      for (const auto &cell : triangulation_.active_cell_iterators())
        for (const auto f : cell->face_indices())
          if (cell->face(f)->at_boundary())
            {
              const auto c = cell->face(f)->center();
              types::boundary_id id = 2;
              if (std::abs(c[2]) <= tol)
                id = 4;
              else if (std::abs(c[2] - t_) <= tol)
                id = 5;
              else if (std::abs(c[0]) <= tol)
                id = 0;
              else if (std::abs(cell->face(f)->vertex(0)[0] - L_) <= tol && std::abs(cell->face(f)->vertex(1)[0] - L_) <= tol &&
                       std::abs(cell->face(f)->vertex(2)[0] - L_) <= tol)
                id = 1;
              cell->face(f)->set_boundary_id(id);
            }
    }

    void ReedElasticity::setup_system()
    {
      dof_handler_.distribute_dofs(fe_);
      constraints_.clear();
      VectorTools::interpolate_boundary_values(dof_handler_, 0, Functions::ZeroFunction<dim>(dim),
                                               constraints_);
      constraints_.close();
      DynamicSparsityPattern dsp(dof_handler_.n_dofs());
      DoFTools::make_sparsity_pattern(dof_handler_, dsp, constraints_, false);
      sparsity_.copy_from(dsp);
      stiffness_matrix_.reinit(sparsity_);
      mass_matrix_.reinit(sparsity_);
      load_.reinit(dof_handler_.n_dofs());
      solution_.reinit(dof_handler_.n_dofs());
      result_.n_dofs  = dof_handler_.n_dofs();
      result_.n_cells = triangulation_.n_active_cells();
    }

    void ReedElasticity::assemble_system()
    {
      const double E = p_.material.youngs_modulus_Pa, nu = p_.material.poisson_ratio;
      const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
      const double mu     = E / (2 * (1 + nu));
      const double rho    = p_.material.density_kg_per_m3;

      const QGauss<dim> quadrature(fe_.degree + 1);
      FEValues<dim>     fe_values(fe_, quadrature,
                              update_values | update_gradients | update_JxW_values);
      const unsigned int                   n = fe_.n_dofs_per_cell();
      FullMatrix<double>                   cell_K(n, n), cell_M(n, n);
      std::vector<types::global_dof_index> dofs(n);
      const FEValuesExtractors::Vector     u(0);
      std::vector<SymmetricTensor<2, dim>> eps(n);
      std::vector<double>                  div(n);
      std::vector<Tensor<1, dim>>          val(n);

      for (const auto &cell : dof_handler_.active_cell_iterators())
        {
          fe_values.reinit(cell);
          cell_K = 0;
          cell_M = 0;
          for (unsigned int q = 0; q < quadrature.size(); ++q)
            {
              for (unsigned int i = 0; i < n; ++i)
                {
                  eps[i] = fe_values[u].symmetric_gradient(i, q);
                  div[i] = trace(eps[i]);
                  val[i] = fe_values[u].value(i, q);
                }
              const double JxW = fe_values.JxW(q);
              for (unsigned int i = 0; i < n; ++i)
                for (unsigned int j = 0; j <= i; ++j)
                  {
                    // (lambda div u, div v) + (2 mu eps(u), eps(v))
                    cell_K(i, j) += (lambda * div[i] * div[j] + 2 * mu * (eps[i] * eps[j])) * JxW;
                    // (rho u, v)
                    cell_M(i, j) += rho * (val[i] * val[j]) * JxW;
                  }
            }
          for (unsigned int i = 0; i < n; ++i)
            for (unsigned int j = i + 1; j < n; ++j)
              {
                cell_K(i, j) = cell_K(j, i);
                cell_M(i, j) = cell_M(j, i);
              }
          cell->get_dof_indices(dofs);
          constraints_.distribute_local_to_global(cell_K, dofs, stiffness_matrix_);
          constraints_.distribute_local_to_global(cell_M, dofs, mass_matrix_);
        }
      // Clamped dofs carry no inertia: a zero mass diagonal sends their
      // eigenvalues to infinity, away from the modes sought.
      for (types::global_dof_index i = 0; i < dof_handler_.n_dofs(); ++i)
        if (constraints_.is_constrained(i))
          mass_matrix_.set(i, i, 0.0);
      result_.plate_mass_kg = rho * std::abs(geometry::signed_area(outline_)) * t_;
    }

    void ReedElasticity::assemble_load()
    {
      const auto   load   = p_.settings.load;
      const unsigned int face_id = load == Load::tip_line ? 1 : 4;
      // Traction for a unit level: pressure 1 Pa pushing the underside up
      // (+z), or a tip force of 1 N spread over the tip face.
      const double traction = load == Load::tip_line ? 1.0 / tip_area_ : 1.0;
      // Each port's bounding box, to find the faces its mouth reaches.
      std::vector<std::array<double, 4>> boxes;
      for (const auto &port : ports_)
        {
          std::array<double, 4> b = {1e300, -1e300, 1e300, -1e300};
          for (const auto &q : port.polygon())
            b = {std::min(b[0], q[0]), std::max(b[1], q[0]), std::min(b[2], q[1]), std::max(b[3], q[1])};
          const double grow = 0.02 * std::max(b[1] - b[0], b[3] - b[2]); // a circle's polygon lies inside its circle's box
          boxes.push_back({b[0] - grow, b[1] + grow, b[2] - grow, b[3] + grow});
        }

      const QGauss<dim - 1>   regular(fe_.degree + 1);
      const QIterated<dim - 1> fine(QGauss<1>(2), 48); // faces cut by the port's rim
      FEFaceValues<dim> regular_values(fe_, regular,
                                       update_values | update_quadrature_points | update_JxW_values);
      FEFaceValues<dim> fine_values(fe_, fine,
                                    update_values | update_quadrature_points | update_JxW_values);
      const FEValuesExtractors::Scalar     uz(2);
      const unsigned int                   n = fe_.n_dofs_per_cell();
      Vector<double>                       cell_rhs(n);
      std::vector<types::global_dof_index> dofs(n);
      double                               force = 0;

      const auto inside = [&](const Point<dim> &x) {
        if (load != Load::port_pressure)
          return true;
        for (const auto &port : ports_)
          if (port.contains({x[0], x[1]}))
            return true;
        return false;
      };

      for (const auto &cell : dof_handler_.active_cell_iterators())
        for (const auto f : cell->face_indices())
          {
            const auto face = cell->face(f);
            if (!face->at_boundary() || face->boundary_id() != face_id)
              continue;
            FEFaceValues<dim> *values = &regular_values;
            if (load == Load::port_pressure)
              {
                unsigned int n_in = 0;
                double       x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
                for (const auto v : face->vertex_indices())
                  {
                    n_in += inside(face->vertex(v)) ? 1 : 0;
                    x0 = std::min(x0, face->vertex(v)[0]), x1 = std::max(x1, face->vertex(v)[0]);
                    y0 = std::min(y0, face->vertex(v)[1]), y1 = std::max(y1, face->vertex(v)[1]);
                  }
                bool touches = false;
                for (const auto &b : boxes)
                  touches = touches || (x0 <= b[1] && x1 >= b[0] && y0 <= b[3] && y1 >= b[2]);
                if (!touches)
                  continue;
                if (n_in < face->n_vertices())
                  values = &fine_values;
              }
            values->reinit(cell, f);
            cell_rhs = 0;
            for (unsigned int q = 0; q < values->n_quadrature_points; ++q)
              {
                if (!inside(values->quadrature_point(q)))
                  continue;
                const double w = traction * values->JxW(q);
                force += w;
                for (unsigned int i = 0; i < n; ++i)
                  cell_rhs(i) += (*values)[uz].value(i, q) * w;
              }
            cell->get_dof_indices(dofs);
            constraints_.distribute_local_to_global(cell_rhs, dofs, load_);
          }
      result_.force_per_level = force;
    }

    void ReedElasticity::solve()
    {
      stiffness_inverse_.initialize(stiffness_matrix_);
      stiffness_inverse_.vmult(solution_, load_);
      constraints_.distribute(solution_);
    }

    double ReedElasticity::tip_face_integral(const Vector<double> &u, bool antisymmetric, unsigned component) const
    {
      const QGauss<dim - 1>            quadrature(fe_.degree + 1);
      FEFaceValues<dim>                values(fe_, quadrature,
                                   update_values | update_quadrature_points | update_JxW_values);
      const FEValuesExtractors::Scalar u_c(component);
      std::vector<double>              uz_q(quadrature.size());
      double                           integral = 0;
      for (const auto &cell : dof_handler_.active_cell_iterators())
        for (const auto f : cell->face_indices())
          if (cell->face(f)->at_boundary() && cell->face(f)->boundary_id() == 1)
            {
              values.reinit(cell, f);
              values[u_c].get_function_values(u, uz_q);
              for (unsigned int q = 0; q < quadrature.size(); ++q)
                {
                  const double sign = antisymmetric ? (values.quadrature_point(q)[1] >= tip_y_ ? 1 : -1) : 1;
                  integral += sign * uz_q[q] * values.JxW(q);
                }
            }
      return integral / tip_area_;
    }

    double ReedElasticity::value_z(const Vector<double> &u, const Point<dim> &p) const
    {
      Vector<double> v(dim);
      VectorTools::point_value(dof_handler_, u, p, v);
      return v[2];
    }

    // The underside's axial stress integrated across the width, S(x) =
    // int sigma_xx dy = 6 M(x) / t^2 for a plate in bending, at six stations
    // from four thicknesses off the clamp (its clamped edge's stress is
    // singular) to fit_to_m; a quadratic through them extrapolated to x = 0,
    // over the clamp line's width: the root's mean bending stress, exact for
    // a moment linear or quadratic in x whatever the width does. The first
    // station's peak principal stress over its mean sigma_xx is the corners'
    // concentration there.
    RootStress ReedElasticity::root_stress(const Vector<double> &u, double fit_to_m, bool green) const
    {
      const double E = p_.material.youngs_modulus_Pa, nu = p_.material.poisson_ratio;
      const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
      const auto   stress_at = [&](double x, double y) {
        std::vector<Tensor<1, dim>> grad(dim);
        VectorTools::point_gradient(dof_handler_, u, Point<dim>(x, y, 0.0), grad);
        SymmetricTensor<2, dim> strain;
        for (unsigned i = 0; i < dim; ++i)
          for (unsigned j = i; j < dim; ++j)
            {
              strain[i][j] = 0.5 * (grad[i][j] + grad[j][i]);
              if (green) // Green-Lagrange: blind to the section's rotation
                for (unsigned k = 0; k < dim; ++k)
                  strain[i][j] += 0.5 * grad[k][i] * grad[k][j];
            }
        return SymmetricTensor<2, dim>(lambda * trace(strain) * unit_symmetric_tensor<dim>() + 2 * mu * strain);
      };
      const double x_from = 4 * t_;
      if (!(fit_to_m > 1.5 * x_from))
        throw std::runtime_error("the root stress's fit runs from four thicknesses off the clamp (" +
                                 format_number(x_from) + " m) to where the load starts (" + format_number(fit_to_m) +
                                 " m): too short for this reed");
      const int n_stations = 6, n_across = 21;
      double    A[3][3] = {}, b[3] = {}, S0 = 0, peak0 = 0, width0 = 0;
      for (int k = 0; k < n_stations; ++k)
        {
          const double x = x_from + (fit_to_m - x_from) * k / (n_stations - 1.0);
          double       S = 0, width = 0, peak = -1e300;
          for (auto [y0, y1] : geometry::chord_intervals(outline_, x))
            {
              const double inset = 1e-7 * (y1 - y0);
              y0 += inset, y1 -= inset;
              for (int j = 0; j < n_across; ++j)
                {
                  const double y     = y0 + (y1 - y0) * j / (n_across - 1.0);
                  const auto   sigma = stress_at(x, y);
                  const double w     = (j == 0 || j == n_across - 1) ? 0.5 : 1.0;
                  S += w * (y1 - y0) / (n_across - 1.0) * sigma[0][0];
                  peak = std::max(peak, eigenvalues(sigma)[0]);
                }
              width += y1 - y0;
            }
          if (k == 0)
            S0 = S, peak0 = peak, width0 = width;
          const double phi[3] = {1, x, x * x};
          for (int i = 0; i < 3; ++i)
            {
              b[i] += phi[i] * S;
              for (int j = 0; j < 3; ++j)
                A[i][j] += phi[i] * phi[j];
            }
        }
      const auto det = [](const double m[3][3]) {
        return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
      };
      double A0[3][3];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          A0[i][j] = j == 0 ? b[i] : A[i][j];
      const auto clamp = p_.geometry.clamp_line_y();
      RootStress r;
      r.mean_Pa       = det(A0) / det(A) / (clamp[1] - clamp[0]);
      r.concentration = peak0 / (S0 / width0);
      return r;
    }

    void ReedElasticity::compute_modes()
    {
      const unsigned int n_modes = p_.settings.n_modes;
      SolverControl      control(dof_handler_.n_dofs(), 1e-8);
      const unsigned int n_arnoldi = std::max(2 * n_modes + 2, 20u);
      ArpackSolver       eigensolver(control, ArpackSolver::AdditionalData(
                                         n_arnoldi, ArpackSolver::largest_magnitude, true));
      eigensolver.set_shift(0.0);
      std::vector<std::complex<double>> eigenvalues(n_modes);
      mode_shapes_.assign(n_modes, Vector<double>(dof_handler_.n_dofs()));
      eigensolver.solve(stiffness_matrix_, mass_matrix_, stiffness_inverse_, eigenvalues, mode_shapes_,
                        n_modes);
      // ARPACK returns them in increasing order for a symmetric problem; sort to be sure.
      std::vector<unsigned int> order(n_modes);
      for (unsigned int i = 0; i < n_modes; ++i)
        order[i] = i;
      std::sort(order.begin(), order.end(),
                [&](unsigned a, unsigned b) { return eigenvalues[a].real() < eigenvalues[b].real(); });
      std::vector<Vector<double>> sorted;
      Vector<double>              Mphi(dof_handler_.n_dofs());
      for (unsigned int k : order)
        {
          Vector<double> phi = mode_shapes_[k];
          constraints_.distribute(phi);
          const double symmetric     = tip_face_integral(phi, false);
          const double antisymmetric = tip_face_integral(phi, true);
          Mode         mode;
          mode.frequency_Hz  = std::sqrt(eigenvalues[k].real()) / (2 * std::numbers::pi);
          mode.kind          = std::abs(symmetric) >= std::abs(antisymmetric) ? "bending" : "torsion";
          mode.modal_mass_kg = 0;
          if (mode.kind == "bending")
            {
              phi /= symmetric; // unit mean tip deflection
              mass_matrix_.vmult(Mphi, phi);
              mode.modal_mass_kg = phi * Mphi;
            }
          result_.modes.push_back(mode);
          sorted.push_back(phi);
        }
      mode_shapes_ = std::move(sorted);
    }

    void ReedElasticity::sample_shape()
    {
      const std::size_t n = std::max<std::size_t>(options_.n_shape_points, 2);
      const int         n_across = 11;
      const double      tip      = tip_face_integral(solution_, false);
      for (std::size_t k = 0; k < n; ++k)
        {
          const double s = L_ * static_cast<double>(k) / static_cast<double>(n - 1);
          // The reed's width at s (the rectangle's [-W/2, W/2]): the chords
          // of the line x = s, taken a hair inside at the clamp and the tip.
          const auto chords = geometry::chord_intervals(outline_, std::clamp(s, 1e-9 * L_, (1 - 1e-9) * L_));
          double     sum = 0, width = 0, widest = -1, centre = tip_y_;
          for (auto [y0, y1] : chords)
            {
              // A hair inside the edges, so that rounding never puts a sample outside the mesh.
              const double inset = 1e-7 * (y1 - y0);
              y0 += inset, y1 -= inset;
              // trapezoidal rule, the edges included
              for (int j = 0; j < n_across; ++j)
                {
                  const double y = y0 + (y1 - y0) * j / (n_across - 1.0);
                  const double w = (j == 0 || j == n_across - 1) ? 0.5 : 1.0;
                  sum += w * (y1 - y0) / (n_across - 1.0) * value_z(solution_, Point<dim>(s, y, 0.0));
                }
              width += y1 - y0;
              if (y1 - y0 > widest)
                widest = y1 - y0, centre = 0.5 * (y0 + y1);
            }
          result_.shape_s_m.push_back(s);
          result_.shape_phi.push_back(sum / width / tip);
          result_.shape_phi_centerline.push_back(value_z(solution_, Point<dim>(s, centre, 0.0)) / tip);
        }
    }

    // Geometrically nonlinear elasticity (St Venant-Kirchhoff, total
    // Lagrangian): F = I + grad u, E = (F^T F - I) / 2, S = lambda tr(E) I +
    // 2 mu E; the residual int P : grad v - level (t_N, v) with P = F S, and
    // its tangent int C[sym(F^T grad du)] : sym(F^T grad v) + S : (grad du^T
    // grad v). The load is the linear solve's, dead (it keeps its direction).
    // Returns the residual's norm.
    double ReedElasticity::assemble_large_deflection(const Vector<double> &u, double level,
                                                     SparseMatrix<double> &tangent, Vector<double> &residual) const
    {
      const double E = p_.material.youngs_modulus_Pa, nu = p_.material.poisson_ratio;
      const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
      const double mu     = E / (2 * (1 + nu));
      const QGauss<dim> quadrature(fe_.degree + 1);
      FEValues<dim>     fe_values(fe_, quadrature, update_gradients | update_JxW_values);
      const unsigned int                   n = fe_.n_dofs_per_cell();
      FullMatrix<double>                   cell_K(n, n);
      Vector<double>                       cell_r(n);
      std::vector<types::global_dof_index> dofs(n);
      const FEValuesExtractors::Vector     uu(0);
      std::vector<Tensor<2, dim>>          grad_u(quadrature.size());
      std::vector<Tensor<2, dim>>          grad(n);
      std::vector<SymmetricTensor<2, dim>> dE(n);
      std::vector<Tensor<2, dim>>          grad_S(n);
      std::vector<double>                  tr_dE(n);
      tangent  = 0;
      residual = 0;
      for (const auto &cell : dof_handler_.active_cell_iterators())
        {
          fe_values.reinit(cell);
          fe_values[uu].get_function_gradients(u, grad_u);
          cell_K = 0;
          cell_r = 0;
          for (unsigned int q = 0; q < quadrature.size(); ++q)
            {
              const Tensor<2, dim>          F  = Tensor<2, dim>(unit_symmetric_tensor<dim>()) + grad_u[q];
              const SymmetricTensor<2, dim> Eg = 0.5 * (symmetrize(transpose(F) * F) - unit_symmetric_tensor<dim>());
              const SymmetricTensor<2, dim> S  = lambda * trace(Eg) * unit_symmetric_tensor<dim>() + 2 * mu * Eg;
              const Tensor<2, dim>          P  = F * Tensor<2, dim>(S);
              const double                  JxW = fe_values.JxW(q);
              for (unsigned int i = 0; i < n; ++i)
                {
                  grad[i]   = fe_values[uu].gradient(i, q);
                  dE[i]     = symmetrize(transpose(F) * grad[i]);
                  grad_S[i] = grad[i] * Tensor<2, dim>(S);
                  tr_dE[i]  = trace(dE[i]);
                }
              for (unsigned int i = 0; i < n; ++i)
                {
                  cell_r(i) += scalar_product(P, grad[i]) * JxW;
                  for (unsigned int j = 0; j <= i; ++j)
                    cell_K(i, j) += (lambda * tr_dE[i] * tr_dE[j] + 2 * mu * (dE[i] * dE[j]) +
                                     scalar_product(grad_S[j], grad[i])) *
                                    JxW;
                }
            }
          for (unsigned int i = 0; i < n; ++i)
            for (unsigned int j = i + 1; j < n; ++j)
              cell_K(i, j) = cell_K(j, i);
          cell->get_dof_indices(dofs);
          constraints_.distribute_local_to_global(cell_K, cell_r, dofs, tangent, residual);
        }
      residual.add(-level, load_);
      return residual.l2_norm();
    }

    /// Newton's method from `u` to equilibrium under `level` x the unit load
    /// (residual down to 1e-8 of the load's); returns its iterations.
    unsigned ReedElasticity::newton(Vector<double> &u, double level, SparseMatrix<double> &tangent) const
    {
      Vector<double> residual(u.size()), du(u.size());
      const double   scale = std::abs(level) * load_.l2_norm();
      for (unsigned it = 0; it < 30; ++it)
        {
          const double norm = assemble_large_deflection(u, level, tangent, residual);
          if (!std::isfinite(norm))
            break;
          if (norm <= 1e-8 * scale) // the internal forces' rounding: about 4e-9 of the load on a thin strip
            return it;
          SparseDirectUMFPACK inverse;
          inverse.initialize(tangent);
          inverse.vmult(du, residual);
          constraints_.distribute(du);
          u -= du;
        }
      throw std::runtime_error("the reed's large-deflection check (geometrically nonlinear solve) did not converge "
                               "at load level " + format_number(level));
    }

    // Load steps up to the linear solve's load for the opening, then secant
    // steps on the level until the mean tip deflection is the opening to 1e-6.
    void ReedElasticity::check_large_deflection(double opening_m, double unloaded_to_m)
    {
      const double tip_per_level = tip_face_integral(solution_, false);
      SparseMatrix<double> tangent(sparsity_);
      LargeDeflectionCheck c;
      // Each step starts from the last two solutions extrapolated to its level
      // (the first from the linear solution): Newton then needs 2-4 iterations.
      Vector<double> u(dof_handler_.n_dofs()), u_previous(dof_handler_.n_dofs()), u_start(dof_handler_.n_dofs());
      double         level_reached = 0, level_previous = 0;
      const auto     step_to = [&](double level) {
        if (level_reached == 0)
          u_start.equ(level, solution_);
        else
          {
            u_start = u;
            u_start.add((level - level_reached) / (level_reached - level_previous), u);
            u_start.add(-(level - level_reached) / (level_reached - level_previous), u_previous);
          }
        u_previous = u;
        u          = u_start;
        c.newton_iterations += newton(u, level, tangent);
        level_previous = level_reached, level_reached = level;
        ++c.load_steps;
      };
      double         level = opening_m / tip_per_level;
      const unsigned steps = std::max(2u, static_cast<unsigned>(std::ceil(5 * opening_m / L_)));
      for (unsigned k = 1; k <= steps; ++k)
        step_to(level * k / steps);
      // the secant through the last two (level, opening) pairs
      double previous = tip_face_integral(u_previous, false);
      for (unsigned k = 0; k < 20; ++k)
        {
          const double reached = tip_face_integral(u, false);
          if (std::abs(reached / opening_m - 1) <= 1e-6)
            break;
          const double slope = (reached - previous) / (level_reached - level_previous);
          previous = reached;
          step_to(level_reached + (opening_m - reached) / slope);
        }
      if (!(std::abs(tip_face_integral(u, false) / opening_m - 1) <= 1e-6))
        throw std::runtime_error("the reed's large-deflection check did not reach the opening " +
                                 format_number(opening_m) + " m (it reached " +
                                 format_number(tip_face_integral(u, false)) + " m)");
      level = level_reached;
      c.opening_m                = tip_face_integral(u, false);
      c.force_N                  = level * result_.force_per_level;
      c.secant_stiffness_N_per_m = c.force_N / c.opening_m;
      c.stiffness_ratio          = c.secant_stiffness_N_per_m / result_.k_N_per_m;
      c.root_stress_Pa           = root_stress(u, unloaded_to_m, true).mean_Pa;
      c.root_stress_ratio        = c.root_stress_Pa / (result_.root_stress_per_opening_Pa_per_m * c.opening_m);
      // St Venant-Kirchhoff holds for small strains only (a steel yields below 1 %)
      const double strain = c.root_stress_Pa / p_.material.youngs_modulus_Pa;
      if (!(std::abs(strain) <= 0.02))
        throw std::runtime_error("the reed's large-deflection check reached the opening with a root strain of " +
                                 format_number(100 * strain) + " %: beyond small strains, no elastic answer");
      c.tip_shortening_m         = -tip_face_integral(u, false, 0); // u_x < 0: towards the clamp
      result_.large_deflection = c;
    }

    void ReedElasticity::output_results() const
    {
      if (options_.vtu_file.empty())
        return;
      DataOut<dim> data_out;
      data_out.attach_dof_handler(dof_handler_);
      const std::vector<DataComponentInterpretation::DataComponentInterpretation> vector(
        dim, DataComponentInterpretation::component_is_part_of_vector);
      Vector<double> u = solution_;
      u *= p_.settings.load_levels.front();
      data_out.add_data_vector(u, std::vector<std::string>(dim, "displacement_m"),
                               DataOut<dim>::type_dof_data, vector);
      for (std::size_t k = 0; k < mode_shapes_.size(); ++k)
        data_out.add_data_vector(mode_shapes_[k],
                                 std::vector<std::string>(dim, "mode_" + std::to_string(k + 1)),
                                 DataOut<dim>::type_dof_data, vector);
      data_out.build_patches(fe_.degree);
      std::ostringstream out;
      data_out.write_vtu(out);
      write_file_atomic(options_.vtu_file, out.str());
    }

    StiffnessResult ReedElasticity::run()
    {
      const auto start = std::chrono::steady_clock::now();
      auto       lap   = start;
      const auto phase = [&](const char *name) {
        const auto now = std::chrono::steady_clock::now();
        result_.phase_times.emplace_back(name, std::chrono::duration<double>(now - lap).count());
        lap = now;
      };
      make_grid();
      setup_system();
      phase("setup");
      assemble_system();
      assemble_load();
      phase("assemble");
      solve();
      phase("factorise and solve");

      const double F         = result_.force_per_level;
      const double tip       = tip_face_integral(solution_, false);
      const double tip_centre = value_z(solution_, Point<dim>(L_, tip_y_, t_ / 2));
      result_.k_N_per_m        = F / tip;
      result_.k_center_N_per_m = F / tip_centre;
      const auto   clamp       = p_.geometry.clamp_line_y();
      const double I           = analytic::second_moment(clamp[1] - clamp[0], t_); // at the clamp
      for (double level : p_.settings.load_levels)
        {
          LoadLevel l;
          l.level                   = level;
          l.force_N                 = F * level;
          l.tip_deflection_m        = tip * level;
          l.tip_center_deflection_m = tip_centre * level;
          l.deflection_ratio        = l.tip_deflection_m / L_;
          // M at the clamp from the load's resultant: F * (distance of its centroid)
          const double arm = p_.settings.load == Load::port_pressure ? p_.geometry.port_center_x_m :
                             p_.settings.load == Load::tip_line      ? L_ :
                                                                       L_ / 2;
          l.root_stress_beam_Pa = l.force_N * arm * (t_ / 2) / I;
          l.small_deflection    = l.deflection_ratio <= p_.settings.max_linear_deflection_ratio;
          result_.levels.push_back(l);
        }
      // The load's nearest edge to the clamp: up to there the moment is linear
      // in x (quadratic under a uniform pressure).
      double unloaded_to = 0.6 * L_;
      if (p_.settings.load == Load::port_pressure)
        for (const auto &port : ports_)
          for (const auto &q : port.polygon())
            unloaded_to = std::min(unloaded_to, q[0]);
      const auto root = root_stress(solution_, unloaded_to);
      result_.root_stress_per_opening_Pa_per_m      = root.mean_Pa / tip;
      result_.root_stress_concentration              = root.concentration;
      // Beam theory (a uniform cantilever, E): sigma_root / tip deflection.
      const double E = p_.material.youngs_modulus_Pa, a = p_.geometry.port_center_x_m;
      result_.root_stress_beam_per_opening_Pa_per_m = p_.settings.load == Load::port_pressure ? 3 * E * t_ / (a * (3 * L_ - a)) :
                                                      p_.settings.load == Load::tip_line      ? 1.5 * E * t_ / (L_ * L_) :
                                                                                                2 * E * t_ / (L_ * L_);
      if (options_.large_deflection_opening_m > 0)
        {
          try
            {
              check_large_deflection(options_.large_deflection_opening_m, unloaded_to);
            }
          catch (const std::runtime_error &e) // the linear results stand; the check says why it has none
            {
              result_.large_deflection = LargeDeflectionCheck{};
              result_.large_deflection->opening_m = options_.large_deflection_opening_m;
              result_.large_deflection->failure   = e.what();
            }
          phase("large-deflection check");
        }
      if (options_.compute_modes)
        compute_modes();
      phase("modes");
      for (std::size_t k = 0, bending = 0; k < result_.modes.size(); ++k)
        if (result_.modes[k].kind == "bending" && ++bending == 2)
          result_.second_mode_root_stress_per_opening_Pa_per_m = root_stress(mode_shapes_[k], 0.3 * L_).mean_Pa;
      sample_shape();
      phase("shape");
      output_results();
      phase("output");
      result_.wall_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      return result_;
    }
  } // namespace

  StiffnessResult solve_reed(const StiffnessParameters &parameters, const SolveOptions &options)
  {
    ReedElasticity solver(parameters, options);
    return solver.run();
  }
} // namespace rectify::stiffness
