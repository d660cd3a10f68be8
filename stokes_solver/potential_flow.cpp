#include "stokes_solver/potential_flow.h"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/petsc_precondition.h>
#include <deal.II/lac/petsc_solver.h>
#include <deal.II/lac/petsc_sparse_matrix.h>
#include <deal.II/lac/petsc_vector.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/numerics/vector_tools.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "mesher/tet_mesh.h"

namespace rectify::stokes
{
  using namespace dealii;

  namespace
  {
    /// CG with one BoomerAMG V-cycle per iteration until PETSc's (preconditioned)
    /// residual norm is 1e-8 of the right-hand side's (the added mass is the
    /// energy, whose error is of the order of the solution's squared: 1e-9 at
    /// 2 um, 1e-13 at 100 um against MUMPS on the reference valve); MUMPS
    /// where that is not reached in 200 iterations.
    void solve_laplace(const PETScWrappers::MPI::SparseMatrix &matrix, PETScWrappers::MPI::Vector &solution,
                       const PETScWrappers::MPI::Vector &rhs, MPI_Comm comm)
    {
      PETScWrappers::PreconditionBoomerAMG::AdditionalData amg;
      amg.symmetric_operator = true;
      amg.strong_threshold   = 0.7; // the gap's flat cells couple strongly across it (0.25, 0.5: no convergence)
      amg.aggressive_coarsening_num_levels = 1;
      using Relaxation = PETScWrappers::PreconditionBoomerAMG::AdditionalData::RelaxationType;
      amg.relaxation_type_up = amg.relaxation_type_down = Relaxation::Chebyshev; // symmetric, cheap
      try
        {
          PETScWrappers::PreconditionBoomerAMG preconditioner(matrix, amg);
          SolverControl                        control(200, 1e-8 * rhs.l2_norm());
          PETScWrappers::SolverCG              cg(control);
          cg.solve(matrix, solution, rhs, preconditioner);
        }
      catch (const SolverControl::NoConvergence &)
        {
          SolverControl                    control(1, 0);
          PETScWrappers::SparseDirectMUMPS mumps(control, comm);
          solution = 0;
          mumps.solve(matrix, solution, rhs);
        }
      if (!std::isfinite(solution.l2_norm()))
        throw std::runtime_error("the added mass's potential flow returned a non-finite solution");
    }
  } // namespace

  PotentialFlow solve_potential_flow(const Triangulation<3> &triangulation, const Mapping<3> &mapping,
                                     const std::function<double(double, double)> &shape, MPI_Comm comm)
  {
    const FE_SimplexP<3>   fe(2);
    const QGaussSimplex<3> quadrature(2); // exact for grad.grad of P2 on straight tetrahedra
    const QGaussSimplex<2> face_quadrature(3);
    DoFHandler<3>          dof_handler(triangulation);
    dof_handler.distribute_dofs(fe);
    const IndexSet owned = dof_handler.locally_owned_dofs();
    IndexSet       relevant;
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant);

    AffineConstraints<double> constraints(relevant);
    VectorTools::interpolate_boundary_values(mapping, dof_handler, mesher::outlet, Functions::ZeroFunction<3>(),
                                             constraints);
    constraints.close();
    DynamicSparsityPattern dsp(relevant);
    DoFTools::make_sparsity_pattern(dof_handler, dsp, constraints, false);
    SparsityTools::distribute_sparsity_pattern(dsp, owned, comm, relevant);
    PETScWrappers::MPI::SparseMatrix matrix;
    matrix.reinit(owned, owned, dsp, comm);
    PETScWrappers::MPI::Vector rhs(owned, comm), solution(owned, comm);

    // (grad phi, grad psi) = integral of w n_z psi over the reed
    FEValues<3>     fe_values(mapping, fe, quadrature, update_gradients | update_JxW_values);
    FEFaceValues<3> face_values(mapping, fe, face_quadrature,
                                update_values | update_quadrature_points | update_normal_vectors | update_JxW_values);
    const unsigned  n = fe.n_dofs_per_cell();
    FullMatrix<double>                   local_matrix(n, n);
    Vector<double>                       local_rhs(n);
    std::vector<types::global_dof_index> dofs(n);
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          fe_values.reinit(cell);
          local_matrix = 0;
          local_rhs    = 0;
          for (unsigned q = 0; q < quadrature.size(); ++q)
            for (unsigned i = 0; i < n; ++i)
              for (unsigned j = 0; j < n; ++j)
                local_matrix(i, j) += fe_values.shape_grad(i, q) * fe_values.shape_grad(j, q) * fe_values.JxW(q);
          for (const auto f : cell->face_indices())
            if (cell->face(f)->at_boundary() && cell->face(f)->boundary_id() == mesher::reed)
              {
                face_values.reinit(cell, f);
                for (unsigned q = 0; q < face_quadrature.size(); ++q)
                  {
                    const auto  &x = face_values.quadrature_point(q);
                    const double g = shape(x[0], x[1]) * face_values.normal_vector(q)[2];
                    for (unsigned i = 0; i < n; ++i)
                      local_rhs(i) += g * face_values.shape_value(i, q) * face_values.JxW(q);
                  }
              }
          cell->get_dof_indices(dofs);
          constraints.distribute_local_to_global(local_matrix, local_rhs, dofs, matrix, rhs);
        }
    matrix.compress(VectorOperation::add);
    rhs.compress(VectorOperation::add);

    PotentialFlow result;
    result.n_dofs = dof_handler.n_dofs();
    solve_laplace(matrix, solution, rhs, comm);
    constraints.distribute(solution);
    PETScWrappers::MPI::Vector phi(owned, relevant, comm);
    phi = solution;

    std::vector<Tensor<1, 3>> grad(quadrature.size());
    std::vector<double>       face_phi(face_quadrature.size());
    double                    energy = 0, boundary = 0;
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          fe_values.reinit(cell);
          fe_values.get_function_gradients(phi, grad);
          for (unsigned q = 0; q < quadrature.size(); ++q)
            energy += grad[q] * grad[q] * fe_values.JxW(q);
          for (const auto f : cell->face_indices())
            if (cell->face(f)->at_boundary() && cell->face(f)->boundary_id() == mesher::reed)
              {
                face_values.reinit(cell, f);
                face_values.get_function_values(phi, face_phi);
                for (unsigned q = 0; q < face_quadrature.size(); ++q)
                  {
                    const auto &x = face_values.quadrature_point(q);
                    boundary += face_phi[q] * shape(x[0], x[1]) * face_values.normal_vector(q)[2] * face_values.JxW(q);
                  }
              }
        }
    result.energy_integral   = Utilities::MPI::sum(energy, comm);
    result.boundary_integral = Utilities::MPI::sum(boundary, comm);
    return result;
  }
} // namespace rectify::stokes
