// Taylor-Hood P2-P1 Stokes on tetrahedra with deal.II 9.4 and PETSc.
// Every process builds the same serial triangulation from the mesh, METIS
// partitions it, and a fully distributed triangulation keeps each process's
// part. One monolithic PETSc matrix serves both solvers: MUMPS (direct), or
// FGMRES with PETSc's field split: upper block-triangular Schur
// factorisation, one hypre BoomerAMG V-cycle on the velocity block, the
// pressure mass matrix / mu (Jacobi) on the Schur complement.
#include "stokes_solver/stokes.h"

#include <deal.II/base/function.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/utilities.h>
#include <deal.II/distributed/fully_distributed_tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_renumbering.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_fe.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/tria.h>
#include <deal.II/grid/tria_description.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/petsc_solver.h>
#include <deal.II/lac/petsc_sparse_matrix.h>
#include <deal.II/lac/petsc_vector.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/vector_tools.h>


#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <stdexcept>

#include "mesher/to_dealii.h"
#include "stokes_solver/block_solver.h"

namespace rectify::stokes
{
  using namespace dealii;

  struct MpiSession::Impl
  {
    int                               argc = 1;
    char                              name[8] = "rectify";
    char                             *argv_storage[2] = {name, nullptr};
    char                            **argv = argv_storage;
    Utilities::MPI::MPI_InitFinalize  mpi{argc, argv, 1};
  };
  MpiSession::MpiSession() : impl_(new Impl) {}
  MpiSession::~MpiSession() { delete impl_; }
  unsigned MpiSession::rank() const { return Utilities::MPI::this_mpi_process(MPI_COMM_WORLD); }
  unsigned MpiSession::size() const { return Utilities::MPI::n_mpi_processes(MPI_COMM_WORLD); }
  std::vector<double> MpiSession::broadcast(std::vector<double> values) const
  {
    return Utilities::MPI::broadcast(MPI_COMM_WORLD, values, 0);
  }

  namespace
  {
    using Clock = std::chrono::steady_clock;

    double seconds_since(Clock::time_point t)
    {
      return std::chrono::duration<double>(Clock::now() - t).count();
    }

    /// The height of the thin gap over each of its floor points: the gap's
    /// layered cells (region gap) stack in vertical columns over the floor's
    /// points, so the vertical extent of a column is the gap's height there.
    class GapHeights
    {
    public:
      explicit GapHeights(const mesher::TetMesh &m)
      {
        for (std::size_t c = 0; c < m.cells.size(); ++c)
          if (m.region[c] == mesher::gap)
            for (auto v : m.cells[c])
              {
                const auto &p = m.vertices[v];
                auto [it, added] = column_.try_emplace({p[0], p[1]}, p[2], p[2]);
                it->second.first  = std::min(it->second.first, p[2]);
                it->second.second = std::max(it->second.second, p[2]);
              }
      }
      /// The mean of the gap's height over a gap cell's vertices.
      template <class Cell>
      double of(const Cell &cell) const
      {
        double h = 0;
        for (const auto v : cell->vertex_indices())
          {
            const auto &[lo, hi] = column_.at({cell->vertex(v)[0], cell->vertex(v)[1]});
            h += (hi - lo) / cell->n_vertices();
          }
        return h;
      }

    private:
      std::map<std::pair<double, double>, std::pair<double, double>> column_; // (x, y) -> (z min, z max)
    };

    /// The inlet face's centre, inward normal and circumradius, from its faces.
    struct InletFrame
    {
      Point<3>     centre;
      Tensor<1, 3> inward;
      double       radius = 0;
    };

    InletFrame inlet_frame(const mesher::TetMesh &m)
    {
      InletFrame   f;
      double       area = 0;
      Tensor<1, 3> normal;
      for (const auto &b : m.boundary)
        if (b.id == mesher::inlet)
          {
            const auto  &p0 = m.vertices[b.vertices[0]], &p1 = m.vertices[b.vertices[1]],
                       &p2 = m.vertices[b.vertices[2]];
            const Point<3> a(p0[0], p0[1], p0[2]), b1(p1[0], p1[1], p1[2]), c(p2[0], p2[1], p2[2]);
            const Tensor<1, 3> n = 0.5 * cross_product_3d(b1 - a, c - a); // outward, |n| = area
            area += n.norm();
            normal += n;
            f.centre += n.norm() * (a + b1 + c) / 3.0;
          }
      if (area == 0)
        throw InputError("the mesh has no inlet (no boundary face with id 1)");
      f.centre /= area;
      f.inward = -normal / normal.norm();
      for (const auto &b : m.boundary)
        if (b.id == mesher::inlet)
          for (auto v : b.vertices)
            {
              const Point<3> p(m.vertices[v][0], m.vertices[v][1], m.vertices[v][2]);
              f.radius = std::max(f.radius, p.distance(f.centre));
            }
      return f;
    }

    /// Parabolic inflow 1 - rho^2 / R^2 along the inward normal (velocity components only).
    class InletProfile : public Function<3>
    {
    public:
      InletProfile(const InletFrame &frame, double amplitude) : Function<3>(4), f_(frame), a_(amplitude) {}
      double value(const Point<3> &p, unsigned c) const override
      {
        if (c > 2)
          return 0;
        Tensor<1, 3> d = p - f_.centre;
        d -= (d * f_.inward) * f_.inward;
        const double s = std::max(0.0, 1.0 - d.norm_square() / (f_.radius * f_.radius));
        return a_ * s * f_.inward[c];
      }

    private:
      InletFrame f_;
      double     a_;
    };
  } // namespace

  StokesResult solve_stokes(const mesher::TetMesh &mesh, const FlowParameters &parameters,
                            const std::filesystem::path &vtu_dir, bool verbose)
  {
    const auto   start = Clock::now();
    const auto  &s     = parameters.settings;
    const double mu    = parameters.fluid.viscosity_Pa_s;
    const double Q     = s.flow_rate_m3_per_s;
    if (!(mu > 0) || !std::isfinite(mu))
      throw InputError("[fluid] viscosity_Pa_s = " + format_number(mu) + ": must be positive");
    if (!(Q > 0) || !std::isfinite(Q))
      throw InputError("[flow] flow_rate_m3_per_s = " + format_number(Q) + ": must be positive");
    bool has_outlet = false;
    for (const auto &b : mesh.boundary)
      {
        if (b.id < mesher::inlet || b.id > mesher::reed)
          throw InputError("the mesh has a boundary face with id " + std::to_string(b.id) +
                           " (expected 1 inlet, 2 outlet, 3 walls, 4 reed)");
        has_outlet = has_outlet || b.id == mesher::outlet;
      }
    if (!has_outlet)
      throw InputError("the mesh has no outlet (no boundary face with id 2)");
    const InletFrame frame = inlet_frame(mesh);

    const MPI_Comm comm    = MPI_COMM_WORLD;
    const unsigned n_procs = Utilities::MPI::n_mpi_processes(comm);
    const bool     root    = Utilities::MPI::this_mpi_process(comm) == 0;
    auto           stage   = Clock::now();
    const auto     lap     = [&](const char *what) {
      if (verbose && root)
        std::fprintf(stderr, "  %-28s %.2f s\n", what, seconds_since(stage));
      stage = Clock::now();
    };
    StokesResult   r;
    r.n_processes = n_procs;
    r.n_cells     = mesh.cells.size();

    // Mesh: serial on every process, partitioned, each keeping its part.
    Triangulation<3> serial;
    mesher::fill_triangulation(mesh, serial);
    parallel::fullydistributed::Triangulation<3> distributed(comm);
    if (n_procs > 1)
      {
        GridTools::partition_triangulation(n_procs, serial);
        distributed.create_triangulation(
          TriangulationDescription::Utilities::create_description_from_triangulation(serial, comm));
      }
    const Triangulation<3> &tria = n_procs > 1 ? static_cast<const Triangulation<3> &>(distributed) : serial;
    lap("flow: triangulation");

    const FESystem<3>   fe(FE_SimplexP<3>(2), 3, FE_SimplexP<3>(1), 1);
    const MappingFE<3>  mapping(FE_SimplexP<3>(1));
    const QGaussSimplex<3> quadrature(3);
    const QGaussSimplex<2> face_quadrature(3);
    const FEValuesExtractors::Vector velocities(0);
    const FEValuesExtractors::Scalar pressure(3);

    DoFHandler<3> dof(tria);
    dof.distribute_dofs(fe);
    // No component-wise renumbering: in parallel it would make a process's
    // DoFs non-contiguous; the field split takes the velocity and pressure
    // DoFs as index sets instead.
    const IndexSet owned    = dof.locally_owned_dofs();
    IndexSet       relevant;
    DoFTools::extract_locally_relevant_dofs(dof, relevant);
    const IndexSet owned_u = DoFTools::extract_dofs(dof, fe.component_mask(velocities));
    const IndexSet owned_p = DoFTools::extract_dofs(dof, fe.component_mask(pressure));
    r.n_dofs          = dof.n_dofs();
    r.n_pressure_dofs = Utilities::MPI::sum(owned_p.n_elements(), comm);
    r.n_velocity_dofs = r.n_dofs - r.n_pressure_dofs;

    // Boundary values: no slip on walls and reed first, then the inlet
    // profile on what is left (its rim stays at zero), scaled to carry Q.
    std::map<types::global_dof_index, double> wall_values, inlet_values;
    std::map<types::boundary_id, const Function<3> *> wall_functions;
    Functions::ZeroFunction<3> zero(4);
    wall_functions[mesher::walls] = &zero;
    wall_functions[mesher::reed]  = &zero;
    VectorTools::interpolate_boundary_values(mapping, dof, wall_functions, wall_values,
                                             fe.component_mask(velocities));
    const InletProfile unit(frame, 1.0);
    VectorTools::interpolate_boundary_values(mapping, dof, mesher::inlet, unit, inlet_values,
                                             fe.component_mask(velocities));
    for (const auto &[i, v] : wall_values)
      inlet_values.erase(i);

    FEFaceValues<3> face_values(mapping, fe, face_quadrature,
                                update_values | update_gradients | update_normal_vectors |
                                  update_JxW_values);
    std::vector<types::global_dof_index> dofs(fe.n_dofs_per_cell());
    double unit_flux = 0;
    for (const auto &cell : dof.active_cell_iterators())
      if (cell->is_locally_owned())
        for (const auto f : cell->face_indices())
          if (cell->face(f)->at_boundary() && cell->face(f)->boundary_id() == mesher::inlet)
            {
              face_values.reinit(cell, f);
              cell->get_dof_indices(dofs);
              for (unsigned q = 0; q < face_values.n_quadrature_points; ++q)
                {
                  Tensor<1, 3> u;
                  for (unsigned i = 0; i < dofs.size(); ++i)
                    if (const auto it = inlet_values.find(dofs[i]); it != inlet_values.end())
                      u += it->second * face_values[velocities].value(i, q);
                  unit_flux -= u * face_values.normal_vector(q) * face_values.JxW(q);
                }
            }
    unit_flux = Utilities::MPI::sum(unit_flux, comm);
    if (!(unit_flux > 0))
      throw std::runtime_error("the inlet profile carries no flow (inlet too coarse?)");
    const double amplitude = Q / unit_flux;

    AffineConstraints<double> constraints(relevant);
    for (const auto &[i, v] : wall_values)
      {
        constraints.add_line(i);
        constraints.set_inhomogeneity(i, 0.0);
      }
    for (const auto &[i, v] : inlet_values)
      {
        constraints.add_line(i);
        constraints.set_inhomogeneity(i, amplitude * v);
      }
    constraints.close();

    DynamicSparsityPattern dsp(relevant);
    // Velocity components couple only with themselves (the Laplacian form)
    // and with the pressure; leaving the zero blocks out of the pattern
    // keeps them out of the AMG hierarchy and the direct solver's factors.
    // Navier-Stokes's linearised convection couples them all.
    Table<2, DoFTools::Coupling> coupling(4, 4);
    for (unsigned i = 0; i < 4; ++i)
      for (unsigned j = 0; j < 4; ++j)
        coupling(i, j) = i == j || i == 3 || j == 3 || s.navier_stokes ? DoFTools::always : DoFTools::none;
    DoFTools::make_sparsity_pattern(dof, coupling, dsp, constraints, false);
    SparsityTools::distribute_sparsity_pattern(dsp, owned, comm, relevant);
    PETScWrappers::MPI::SparseMatrix system, preconditioner, gap_laplace;
    system.reinit(owned, owned, dsp, comm);
    const bool direct = s.solver == "direct" || (s.solver == "auto" && r.n_dofs <= static_cast<std::size_t>(s.direct_max_dofs));
    const bool gap_schur = !direct && s.schur == "gap";
    if (!direct)
      preconditioner.reinit(owned, owned, dsp, comm);
    // The gap Laplacian (pressure block only) vanishes on the outlet's
    // pressure DoFs, where the traction fixes the pressure.
    AffineConstraints<double> outlet_pressure(relevant);
    std::unique_ptr<GapHeights> gap_heights;
    double                    wide_weight = 0;
    if (gap_schur)
      {
        gap_laplace.reinit(owned, owned, dsp, comm);
        std::map<types::global_dof_index, double> outlet_values;
        VectorTools::interpolate_boundary_values(mapping, dof, mesher::outlet, zero, outlet_values,
                                                 fe.component_mask(pressure));
        for (const auto &[i, v] : outlet_values)
          outlet_pressure.add_line(i);
        outlet_pressure.close();
        gap_heights = std::make_unique<GapHeights>(mesh);
        Point<3> lo = Point<3>(mesh.vertices[0][0], mesh.vertices[0][1], mesh.vertices[0][2]), hi = lo;
        for (const auto &v : mesh.vertices)
          for (int d = 0; d < 3; ++d)
            lo[d] = std::min(lo[d], v[d]), hi[d] = std::max(hi[d], v[d]);
        wide_weight = lo.distance_square(hi) / mu;
      }
    PETScWrappers::MPI::Vector rhs(owned, comm), solution(owned, comm);
    r.setup_time_s = seconds_since(start);
    lap("flow: set-up");
    if (verbose && root)
      std::fprintf(stderr, "  %zu DoFs (%zu velocity, %zu pressure) on %u process(es)\n", r.n_dofs,
                   r.n_velocity_dofs, r.n_pressure_dofs, n_procs);

    // The pressure unknown is p / sigma and the continuity equation is
    // multiplied by sigma = mu / (mean cell size): both blocks of the matrix
    // then have the same scale, and the solver's residual weighs the mass
    // balance as much as the momentum.
    double volume = 0;
    for (std::size_t c = 0; c < mesh.cells.size(); ++c)
      volume += mesher::cell_volume(mesh, c);
    const double sigma = mu / std::cbrt(volume / static_cast<double>(mesh.cells.size()));
    const double rho   = parameters.fluid.density_kg_per_m3;

    // Assembly: mu grad u : grad v - p div v - q div u (the Laplacian form,
    // the same flow inside for constant mu; its natural outlet condition
    // (mu grad u - p I) n = -p_out n lets fully developed flow leave
    // undisturbed, which the symmetric-gradient form's does not); the
    // preconditioner matrix has -(1/mu) p q in place of the zero pressure
    // block. With `state` (Newton's step for Navier-Stokes), the convection
    // in skew-symmetric form, rho (u.grad)u + rho/2 (div u) u (the same for
    // the exact, divergence-free flow; for the discrete one it makes the
    // convection's work exactly the kinetic energy flux through the
    // boundary, so the energy balance holds), linearised about the state's
    // velocity w: rho [(w.grad)u + (u.grad)w + (div w) u / 2 + (div u) w / 2]
    // on the left, rho [(w.grad)w + (div w) w / 2] on the right.
    const auto assemble = [&](const PETScWrappers::MPI::Vector *state, bool with_gap_laplace) {
      system = 0;
      rhs    = 0;
      if (!direct)
        preconditioner = 0;
      FEValues<3> values(mapping, fe, quadrature, update_values | update_gradients | update_JxW_values);
      const unsigned n = fe.n_dofs_per_cell();
      FullMatrix<double> local(n, n), local_prec(n, n), local_laplace(n, n);
      Vector<double>     local_rhs(n);
      // Each shape function has one non-zero component: velocity functions
      // couple through mu grad.grad only with the same component, and with
      // pressure functions through the divergence (that component's derivative).
      std::vector<unsigned> component(n);
      for (unsigned i = 0; i < n; ++i)
        component[i] = fe.system_to_component_index(i).first;
      std::vector<Tensor<1, 3>> grad(n);
      std::vector<double>       phi(n);
      std::vector<Tensor<1, 3>> w(quadrature.size());
      std::vector<Tensor<2, 3>> grad_w(quadrature.size());
      const double p_out = s.outlet_pressure_Pa;
      for (const auto &cell : dof.active_cell_iterators())
        if (cell->is_locally_owned())
          {
            values.reinit(cell);
            local = 0, local_prec = 0, local_rhs = 0, local_laplace = 0;
            if (state != nullptr)
              {
                values[velocities].get_function_values(*state, w);
                values[velocities].get_function_gradients(*state, grad_w);
              }
            // The cell's weight in the gap Laplacian (sigma^2 from the scaling).
            double weight = 0;
            if (with_gap_laplace)
              {
                const double h = cell->material_id() == mesher::gap ? gap_heights->of(cell) : 0.0;
                weight = sigma * sigma * (h > 0 ? h * h / (12 * mu) : wide_weight);
              }
            for (unsigned q = 0; q < values.n_quadrature_points; ++q)
              {
                const double dx    = values.JxW(q);
                const double div_w = state != nullptr ? trace(grad_w[q]) : 0.0;
                for (unsigned i = 0; i < n; ++i)
                  {
                    grad[i] = values.shape_grad_component(i, q, component[i]);
                    phi[i]  = values.shape_value_component(i, q, component[i]);
                  }
                for (unsigned i = 0; i < n; ++i)
                  {
                    const unsigned ci = component[i];
                    if (state != nullptr && ci < 3)
                      local_rhs(i) += rho * (w[q] * grad_w[q][ci] + 0.5 * div_w * w[q][ci]) * phi[i] * dx;
                    for (unsigned j = 0; j < n; ++j)
                      {
                        const unsigned cj = component[j];
                        double         a  = 0;
                        if (ci < 3 && cj < 3)
                          {
                            if (state != nullptr)
                              a = rho *
                                  ((ci == cj ? w[q] * grad[j] + 0.5 * div_w * phi[j] : 0.0) +
                                   phi[j] * grad_w[q][ci][cj] + 0.5 * grad[j][cj] * w[q][ci]) *
                                  phi[i] * dx;
                            if (ci == cj)
                              a += mu * (grad[i] * grad[j]) * dx;
                            else if (state == nullptr)
                              continue;
                          }
                        else if (ci < 3)
                          a = -sigma * grad[i][ci] * phi[j] * dx;
                        else if (cj < 3)
                          a = -sigma * phi[i] * grad[j][cj] * dx;
                        else
                          {
                            local_prec(i, j) -= sigma * sigma * phi[i] * phi[j] / mu * dx;
                            local_laplace(i, j) += weight * (grad[i] * grad[j]) * dx;
                            continue;
                          }
                        local(i, j) += a;
                        local_prec(i, j) += a;
                      }
                  }
              }
            for (const auto f : cell->face_indices())
              if (cell->face(f)->at_boundary() && cell->face(f)->boundary_id() == mesher::outlet)
                {
                  face_values.reinit(cell, f);
                  for (unsigned q = 0; q < face_values.n_quadrature_points; ++q)
                    for (unsigned i = 0; i < n; ++i)
                      local_rhs(i) -= p_out * (face_values[velocities].value(i, q) * face_values.normal_vector(q)) *
                                      face_values.JxW(q);
                }
            cell->get_dof_indices(dofs);
            constraints.distribute_local_to_global(local, local_rhs, dofs, system, rhs);
            if (!direct)
              constraints.distribute_local_to_global(local_prec, dofs, preconditioner);
            if (with_gap_laplace)
              outlet_pressure.distribute_local_to_global(local_laplace, dofs, gap_laplace);
          }
      system.compress(VectorOperation::add);
      if (!direct)
        preconditioner.compress(VectorOperation::add);
      if (with_gap_laplace)
        gap_laplace.compress(VectorOperation::add);
      rhs.compress(VectorOperation::add);
    };

    // One linear solve of the assembled system into `solution`.
    const std::vector<PetscInt> velocity_indices(owned_u.begin(), owned_u.end()),
      pressure_indices(owned_p.begin(), owned_p.end());
    const auto linear_solve = [&]() {
      if (direct)
        {
          SolverControl                    control(1, 0);
          PETScWrappers::SparseDirectMUMPS mumps(control, comm);
          mumps.solve(system, solution, rhs);
          r.solver = "direct (MUMPS)";
          r.iterations += 1;
        }
      else
        {
          BlockSolverSettings b;
          b.tolerance      = s.tolerance;
          b.max_iterations = s.max_iterations;
          b.verbose        = verbose;
          r.iterations += solve_block_system(system.petsc_matrix(), preconditioner.petsc_matrix(),
                                             gap_schur ? gap_laplace.petsc_matrix() : nullptr, rhs, solution,
                                             velocity_indices, pressure_indices, b);
          r.solver = block_solver_name(gap_schur);
        }
      if (!std::isfinite(solution.l2_norm()))
        throw std::runtime_error("the Stokes solver (" + r.solver + ") returned a non-finite solution (" +
                                 std::to_string(r.n_dofs) + " DoFs); nothing is reported");
      constraints.distribute(solution);
    };

    // The physical solution (pressure times sigma) with ghost values.
    PETScWrappers::MPI::Vector ghosted(owned, relevant, comm), state(owned, relevant, comm);
    const auto physical = [&]() {
      PETScWrappers::MPI::Vector scaled = solution;
      for (const auto i : owned_p)
        scaled(i) *= sigma;
      scaled.compress(VectorOperation::insert);
      ghosted = scaled;
    };

    // Results: mean pressures and fluxes on inlet and outlet, dissipation,
    // force on the reed.
    const auto evaluate = [&]() {
      FEValues<3> values(mapping, fe, quadrature, update_gradients | update_JxW_values);
      std::vector<SymmetricTensor<2, 3>> e(quadrature.size());
      std::vector<Tensor<2, 3>>          gu(quadrature.size());
      std::vector<Tensor<1, 3>>          u_face(face_quadrature.size());
      std::vector<SymmetricTensor<2, 3>> e_face(face_quadrature.size());
      std::vector<double>                p_face(face_quadrature.size());
      double sums[14] = {}; // dissipation, p_in A, A_in, flux_in, p_out A, A_out, flux_out, F(3), kinetic energy flux,
                            // mu grad u : grad u
      for (const auto &cell : dof.active_cell_iterators())
        if (cell->is_locally_owned())
          {
            values.reinit(cell);
            values[velocities].get_function_symmetric_gradients(ghosted, e);
            values[velocities].get_function_gradients(ghosted, gu);
            for (unsigned q = 0; q < quadrature.size(); ++q)
              {
                sums[0] += 2 * mu * (e[q] * e[q]) * values.JxW(q);
                sums[13] += mu * scalar_product(gu[q], gu[q]) * values.JxW(q);
              }
            for (const auto f : cell->face_indices())
              if (cell->face(f)->at_boundary())
                {
                  const auto id = cell->face(f)->boundary_id();
                  if (id == mesher::walls)
                    continue;
                  face_values.reinit(cell, f);
                  face_values[velocities].get_function_values(ghosted, u_face);
                  face_values[velocities].get_function_symmetric_gradients(ghosted, e_face);
                  face_values[pressure].get_function_values(ghosted, p_face);
                  for (unsigned q = 0; q < face_quadrature.size(); ++q)
                    {
                      const double dA = face_values.JxW(q);
                      const auto  &n  = face_values.normal_vector(q);
                      if (id == mesher::inlet || id == mesher::outlet)
                        sums[12] += 0.5 * rho * u_face[q].norm_square() * (u_face[q] * n) * dA;
                      if (id == mesher::inlet)
                        sums[1] += p_face[q] * dA, sums[2] += dA, sums[3] -= u_face[q] * n * dA;
                      else if (id == mesher::outlet)
                        sums[4] += p_face[q] * dA, sums[5] += dA, sums[6] += u_face[q] * n * dA;
                      else // reed: the fluid's force on it, -sigma n with n out of the fluid
                        {
                          const Tensor<1, 3> t = (p_face[q] - s.outlet_pressure_Pa) * n - 2 * mu * (e_face[q] * n);
                          for (int d = 0; d < 3; ++d)
                            sums[7 + d] += t[d] * dA;
                        }
                    }
                }
          }
      Utilities::MPI::sum(ArrayView<const double>(sums, 14), comm, ArrayView<double>(sums, 14));
      r.R_gradient_dissipation_Pa_s_per_m3 = sums[13] / (Q * Q);
      r.kinetic_energy_flux_W = sums[12];
      r.inlet_area_m2             = sums[2];
      r.outlet_area_m2            = sums[5];
      r.inlet_pressure_Pa         = sums[1] / sums[2];
      r.outlet_pressure_Pa        = sums[4] / sums[5];
      r.inlet_flux_m3_per_s       = sums[3];
      r.outlet_flux_m3_per_s      = sums[6];
      r.mass_balance_rel_error    = std::abs(sums[6] - sums[3]) / Q;
      r.R_pressure_Pa_s_per_m3    = (r.inlet_pressure_Pa - r.outlet_pressure_Pa) / Q;
      r.R_dissipation_Pa_s_per_m3 = sums[0] / (Q * Q);
      for (int d = 0; d < 3; ++d)
        r.reed_force_N[d] = sums[7 + d];
      r.A_eff_m2 = r.reed_force_N[2] / (r.inlet_pressure_Pa - r.outlet_pressure_Pa);
      for (double v : {r.R_pressure_Pa_s_per_m3, r.R_dissipation_Pa_s_per_m3, r.mass_balance_rel_error, r.A_eff_m2})
        if (!std::isfinite(v))
          throw std::runtime_error("the Stokes solution gives a non-finite result (" + r.solver + ", " +
                                   std::to_string(r.n_dofs) + " DoFs); nothing is reported");
    };

    // Stokes.
    auto step_start = Clock::now();
    assemble(nullptr, gap_schur);
    r.assembly_time_s = seconds_since(step_start);
    lap("flow: assembly");
    step_start = Clock::now();
    linear_solve();
    r.solve_time_s = seconds_since(step_start);
    lap(direct ? "flow: solve (MUMPS)" : "flow: solve (FGMRES)");
    physical();
    evaluate();
    r.stokes_R_Pa_s_per_m3              = r.R_pressure_Pa_s_per_m3;
    r.stokes_R_gradient_dissipation_Pa_s_per_m3 = r.R_gradient_dissipation_Pa_s_per_m3;

    // Navier-Stokes: Newton's method from the Stokes flow.
    if (s.navier_stokes)
      {
        double change = 1;
        while (change > s.newton_tolerance)
          {
            if (r.newton_iterations == static_cast<unsigned>(s.newton_max_iterations))
              throw std::runtime_error("Newton's method for Navier-Stokes did not converge in " +
                                       std::to_string(s.newton_max_iterations) + " steps (relative change " +
                                       format_number(change) + "; Re too high for a steady flow?)");
            state = solution;
            const double previous = r.R_pressure_Pa_s_per_m3;
            step_start = Clock::now();
            assemble(&state, false);
            r.assembly_time_s += seconds_since(step_start);
            step_start = Clock::now();
            try
              {
                linear_solve();
              }
            catch (const std::runtime_error &e)
              {
                throw std::runtime_error(std::string(e.what()) + " in Newton step " +
                                         std::to_string(r.newton_iterations + 1) +
                                         " of Navier-Stokes: the Schur preconditioner ignores convection; at "
                                         "higher Reynolds numbers use [flow] solver = \"direct\"");
              }
            r.solve_time_s += seconds_since(step_start);
            physical();
            evaluate();
            ++r.newton_iterations;
            change = std::abs(r.R_pressure_Pa_s_per_m3 / previous - 1);
            if (verbose && root)
              std::fprintf(stderr, "  Newton step %u: R %.9e (change %.1e)\n", r.newton_iterations,
                           r.R_pressure_Pa_s_per_m3, change);
          }
      }
    if (!vtu_dir.empty())
      {
        DataOut<3> out;
        out.attach_dof_handler(dof);
        std::vector<std::string> names{"velocity", "velocity", "velocity", "pressure"};
        std::vector<DataComponentInterpretation::DataComponentInterpretation> kinds(
          3, DataComponentInterpretation::component_is_part_of_vector);
        kinds.push_back(DataComponentInterpretation::component_is_scalar);
        out.add_data_vector(ghosted, names, DataOut<3>::type_dof_data, kinds);
        out.build_patches(mapping);
        out.write_vtu_with_pvtu_record(vtu_dir.string() + "/", "flow", 0, comm, 0, 0);
      }
    r.wall_time_s = seconds_since(start);
    return r;
  }
} // namespace rectify::stokes
