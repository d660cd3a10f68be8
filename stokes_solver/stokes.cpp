// Taylor-Hood P2-P1 Stokes on tetrahedra with deal.II 9.4 and PETSc.
// Every process builds the same serial triangulation from the mesh, METIS
// partitions it, and a fully distributed triangulation keeps each process's
// part. One monolithic PETSc matrix serves both solvers: MUMPS (direct), or
// FGMRES with PETSc's field split: upper block-triangular Schur
// factorisation, one hypre BoomerAMG V-cycle on the velocity block, the
// pressure mass matrix / mu (Jacobi) on the Schur complement.
//
// The problem is one class in the shape of deal.II's step-22, on tetrahedra
// as tests/simplex/stokes-sv.cc: MappingFE with FE_SimplexP(1), FESystem of
// FE_SimplexP(2)^3 x FE_SimplexP(1), QGaussSimplex. What differs from
// step-22: no adaptive refinement (the mesher makes the mesh), PETSc and MPI
// (a fully distributed triangulation from a METIS partition), a scaled
// pressure unknown, the Laplacian form of the viscous term (the outlet's
// natural condition), and Navier-Stokes by Newton's method from the Stokes flow.
#include "stokes_solver/stokes.h"

#include <deal.II/base/function.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/lac/vector_memory.h>
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


#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>
#include <cstdio>
#include <map>
#include <memory>
#include <stdexcept>

#include <petscsys.h>
#include <slepcsys.h>

#include "mesher/to_dealii.h"
#include "stokes_solver/block_solver.h"
#include "stokes_solver/wall_distance.h"
#include "stokes_solver/duct_profile.h"
#include "stokes_solver/potential_flow.h"

namespace rectify::stokes
{
  using namespace dealii;

  namespace
  {
    /// What deal.II's MPI_InitFinalize does (MPI, then SLEPc and PETSc on
    /// it, one thread for deal.II's own tasks; the reverse at the end), at
    /// MPI_THREAD_MULTIPLE, which MPI_InitFinalize does not ask for.
    class MultipleThreadsInitFinalize
    {
    public:
      MultipleThreadsInitFinalize()
      {
        int provided = 0;
        MPI_Init_thread(nullptr, nullptr, MPI_THREAD_MULTIPLE, &provided);
        if (provided < MPI_THREAD_MULTIPLE)
          {
            MPI_Finalize();
            throw std::runtime_error("this MPI library does not provide MPI_THREAD_MULTIPLE, which rectify whatif "
                                     "needs (its scheduler answers while its process solves)");
          }
        SlepcInitialize(nullptr, nullptr, nullptr, nullptr);
        PetscPopSignalHandler();
        MultithreadInfo::set_thread_limit(1);
      }
      ~MultipleThreadsInitFinalize()
      {
        GrowingVectorMemory<PETScWrappers::MPI::Vector>::release_unused_memory();
        SlepcFinalize();
        MPI_Finalize();
      }
      MultipleThreadsInitFinalize(const MultipleThreadsInitFinalize &)            = delete;
      MultipleThreadsInitFinalize &operator=(const MultipleThreadsInitFinalize &) = delete;
    };
  } // namespace

  struct MpiSession::Impl
  {
    explicit Impl(Threads threads)
    {
      if (threads == Threads::multiple)
        multiple = std::make_unique<MultipleThreadsInitFinalize>();
      else
        serialized = std::make_unique<Utilities::MPI::MPI_InitFinalize>(argc, argv, 1);
    }
    int                                               argc = 1;
    char                                              name[8] = "rectify";
    char                                             *argv_storage[2] = {name, nullptr};
    char                                            **argv = argv_storage;
    std::unique_ptr<Utilities::MPI::MPI_InitFinalize> serialized;
    std::unique_ptr<MultipleThreadsInitFinalize>      multiple;
  };
  MpiSession::MpiSession(Threads threads) : impl_(new Impl(threads)), comm_(MPI_COMM_WORLD) {}
  MpiSession::MpiSession(std::nullptr_t, MPI_Comm comm) : impl_(nullptr), comm_(comm) {}
  MpiSession::MpiSession(MpiSession &&other) noexcept : impl_(other.impl_), comm_(other.comm_)
  {
    other.impl_ = nullptr;
  }
  MpiSession MpiSession::on(MPI_Comm comm) { return MpiSession(nullptr, comm); }
  MpiSession::~MpiSession() { delete impl_; }
  unsigned MpiSession::rank() const { return Utilities::MPI::this_mpi_process(comm_); }
  unsigned MpiSession::size() const { return Utilities::MPI::n_mpi_processes(comm_); }
  std::vector<double> MpiSession::broadcast(std::vector<double> values) const
  {
    return Utilities::MPI::broadcast(comm_, values, 0);
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

    /// An inlet patch's centre, inward normal and circumradius, from its faces.
    struct InletFrame
    {
      Point<3>     centre;
      Tensor<1, 3> inward;
      double       radius = 0;
    };

    InletFrame inlet_frame(const mesher::TetMesh &m, const std::vector<std::size_t> &faces)
    {
      InletFrame   f;
      double       area = 0;
      Tensor<1, 3> normal;
      for (const auto i : faces)
        {
          const auto &b = m.boundary[i];
          const auto &p0 = m.vertices[b.vertices[0]], &p1 = m.vertices[b.vertices[1]], &p2 = m.vertices[b.vertices[2]];
          const Point<3> a(p0[0], p0[1], p0[2]), b1(p1[0], p1[1], p1[2]), c(p2[0], p2[1], p2[2]);
          const Tensor<1, 3> n = 0.5 * cross_product_3d(b1 - a, c - a); // outward, |n| = area
          area += n.norm();
          normal += n;
          f.centre += n.norm() * (a + b1 + c) / 3.0;
        }
      f.centre /= area;
      f.inward = -normal / normal.norm();
      for (const auto i : faces)
        for (auto v : m.boundary[i].vertices)
          {
            const Point<3> p(m.vertices[v][0], m.vertices[v][1], m.vertices[v][2]);
            f.radius = std::max(f.radius, p.distance(f.centre));
          }
      return f;
    }

    /// One port's inlet: a connected patch of the mesh's inlet faces, and
    /// its developed inflow: a round port's parabola (Hagen-Poiseuille), any
    /// other section's duct profile (DuctProfile) on the patch's own triangles.
    struct InletPort
    {
      InletFrame                         frame;
      std::array<Tensor<1, 3>, 2>        plane; ///< unit vectors in the patch's plane
      double                             area = 0;
      bool                               round = false;
      std::shared_ptr<const DuctProfile> duct; ///< not round
    };

    /// The mesh's inlet faces grouped into patches (union-find over their
    /// shared vertices), in the order of their first face.
    std::vector<std::vector<std::size_t>> inlet_patches(const mesher::TetMesh &m)
    {
      std::vector<std::size_t>                  faces;
      std::map<std::uint32_t, std::size_t>      first_face_of_vertex;
      std::vector<std::size_t>                  parent;
      const std::function<std::size_t(std::size_t)> root = [&](std::size_t i) {
        while (parent[i] != i)
          i = parent[i] = parent[parent[i]];
        return i;
      };
      for (std::size_t i = 0; i < m.boundary.size(); ++i)
        if (m.boundary[i].id == mesher::inlet)
          {
            const std::size_t k = faces.size();
            faces.push_back(i);
            parent.push_back(k);
            for (const auto v : m.boundary[i].vertices)
              {
                const auto [it, added] = first_face_of_vertex.try_emplace(v, k);
                if (!added)
                  parent[root(k)] = root(it->second);
              }
          }
      if (faces.empty())
        throw InputError("the mesh has no inlet (no boundary face with id 1)");
      std::vector<std::vector<std::size_t>> patches;
      std::map<std::size_t, std::size_t>    patch_of_root;
      for (std::size_t k = 0; k < faces.size(); ++k)
        {
          const auto [it, added] = patch_of_root.try_emplace(root(k), patches.size());
          if (added)
            patches.emplace_back();
          patches[it->second].push_back(faces[k]);
        }
      return patches;
    }

    /// A patch's rim corners: its boundary edges' vertices (edges used once)
    /// but those on a straight stretch (a triangulation's points along a
    /// polygon's edge).
    std::vector<std::size_t> rim_corners(const std::vector<DuctProfile::Point2> &points,
                                         const std::map<std::pair<std::size_t, std::size_t>, unsigned> &edges)
    {
      std::map<std::size_t, std::vector<std::size_t>> rim_neighbours;
      for (const auto &[e, count] : edges)
        if (count == 1)
          {
            rim_neighbours[e.first].push_back(e.second);
            rim_neighbours[e.second].push_back(e.first);
          }
      std::vector<std::size_t> rim;
      for (const auto &[v, nb] : rim_neighbours)
        {
          if (nb.size() == 2)
            {
              const auto  &p = points[v], &a = points[nb[0]], &b = points[nb[1]];
              const double ux = p[0] - a[0], uy = p[1] - a[1], wx = b[0] - p[0], wy = b[1] - p[1];
              if (std::abs(ux * wy - uy * wx) <= 1e-9 * std::hypot(ux, uy) * std::hypot(wx, wy))
                continue;
            }
          rim.push_back(v);
        }
      return rim;
    }

    /// At least 12 rim corners, all on one circle within 1e-6 of its radius
    /// (least squares: u^2 + v^2 + D u + E v + F = 0, Kasa's fit).
    bool on_one_circle(const std::vector<DuctProfile::Point2> &points, const std::vector<std::size_t> &rim)
    {
      if (rim.size() < 12)
        return false;
      FullMatrix<double> A(3, 3);
      Vector<double>     rhs(3), x(3);
      for (const auto r : rim)
        {
          const double u = points[r][0], v = points[r][1], row[3] = {u, v, 1.0};
          for (int i = 0; i < 3; ++i)
            {
              rhs(i) -= (u * u + v * v) * row[i];
              for (int j = 0; j < 3; ++j)
                A(i, j) += row[i] * row[j];
            }
        }
      A.gauss_jordan();
      A.vmult(x, rhs);
      const double uc = -x(0) / 2, vc = -x(1) / 2, radius = std::sqrt(uc * uc + vc * vc - x(2));
      double       worst = 0;
      for (const auto r : rim)
        worst = std::max(worst, std::abs(std::hypot(points[r][0] - uc, points[r][1] - vc) - radius));
      return std::isfinite(radius) && worst <= 1e-6 * radius;
    }

    /// The inlet's patches, in the order of their first face. A patch is
    /// round if its rim has at least 12 corners (vertices not on a straight
    /// stretch of it) and all lie on one circle within 1e-6 of its radius
    /// (least squares); the mesher's round ports do (their polygons'
    /// vertices are on the circle; the triangulation adds points along the
    /// polygon's edges).
    std::vector<InletPort> inlet_ports(const mesher::TetMesh &m)
    {
      const auto patches = inlet_patches(m);
      std::vector<InletPort> ports;
      for (const auto &patch : patches)
        {
          InletPort port;
          port.frame = inlet_frame(m, patch);
          const Tensor<1, 3> &n = port.frame.inward;
          Tensor<1, 3>        e1;
          e1[std::abs(n[0]) < 0.9 ? 0 : 1] = 1;
          e1 -= (e1 * n) * n;
          e1 /= e1.norm();
          port.plane = {e1, cross_product_3d(n, e1)};
          // The patch's own triangles in the plane, and its rim.
          std::map<std::uint32_t, std::size_t>                    local;
          std::vector<DuctProfile::Point2>                        points;
          std::vector<std::array<std::size_t, 3>>                 triangles;
          std::map<std::pair<std::size_t, std::size_t>, unsigned> edges;
          for (const auto i : patch)
            {
              std::array<std::size_t, 3> t{};
              for (int j = 0; j < 3; ++j)
                {
                  const auto v          = m.boundary[i].vertices[j];
                  const auto [it, added] = local.try_emplace(v, points.size());
                  if (added)
                    {
                      const Tensor<1, 3> d = Point<3>(m.vertices[v][0], m.vertices[v][1], m.vertices[v][2]) -
                                             port.frame.centre;
                      points.push_back({d * port.plane[0], d * port.plane[1]});
                    }
                  t[j] = it->second;
                }
              for (int j = 0; j < 3; ++j)
                ++edges[std::minmax(t[j], t[(j + 1) % 3])];
              triangles.push_back(t);
              const auto &a = points[t[0]], &b = points[t[1]], &c = points[t[2]];
              port.area += 0.5 * std::abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
            }
          const auto rim = rim_corners(points, edges);
          port.round = on_one_circle(points, rim);
          if (!port.round)
            port.duct = std::make_shared<const DuctProfile>(std::move(points), triangles);
          ports.push_back(std::move(port));
        }
      return ports;
    }

    /// A port's developed inflow along its inward normal, zero off its patch
    /// (velocity components only): a round port's 1 - rho^2 / R^2, any
    /// other's duct profile. Either is scaled to carry the flow wanted.
    class InletProfile : public Function<3>
    {
    public:
      explicit InletProfile(const InletPort &port) : Function<3>(4), port_(port) {}
      double value(const Point<3> &p, unsigned c) const override
      {
        if (c > 2)
          return 0;
        const InletFrame &f = port_.frame;
        Tensor<1, 3>      d = p - f.centre;
        const double      off = d * f.inward;
        if (std::abs(off) > 1e-6 * f.radius)
          return 0; // another port's plane
        if (!port_.round)
          return port_.duct->value(d * port_.plane[0], d * port_.plane[1]) * f.inward[c];
        d -= off * f.inward;
        const double s = std::max(0.0, 1.0 - d.norm_square() / (f.radius * f.radius));
        return s * f.inward[c];
      }

    private:
      const InletPort &port_;
    };

    /// The reed's surface velocity per unit tip velocity, w(x, y) e_z.
    class ReedVelocity : public Function<3>
    {
    public:
      explicit ReedVelocity(const std::function<double(double, double)> &shape) : Function<3>(4), shape_(shape) {}
      double value(const Point<3> &p, unsigned c) const override { return c == 2 ? shape_(p[0], p[1]) : 0.0; }

    private:
      const std::function<double(double, double)> &shape_;
    };
      /// Integrals of the solution, summed over the processes.
    struct FlowIntegrals
    {
      double       dissipation_W               = 0; ///< integral of 2 mu e(u):e(u)
      double       gradient_dissipation_W      = 0; ///< integral of mu grad u : grad u
      double       inlet_pressure_times_area   = 0; ///< integral of p over the inlet
      double       inlet_area_m2               = 0;
      double       inlet_flux_m3_per_s         = 0; ///< into the domain
      double       outlet_pressure_times_area  = 0;
      double       outlet_area_m2              = 0;
      double       outlet_flux_m3_per_s        = 0; ///< out of the domain
      Tensor<1, 3> reed_force_N;                    ///< the fluid's traction on the reed, p relative to p_out
      double       kinetic_energy_flux_W       = 0; ///< integral of rho |u|^2 / 2 u.n over inlet and outlet

      void sum_over(const MPI_Comm comm)
      {
        for (double *v : {&dissipation_W, &gradient_dissipation_W, &inlet_pressure_times_area, &inlet_area_m2,
                          &inlet_flux_m3_per_s, &outlet_pressure_times_area, &outlet_area_m2, &outlet_flux_m3_per_s,
                          &kinetic_energy_flux_W})
          *v = Utilities::MPI::sum(*v, comm);
        reed_force_N = Utilities::MPI::sum(reed_force_N, comm);
      }
    };

    /// One cell's share of the linear system: the Stokes matrix (with
    /// Newton's linearised convection about a state w) and right-hand side,
    /// the pressure mass and the gap Laplacian (pressure DoFs only). Each
    /// shape function has one non-zero component: velocity functions couple
    /// through mu grad.grad only with the same component, and with pressure
    /// functions through the divergence (that component's derivative).
    struct CellSystem
    {
      explicit CellSystem(const FiniteElement<3> &fe)
        : n(fe.n_dofs_per_cell()), component(n), grad_phi(n), phi(n), matrix(n, n), rhs(n)
      {
        for (unsigned i = 0; i < n; ++i)
          if ((component[i] = fe.system_to_component_index(i).first) == 3)
            pressure_dof.push_back(i);
        mass.reinit(pressure_dof.size(), pressure_dof.size());
        gap_laplace.reinit(pressure_dof.size(), pressure_dof.size());
      }

      void clear() { matrix = 0, rhs = 0, mass = 0, gap_laplace = 0; }

      /// Quadrature point q; w and grad_w null for Stokes.
      void add_point(const FEValues<3> &v, unsigned q, const Tensor<1, 3> *w, const Tensor<2, 3> *grad_w, double mu,
                     double rho, double sigma, double laplace_weight)
      {
        const double dx    = v.JxW(q);
        const double div_w = w != nullptr ? trace(*grad_w) : 0.0;
        for (unsigned i = 0; i < n; ++i)
          {
            grad_phi[i] = v.shape_grad_component(i, q, component[i]);
            phi[i]      = v.shape_value_component(i, q, component[i]);
          }
        for (unsigned i = 0; i < n; ++i)
          {
            const unsigned ci = component[i];
            // f (Newton): rho [(w.grad)w + (div w) w / 2] . v
            if (w != nullptr && ci < 3)
              rhs(i) += rho * (*w * (*grad_w)[ci] + 0.5 * div_w * (*w)[ci]) * phi[i] * dx;
            for (unsigned j = 0; j < n; ++j)
              {
                const unsigned cj    = component[j];
                double         value = 0;
                if (ci < 3 && cj < 3)
                  {
                    // convection (Newton): rho [(w.grad)u + (div w) u/2 + (u.grad)w + (div u) w/2] . v
                    if (w != nullptr)
                      value = rho *
                              ((ci == cj ? *w * grad_phi[j] + 0.5 * div_w * phi[j] : 0.0) +
                               phi[j] * (*grad_w)[ci][cj] + 0.5 * grad_phi[j][cj] * (*w)[ci]) *
                              phi[i] * dx;
                    // A: (mu grad u, grad v)
                    if (ci == cj)
                      value += mu * (grad_phi[i] * grad_phi[j]) * dx;
                    else if (w == nullptr)
                      continue;
                  }
                else if (ci < 3) // sigma B^T: -(p, div v)
                  value = -sigma * grad_phi[i][ci] * phi[j] * dx;
                else if (cj < 3) // sigma B: -(q, div u)
                  value = -sigma * phi[i] * grad_phi[j][cj] * dx;
                else
                  continue; // the zero pressure block
                matrix(i, j) += value;
              }
          }
        // preconditioner: -(1/mu)(p, q); the gap Laplacian
        for (unsigned a = 0; a < pressure_dof.size(); ++a)
          for (unsigned b = 0; b < pressure_dof.size(); ++b)
            {
              const unsigned i = pressure_dof[a], j = pressure_dof[b];
              mass(a, b) -= sigma * sigma * phi[i] * phi[j] / mu * dx;
              gap_laplace(a, b) += laplace_weight * (grad_phi[i] * grad_phi[j]) * dx;
            }
      }

      const unsigned            n;
      std::vector<unsigned>     component, pressure_dof;
      std::vector<Tensor<1, 3>> grad_phi;
      std::vector<double>       phi;
      FullMatrix<double>        matrix, mass, gap_laplace;
      Vector<double>            rhs;
    };

    class StokesProblem
    {
    public:
      StokesProblem(const mesher::TetMesh &mesh, const FlowParameters &parameters, bool verbose,
                    const ReedMotion *motion, MPI_Comm comm);
      StokesResult run(const std::filesystem::path &vtu_dir);

    private:
      void          make_grid();
      void          setup_system();
      void          set_boundary_values();
      void          make_all_constraints();
      void          make_matrices_and_vectors();
      void          assemble_system(const PETScWrappers::MPI::Vector *state, bool with_gap_laplace);
      double        gap_weight(const DoFHandler<3>::active_cell_iterator &cell) const;
      void          solve(bool with_motion, bool with_exchange);
      PETScWrappers::MPI::Vector physical(const PETScWrappers::MPI::Vector &scaled) const;
      void          make_physical_solution();
      FlowIntegrals evaluate(const PETScWrappers::MPI::Vector &physical, double p_ref) const;
      double        tested_residual(const PETScWrappers::MPI::Vector &physical, double p_ref,
                                    const PETScWrappers::MPI::Vector &lift) const;
      void          split_flow();
      void          make_constraints(AffineConstraints<double> &c, const std::vector<double> &port_weights,
                                     bool reed_moves) const;
      void          set_ghosted(PETScWrappers::MPI::Vector &out, const std::map<types::global_dof_index, double> &values) const;
      double        inflow(const PETScWrappers::MPI::Vector &lift, types::boundary_id boundary) const;
      void          compute_loading();
      void          store(const FlowIntegrals &integrals);
      void          newton_iteration();
      void          output_results(const std::filesystem::path &vtu_dir) const;
      void          lap(const char *what);

      // Data, in the order it flows.
      const mesher::TetMesh &mesh_;
      const FlowSettings    &settings_;
      const double           mu_, rho_, Q_;
      const bool             verbose_;
      const ReedMotion      *motion_; ///< null: no fluid loading
      const MPI_Comm         comm_;
      const unsigned         n_processes_;
      const bool             root_;
      const std::vector<InletPort> ports_;

      Triangulation<3>                             serial_triangulation_;
      parallel::fullydistributed::Triangulation<3> distributed_triangulation_;
      const Triangulation<3>                      *triangulation_ = nullptr;

      const FESystem<3>                fe_;
      const MappingFE<3>               mapping_;
      const QGaussSimplex<3>           quadrature_;
      /// Exact for the Stokes matrix (degree 2 on straight tetrahedra);
      /// Navier-Stokes's convection (degree 5) takes quadrature_.
      const QGaussSimplex<3>           stokes_quadrature_;
      const QGaussSimplex<2>           face_quadrature_;
      const FEValuesExtractors::Vector velocities_;
      const FEValuesExtractors::Scalar pressure_;
      DoFHandler<3>                    dof_handler_;
      IndexSet                         owned_, relevant_, owned_velocity_, owned_pressure_;

      AffineConstraints<double> constraints_;     ///< no slip; the inlet's profile carrying Q
      AffineConstraints<double> outlet_pressure_; ///< the gap Laplacian vanishes on the outlet
      /// The fluid loading's solve (b): the same DoFs constrained, the reed
      /// moving with unit tip velocity, the inlet shut.
      AffineConstraints<double> motion_constraints_;
      PETScWrappers::MPI::Vector motion_rhs_, motion_solution_;
      /// Each solve's boundary data alone (zero at every other DoF), ghosted:
      /// the unit-flow inlet profile and the reed's unit-tip-velocity motion.
      PETScWrappers::MPI::Vector inlet_lift_, reed_lift_;
      /// The constrained DoFs: no slip (walls and reed; the reed's motion
      /// where it is not also a fixed wall's DoF), and the inlet's.
      std::vector<types::global_dof_index>      wall_dofs_;
      std::map<types::global_dof_index, double> reed_values_;
      /// Each port's profile on every inlet DoF (zero on the other ports'
      /// faces), scaled to unit flux; ghosted copies as lifts.
      std::vector<std::map<types::global_dof_index, double>> port_values_;
      std::vector<PETScWrappers::MPI::Vector>                port_lift_;
      /// Several ports: solve k moves unit flux from port 0 to port k (outlet
      /// traction zero, reed still), on the same matrix.
      std::vector<AffineConstraints<double>>  exchange_constraints_;
      std::vector<PETScWrappers::MPI::Vector> exchange_rhs_, exchange_solution_;
      /// MUMPS keeps its factors between the two solves of one matrix.
      SolverControl                                     mumps_control_{1, 0};
      std::unique_ptr<PETScWrappers::SparseDirectMUMPS> mumps_;
      bool                      direct_ = false, gap_schur_ = false;
      std::unique_ptr<GapHeights> gap_heights_;
      std::unique_ptr<WallDistance> wall_distance_; ///< the channel width outside the gap
      /// The pressure unknown is p / sigma and the continuity equation is
      /// multiplied by sigma = mu / (mean cell size): both blocks of the
      /// matrix then have the same scale, and the solver's residual weighs
      /// the mass balance as much as the momentum.
      double sigma_ = 0;

      PETScWrappers::MPI::SparseMatrix system_matrix_;
      /// The Schur preconditioner's matrices, in the pressure rows alone: the
      /// (negative) scaled pressure mass, the (positive) gap Laplacian.
      PETScWrappers::MPI::SparseMatrix pressure_mass_matrix_, gap_laplace_matrix_;
      PETScWrappers::MPI::Vector       system_rhs_, solution_;
      PETScWrappers::MPI::Vector       physical_solution_; ///< p times sigma, with ghost values
      PETScWrappers::MPI::Vector       state_;             ///< Newton's linearisation point, ghosted

      std::vector<double> port_flow_; ///< each port's share of Q (split_flow)
      StokesResult      result_;
      Clock::time_point start_, stage_;
    };

    StokesProblem::StokesProblem(const mesher::TetMesh &mesh, const FlowParameters &parameters, bool verbose,
                                 const ReedMotion *motion, MPI_Comm comm)
      : mesh_(mesh)
      , settings_(parameters.settings)
      , mu_(parameters.fluid.viscosity_Pa_s)
      , rho_(parameters.fluid.density_kg_per_m3)
      , Q_(parameters.settings.flow_rate_m3_per_s)
      , verbose_(verbose)
      , motion_(motion)
      , comm_(comm)
      , n_processes_(Utilities::MPI::n_mpi_processes(comm_))
      , root_(Utilities::MPI::this_mpi_process(comm_) == 0)
      , ports_(inlet_ports(mesh))
      , distributed_triangulation_(comm_)
      , fe_(FE_SimplexP<3>(2), 3, FE_SimplexP<3>(1), 1)
      , mapping_(FE_SimplexP<3>(1))
      , quadrature_(3)
      , stokes_quadrature_(2)
      , face_quadrature_(3)
      , velocities_(0)
      , pressure_(3)
      , start_(Clock::now())
      , stage_(start_)
    {
      result_.n_processes = n_processes_;
      result_.n_cells     = mesh.cells.size();
    }

    void StokesProblem::lap(const char *what)
    {
      if (verbose_ && root_)
        std::fprintf(stderr, "  %-28s %.2f s\n", what, seconds_since(stage_));
      stage_ = Clock::now();
    }

    // Mesh: serial on every process, partitioned, each keeping its part.
    void StokesProblem::make_grid()
    {
      mesher::fill_triangulation(mesh_, serial_triangulation_);
      if (n_processes_ > 1)
        {
          GridTools::partition_triangulation(n_processes_, serial_triangulation_);
          distributed_triangulation_.create_triangulation(
            TriangulationDescription::Utilities::create_description_from_triangulation(serial_triangulation_, comm_));
          triangulation_ = &distributed_triangulation_;
        }
      else
        triangulation_ = &serial_triangulation_;
      lap("flow: triangulation");
    }

    void StokesProblem::setup_system()
    {
      dof_handler_.reinit(*triangulation_);
      dof_handler_.distribute_dofs(fe_);
      // No component-wise renumbering: in parallel it would make a process's
      // DoFs non-contiguous; the field split takes the velocity and pressure
      // DoFs as index sets instead.
      owned_ = dof_handler_.locally_owned_dofs();
      DoFTools::extract_locally_relevant_dofs(dof_handler_, relevant_);
      owned_velocity_         = DoFTools::extract_dofs(dof_handler_, fe_.component_mask(velocities_));
      owned_pressure_         = DoFTools::extract_dofs(dof_handler_, fe_.component_mask(pressure_));
      result_.n_dofs          = dof_handler_.n_dofs();
      result_.n_pressure_dofs = Utilities::MPI::sum(owned_pressure_.n_elements(), comm_);
      result_.n_velocity_dofs = result_.n_dofs - result_.n_pressure_dofs;

      set_boundary_values();
      make_all_constraints();
      make_matrices_and_vectors();

      double volume = 0;
      for (std::size_t c = 0; c < mesh_.cells.size(); ++c)
        volume += mesher::cell_volume(mesh_, c);
      sigma_ = mu_ / std::cbrt(volume / static_cast<double>(mesh_.cells.size()));

      result_.setup_time_s = seconds_since(start_);
      lap("flow: set-up");
      if (verbose_ && root_)
        std::fprintf(stderr, "  %zu DoFs (%zu velocity, %zu pressure) on %u process(es)\n", result_.n_dofs,
                     result_.n_velocity_dofs, result_.n_pressure_dofs, n_processes_);
    }

    // Boundary values: no slip on walls and reed first, then each port's
    // profile on what is left (its rim stays at zero), scaled to unit flux;
    // with a moving reed, its velocity where it is not a fixed wall's DoF.
    void StokesProblem::set_boundary_values()
    {
      std::map<types::global_dof_index, double>         wall_values;
      std::map<types::boundary_id, const Function<3> *> wall_functions;
      const Functions::ZeroFunction<3>                  zero(4);
      wall_functions[mesher::walls] = &zero;
      wall_functions[mesher::reed]  = &zero;
      VectorTools::interpolate_boundary_values(mapping_, dof_handler_, wall_functions, wall_values,
                                               fe_.component_mask(velocities_));
      for (const auto &[i, v] : wall_values)
        wall_dofs_.push_back(i);
      if (motion_ != nullptr)
        {
          // The reed's motion where it is not also a fixed wall's DoF.
          std::map<types::global_dof_index, double> fixed_wall_values;
          VectorTools::interpolate_boundary_values(mapping_, dof_handler_, mesher::walls, zero, fixed_wall_values,
                                                   fe_.component_mask(velocities_));
          VectorTools::interpolate_boundary_values(mapping_, dof_handler_, mesher::reed, ReedVelocity(motion_->shape),
                                                   reed_values_, fe_.component_mask(velocities_));
          for (const auto &[i, v] : fixed_wall_values)
            reed_values_.erase(i);
        }
      for (const auto &port : ports_)
        {
          std::map<types::global_dof_index, double> values;
          VectorTools::interpolate_boundary_values(mapping_, dof_handler_, mesher::inlet, InletProfile(port), values,
                                                   fe_.component_mask(velocities_));
          for (const auto &[i, v] : wall_values)
            values.erase(i);
          port_lift_.emplace_back();
          set_ghosted(port_lift_.back(), values);
          const double flux = inflow(port_lift_.back(), mesher::inlet); // of the discrete profile
          if (!(flux > 0))
            {
              const auto &c = port.frame.centre;
              throw std::runtime_error("the inflow profile of the port at (" + format_number(c[0]) + ", " +
                                       format_number(c[1]) + ", " + format_number(c[2]) +
                                       ") m carries no flow (its inlet too coarse?)");
            }
          for (auto &[i, v] : values)
            v /= flux;
          set_ghosted(port_lift_.back(), values); // unit flux
          port_values_.push_back(std::move(values));
        }
      inlet_lift_.reinit(owned_, relevant_, comm_);
      inlet_lift_ = port_lift_[0];
    }

    // The flow's constraints, the ports' exchange problems' and the moving
    // reed's, with their vectors.
    void StokesProblem::make_all_constraints()
    {
      // All the flow through port 0 at first: several ports share it once
      // each exchange solve is known (split_flow).
      std::vector<double> weights(ports_.size(), 0.0);
      weights[0] = Q_;
      make_constraints(constraints_, weights, false);
      for (std::size_t k = 1; k < ports_.size(); ++k)
        {
          std::vector<double> exchange(ports_.size(), 0.0);
          exchange[0] = -1, exchange[k] = 1;
          exchange_constraints_.emplace_back();
          make_constraints(exchange_constraints_.back(), exchange, false);
          exchange_rhs_.emplace_back(owned_, comm_);
          exchange_solution_.emplace_back(owned_, comm_);
        }
      if (motion_ != nullptr)
        {
          // The same DoFs constrained (walls, reed, inlet), so the same matrix.
          make_constraints(motion_constraints_, std::vector<double>(ports_.size(), 0.0), true);
          set_ghosted(reed_lift_, reed_values_);
          motion_rhs_.reinit(owned_, comm_);
          motion_solution_.reinit(owned_, comm_);
        }
    }

    // The sparsity patterns and matrices (the system's; the pressure
    // block's for the Schur preconditioner), the gap Laplacian's outlet
    // constraint and its geometry, the solution vectors.
    void StokesProblem::make_matrices_and_vectors()
    {
      // Velocity components couple only with themselves (the Laplacian form)
      // and with the pressure; leaving the zero blocks out of the pattern
      // keeps them out of the AMG hierarchy and the direct solver's factors.
      // Navier-Stokes's linearised convection couples them all.
      DynamicSparsityPattern       dsp(relevant_);
      Table<2, DoFTools::Coupling> coupling(4, 4);
      for (unsigned i = 0; i < 4; ++i)
        for (unsigned j = 0; j < 4; ++j)
          coupling(i, j) =
            i == j || i == 3 || j == 3 || settings_.navier_stokes ? DoFTools::always : DoFTools::none;
      DoFTools::make_sparsity_pattern(dof_handler_, coupling, dsp, constraints_, false);
      SparsityTools::distribute_sparsity_pattern(dsp, owned_, comm_, relevant_);
      system_matrix_.reinit(owned_, owned_, dsp, comm_);
      direct_ = settings_.solver == "direct" ||
                (settings_.solver == "auto" && result_.n_dofs <= static_cast<std::size_t>(settings_.direct_max_dofs));
      gap_schur_ = !direct_ && settings_.schur == "gap";
      if (!direct_)
        {
          // The pressure block alone: the Schur preconditioner's matrices
          // take no velocity rows (the velocity AMG reads the system's).
          DynamicSparsityPattern       pressure_dsp(relevant_);
          Table<2, DoFTools::Coupling> pressure_only(4, 4);
          pressure_only.fill(DoFTools::none);
          pressure_only(3, 3) = DoFTools::always;
          DoFTools::make_sparsity_pattern(dof_handler_, pressure_only, pressure_dsp, AffineConstraints<double>(), false);
          SparsityTools::distribute_sparsity_pattern(pressure_dsp, owned_, comm_, relevant_);
          pressure_mass_matrix_.reinit(owned_, owned_, pressure_dsp, comm_);
          if (gap_schur_)
            gap_laplace_matrix_.reinit(owned_, owned_, pressure_dsp, comm_);
        }
      if (gap_schur_)
        {
          const Functions::ZeroFunction<3> zero(4);
          // The gap Laplacian vanishes on the outlet's pressure DoFs, where
          // the traction fixes the pressure.
          std::map<types::global_dof_index, double> outlet_values;
          VectorTools::interpolate_boundary_values(mapping_, dof_handler_, mesher::outlet, zero, outlet_values,
                                                   fe_.component_mask(pressure_));
          outlet_pressure_.reinit(relevant_);
          for (const auto &[i, v] : outlet_values)
            outlet_pressure_.add_line(i);
          outlet_pressure_.close();
          gap_heights_   = std::make_unique<GapHeights>(mesh_);
          wall_distance_ = std::make_unique<WallDistance>(mesh_);
        }
      system_rhs_.reinit(owned_, comm_);
      solution_.reinit(owned_, comm_);
      physical_solution_.reinit(owned_, relevant_, comm_);
      state_.reinit(owned_, relevant_, comm_);
    }

    // No slip on walls and reed (the reed's motion with `reed_moves`), and
    // on the inlet the ports' unit-flux profiles times `port_weights`.
    void StokesProblem::make_constraints(AffineConstraints<double> &c, const std::vector<double> &port_weights,
                                         bool reed_moves) const
    {
      c.clear();
      c.reinit(relevant_);
      for (const auto i : wall_dofs_)
        {
          c.add_line(i);
          const auto it = reed_values_.find(i);
          c.set_inhomogeneity(i, reed_moves && it != reed_values_.end() ? it->second : 0.0);
        }
      for (const auto &[i, v0] : port_values_[0])
        {
          double value = port_weights[0] * v0;
          for (std::size_t k = 1; k < port_values_.size(); ++k)
            value += port_weights[k] * port_values_[k].at(i);
          c.add_line(i);
          c.set_inhomogeneity(i, value);
        }
      c.close();
    }

    // The cell's weight in the gap Laplacian (sigma^2 from the scaling): in
    // the gap h^2 / 12; outside it d^2 with d the distance to the nearest
    // wall (averaged over a plane channel's width w it is w^2/12, the gap's
    // weight; over a round pipe's radius a, a^2/6 (a^2/8 exactly)).
    double StokesProblem::gap_weight(const DoFHandler<3>::active_cell_iterator &cell) const
    {
      const double h = cell->material_id() == mesher::gap ? gap_heights_->of(cell) : 0.0;
      double       k = h * h / 12;
      if (!(h > 0))
        {
          const auto c = cell->center();
          k            = std::pow((*wall_distance_)({c[0], c[1], c[2]}), 2);
        }
      return sigma_ * sigma_ * k / mu_;
    }

    // The block system, in the scaled unknowns (u, p / sigma):
    //
    //   [ A        sigma B^T ] [ u         ]   [ f ]
    //   [ sigma B  0         ] [ p / sigma ] = [ 0 ]
    //
    // with the weak form's terms
    //   A:  (mu grad u, grad v)  the Laplacian form: its natural outlet condition
    //       (mu grad u - p I) n = -p_out n lets fully developed flow leave
    //       undisturbed, which the symmetric-gradient form's does not
    //   B^T: -(p, div v)         B: -(q, div u)
    //   f:  -(p_out n, v) on the outlet (the traction)
    // For the iterative solver the pressure mass -(1/mu)(p, q) (scaled by
    // sigma^2) and the gap Laplacian (sigma^2 h^2 / (12 mu))(grad p, grad q)
    // ("gap" Schur preconditioner) go into matrices of the pressure rows alone.
    // With `state` (Newton's step for Navier-Stokes), the convection in
    // skew-symmetric form, rho (u.grad)u + rho/2 (div u) u (the same for the
    // exact, divergence-free flow; for the discrete one it makes the
    // convection's work exactly the kinetic energy flux through the boundary,
    // so the energy balance holds), linearised about the state's velocity w:
    //   rho [(w.grad)u + (u.grad)w + (div w) u / 2 + (div u) w / 2] on the left,
    //   rho [(w.grad)w + (div w) w / 2] on the right.
    //
    // Assembled: the system matrix and right-hand sides; with the iterative solver the
    // pressure mass and (`with_gap_laplace`) the gap Laplacian; `state` is
    // Newton's linearisation point (null: Stokes).
    void StokesProblem::assemble_system(const PETScWrappers::MPI::Vector *state, bool with_gap_laplace)
    {
      system_matrix_ = 0;
      system_rhs_    = 0;
      mumps_.reset(); // a new matrix: new factors
      const bool with_motion = motion_ != nullptr && state == nullptr;
      if (with_motion)
        motion_rhs_ = 0;
      const bool with_exchange = state == nullptr; // the exchange solves of several ports
      if (with_exchange)
        for (auto &rhs : exchange_rhs_)
          rhs = 0;
      if (!direct_)
        pressure_mass_matrix_ = 0;
      const Vector<double> no_load(fe_.n_dofs_per_cell());
      const auto          &quadrature = state != nullptr ? quadrature_ : stokes_quadrature_;
      FEValues<3>     fe_values(mapping_, fe_, quadrature, update_values | update_gradients | update_JxW_values);
      FEFaceValues<3> fe_face_values(mapping_, fe_, face_quadrature_,
                                     update_values | update_normal_vectors | update_JxW_values);
      CellSystem                           local(fe_);
      std::vector<types::global_dof_index> dofs(fe_.n_dofs_per_cell()), pressure_dofs(local.pressure_dof.size());
      std::vector<Tensor<1, 3>>            w(quadrature.size());
      std::vector<Tensor<2, 3>>            grad_w(quadrature.size());
      const double                         p_out = settings_.outlet_pressure_Pa;

      for (const auto &cell : dof_handler_.active_cell_iterators())
        if (cell->is_locally_owned())
          {
            fe_values.reinit(cell);
            local.clear();
            if (state != nullptr)
              {
                fe_values[velocities_].get_function_values(*state, w);
                fe_values[velocities_].get_function_gradients(*state, grad_w);
              }
            const double laplace_weight = with_gap_laplace ? gap_weight(cell) : 0.0;
            for (unsigned q = 0; q < fe_values.n_quadrature_points; ++q)
              local.add_point(fe_values, q, state != nullptr ? &w[q] : nullptr,
                              state != nullptr ? &grad_w[q] : nullptr, mu_, rho_, sigma_, laplace_weight);
            // f: -(p_out n, v) on the outlet
            for (const auto f : cell->face_indices())
              if (cell->face(f)->at_boundary() && cell->face(f)->boundary_id() == mesher::outlet)
                {
                  fe_face_values.reinit(cell, f);
                  for (unsigned q = 0; q < fe_face_values.n_quadrature_points; ++q)
                    for (unsigned i = 0; i < local.n; ++i)
                      local.rhs(i) -= p_out *
                                      (fe_face_values[velocities_].value(i, q) * fe_face_values.normal_vector(q)) *
                                      fe_face_values.JxW(q);
                }
            cell->get_dof_indices(dofs);
            constraints_.distribute_local_to_global(local.matrix, local.rhs, dofs, system_matrix_, system_rhs_);
            if (with_motion) // solve (b): no traction on the outlet; the reed's motion through the matrix
              motion_constraints_.distribute_local_to_global(no_load, dofs, motion_rhs_, local.matrix);
            if (with_exchange)
              for (std::size_t k = 0; k < exchange_rhs_.size(); ++k)
                exchange_constraints_[k].distribute_local_to_global(no_load, dofs, exchange_rhs_[k], local.matrix);
            for (unsigned a = 0; a < pressure_dofs.size(); ++a)
              pressure_dofs[a] = dofs[local.pressure_dof[a]];
            if (!direct_)
              pressure_mass_matrix_.add(pressure_dofs, local.mass);
            if (with_gap_laplace)
              outlet_pressure_.distribute_local_to_global(local.gap_laplace, pressure_dofs, gap_laplace_matrix_);
          }
      system_matrix_.compress(VectorOperation::add);
      if (!direct_)
        pressure_mass_matrix_.compress(VectorOperation::add);
      if (with_gap_laplace)
        gap_laplace_matrix_.compress(VectorOperation::add);
      system_rhs_.compress(VectorOperation::add);
      if (with_motion)
        motion_rhs_.compress(VectorOperation::add);
      if (with_exchange)
        for (auto &rhs : exchange_rhs_)
          rhs.compress(VectorOperation::add);
    }

    // One linear solve of the assembled system into solution_, and with
    // `with_motion` the fluid loading's solve (b) and with several ports
    // (`with_exchange`) their exchange solves on the same matrix.
    void StokesProblem::solve(bool with_motion, bool with_exchange)
    {
      if (direct_)
        {
          // MUMPS with iterative refinement: a thin gap makes the matrix
          // ill-conditioned (a 5 um gap under mm-sized cells), and the plain
          // factorisation's R carries round-off of ~1e-8 there (one and two
          // processes then differ by that much); up to 10 refinement steps,
          // to a backward error of 1e-16, bring it to the residual's own
          // round-off (docs/stokes.md). PETSC_OPTIONS still overrides both.
          for (const auto &[name, value] : {std::pair{"-mat_mumps_icntl_10", "10"}, std::pair{"-mat_mumps_cntl_2", "1e-16"}})
            {
              PetscBool set = PETSC_FALSE;
              PetscOptionsHasName(nullptr, nullptr, name, &set);
              if (!set)
                PetscOptionsSetValue(nullptr, name, value);
            }
          if (!mumps_)
            mumps_ = std::make_unique<PETScWrappers::SparseDirectMUMPS>(mumps_control_, comm_);
          mumps_->solve(system_matrix_, solution_, system_rhs_);
          if (with_motion)
            mumps_->solve(system_matrix_, motion_solution_, motion_rhs_);
          if (with_exchange)
            for (std::size_t k = 0; k < exchange_rhs_.size(); ++k)
              mumps_->solve(system_matrix_, exchange_solution_[k], exchange_rhs_[k]);
          result_.solver = "direct (MUMPS)";
          result_.iterations += 1;
        }
      else
        {
          const std::vector<PetscInt> velocity(owned_velocity_.begin(), owned_velocity_.end()),
            pressure(owned_pressure_.begin(), owned_pressure_.end());
          BlockSolverSettings b;
          b.tolerance      = settings_.tolerance;
          b.max_iterations = settings_.max_iterations;
          b.verbose        = verbose_;
          std::vector<BlockRhs> systems{{system_rhs_, solution_}};
          if (with_motion)
            systems.push_back({motion_rhs_, motion_solution_, settings_.loading_tolerance, "[flow] loading_tolerance"});
          if (with_exchange)
            for (std::size_t k = 0; k < exchange_rhs_.size(); ++k)
              systems.push_back({exchange_rhs_[k], exchange_solution_[k]});
          result_.iterations += solve_block_system(system_matrix_.petsc_matrix(), pressure_mass_matrix_.petsc_matrix(),
                                                   gap_schur_ ? gap_laplace_matrix_.petsc_matrix() : nullptr,
                                                   systems, velocity, pressure, b);
          result_.solver = block_solver_name(gap_schur_);
        }
      if (!std::isfinite(solution_.l2_norm()))
        throw std::runtime_error("the Stokes solver (" + result_.solver + ") returned a non-finite solution (" +
                                 std::to_string(result_.n_dofs) + " DoFs); nothing is reported");
      constraints_.distribute(solution_);
      if (with_motion)
        {
          if (!std::isfinite(motion_solution_.l2_norm()))
            throw std::runtime_error("the Stokes solver (" + result_.solver +
                                     ") returned a non-finite solution for the moving reed; nothing is reported");
          motion_constraints_.distribute(motion_solution_);
        }
      if (with_exchange)
        for (std::size_t k = 0; k < exchange_rhs_.size(); ++k)
          {
            if (!std::isfinite(exchange_solution_[k].l2_norm()))
              throw std::runtime_error("the Stokes solver (" + result_.solver +
                                       ") returned a non-finite solution for a port's share; nothing is reported");
            exchange_constraints_[k].distribute(exchange_solution_[k]);
          }
    }

    // A solution in physical units (pressure times sigma) with ghost values.
    PETScWrappers::MPI::Vector StokesProblem::physical(const PETScWrappers::MPI::Vector &solution) const
    {
      PETScWrappers::MPI::Vector scaled = solution;
      for (const auto i : owned_pressure_)
        scaled(i) *= sigma_;
      scaled.compress(VectorOperation::insert);
      PETScWrappers::MPI::Vector ghosted(owned_, relevant_, comm_);
      ghosted = scaled;
      return ghosted;
    }

    void StokesProblem::make_physical_solution() { physical_solution_ = physical(solution_); }

    FlowIntegrals StokesProblem::evaluate(const PETScWrappers::MPI::Vector &solution, double p_ref) const
    {
      FEValues<3>     fe_values(mapping_, fe_, quadrature_, update_gradients | update_JxW_values);
      FEFaceValues<3> fe_face_values(mapping_, fe_, face_quadrature_,
                                     update_values | update_gradients | update_normal_vectors | update_JxW_values);
      std::vector<SymmetricTensor<2, 3>> strain(quadrature_.size()), face_strain(face_quadrature_.size());
      std::vector<Tensor<2, 3>>          grad_u(quadrature_.size());
      std::vector<Tensor<1, 3>>          face_u(face_quadrature_.size());
      std::vector<double>                face_p(face_quadrature_.size());
      FlowIntegrals                      s;
      for (const auto &cell : dof_handler_.active_cell_iterators())
        if (cell->is_locally_owned())
          {
            fe_values.reinit(cell);
            fe_values[velocities_].get_function_symmetric_gradients(solution, strain);
            fe_values[velocities_].get_function_gradients(solution, grad_u);
            for (unsigned q = 0; q < quadrature_.size(); ++q)
              {
                s.dissipation_W += 2 * mu_ * (strain[q] * strain[q]) * fe_values.JxW(q);
                s.gradient_dissipation_W += mu_ * scalar_product(grad_u[q], grad_u[q]) * fe_values.JxW(q);
              }
            for (const auto f : cell->face_indices())
              if (cell->face(f)->at_boundary())
                {
                  const auto id = cell->face(f)->boundary_id();
                  if (id == mesher::walls)
                    continue;
                  fe_face_values.reinit(cell, f);
                  fe_face_values[velocities_].get_function_values(solution, face_u);
                  fe_face_values[velocities_].get_function_symmetric_gradients(solution, face_strain);
                  fe_face_values[pressure_].get_function_values(solution, face_p);
                  for (unsigned q = 0; q < face_quadrature_.size(); ++q)
                    {
                      const double dA = fe_face_values.JxW(q);
                      const auto  &n  = fe_face_values.normal_vector(q);
                      if (id == mesher::inlet || id == mesher::outlet)
                        s.kinetic_energy_flux_W += 0.5 * rho_ * face_u[q].norm_square() * (face_u[q] * n) * dA;
                      if (id == mesher::inlet)
                        {
                          s.inlet_pressure_times_area += face_p[q] * dA;
                          s.inlet_area_m2 += dA;
                          s.inlet_flux_m3_per_s -= face_u[q] * n * dA;
                        }
                      else if (id == mesher::outlet)
                        {
                          s.outlet_pressure_times_area += face_p[q] * dA;
                          s.outlet_area_m2 += dA;
                          s.outlet_flux_m3_per_s += face_u[q] * n * dA;
                        }
                      else // the reed: the fluid's force on it, -sigma n with n out of the fluid
                        s.reed_force_N += ((face_p[q] - p_ref) * n -
                                           2 * mu_ * (face_strain[q] * n)) * dA;
                    }
                }
          }
      s.sum_over(comm_);
      return s;
    }

    // The residual of the discrete momentum equation for `physical` (pressure
    // taken relative to p_ref), tested with `lift`: the work per unit
    // amplitude that the boundary data `lift` would do against the
    // solution's stresses, integral of mu grad u : grad L - (p - p_ref) div L
    // (the outlet's traction is zero relative to p_ref, and `lift` vanishes
    // there). For a discrete solution this is exact: the generalised force
    // conjugate to that boundary data.
    double StokesProblem::tested_residual(const PETScWrappers::MPI::Vector &solution, double p_ref,
                                          const PETScWrappers::MPI::Vector &lift) const
    {
      FEValues<3> fe_values(mapping_, fe_, quadrature_, update_values | update_gradients | update_JxW_values);
      std::vector<Tensor<2, 3>>            grad_u(quadrature_.size()), grad_l(quadrature_.size());
      std::vector<double>                  p(quadrature_.size()), div_l(quadrature_.size());
      std::vector<types::global_dof_index> dofs(fe_.n_dofs_per_cell());
      std::vector<double>                  lift_values(dofs.size());
      double                               sum = 0;
      for (const auto &cell : dof_handler_.active_cell_iterators())
        if (cell->is_locally_owned())
          {
            cell->get_dof_indices(dofs);
            lift.extract_subvector_to(dofs.begin(), dofs.end(), lift_values.begin());
            if (std::all_of(lift_values.begin(), lift_values.end(), [](double v) { return v == 0.0; }))
              continue;
            fe_values.reinit(cell);
            fe_values[velocities_].get_function_gradients(solution, grad_u);
            fe_values[pressure_].get_function_values(solution, p);
            fe_values[velocities_].get_function_gradients(lift, grad_l);
            fe_values[velocities_].get_function_divergences(lift, div_l);
            for (unsigned q = 0; q < quadrature_.size(); ++q)
              sum += (mu_ * scalar_product(grad_u[q], grad_l[q]) - (p[q] - p_ref) * div_l[q]) * fe_values.JxW(q);
          }
      return Utilities::MPI::sum(sum, comm_);
    }

    // Boundary data (DoF -> value, this process's entries among them) as a
    // vector with ghost values, zero elsewhere.
    void StokesProblem::set_ghosted(PETScWrappers::MPI::Vector                      &out,
                                    const std::map<types::global_dof_index, double> &values) const
    {
      PETScWrappers::MPI::Vector owned(owned_, comm_);
      for (const auto &[i, v] : values)
        if (owned_.is_element(i))
          owned(i) = v;
      owned.compress(VectorOperation::insert);
      out.reinit(owned_, relevant_, comm_);
      out = owned;
    }

    // The flow boundary data `lift` carries into the domain through the
    // faces of `boundary`, -integral of u.n, summed over the processes.
    double StokesProblem::inflow(const PETScWrappers::MPI::Vector &lift, types::boundary_id boundary) const
    {
      FEFaceValues<3> face_values(mapping_, fe_, face_quadrature_,
                                  update_values | update_normal_vectors | update_JxW_values);
      std::vector<Tensor<1, 3>> u(face_quadrature_.size());
      double                    flux = 0;
      for (const auto &cell : dof_handler_.active_cell_iterators())
        if (cell->is_locally_owned())
          for (const auto f : cell->face_indices())
            if (cell->face(f)->at_boundary() && cell->face(f)->boundary_id() == boundary)
              {
                face_values.reinit(cell, f);
                face_values[velocities_].get_function_values(lift, u);
                for (unsigned q = 0; q < face_values.n_quadrature_points; ++q)
                  flux -= u[q] * face_values.normal_vector(q) * face_values.JxW(q);
              }
      return Utilities::MPI::sum(flux, comm_);
    }

    // Several ports: the flow Q splits so that every port's pressure drop is
    // the same (the ports draw from one chamber). The solution is
    //   u = u_0 + sum_k q_k d_k,   k = 1 .. n-1,
    // u_0 all of Q through port 0, d_k unit flux moved from port 0 to port k;
    // the conditions P_k(u) = P_0(u) are n - 1 linear equations
    //   sum_k M_jk q_k = -(P_j - P_0)(u_0),   M_jk = (P_j - P_0)(d_k),
    // M the dissipation's form on the exchange flows (symmetric, positive
    // definite): the split is the one of least dissipation. The moving
    // reed's solve (b) (ports shut) gets the same correction with zero net
    // flow, so the fluid it displaces may leave by any port at equal pressure.
    void StokesProblem::split_flow()
    {
      const std::size_t n = ports_.size();
      port_flow_.assign(n, 0.0);
      port_flow_[0] = Q_;
      if (n == 1)
        return;
      const double                            p_out = settings_.outlet_pressure_Pa;
      std::vector<PETScWrappers::MPI::Vector> d;
      for (const auto &e : exchange_solution_)
        d.push_back(physical(e));
      const auto difference = [&](const PETScWrappers::MPI::Vector &u, double p_ref, std::size_t j) {
        return tested_residual(u, p_ref, port_lift_[j]) - tested_residual(u, p_ref, port_lift_[0]);
      };
      FullMatrix<double> M(n - 1, n - 1);
      for (std::size_t j = 1; j < n; ++j)
        for (std::size_t k = 1; k < n; ++k)
          M(j - 1, k - 1) = difference(d[k - 1], 0.0, j);
      M.gauss_jordan(); // its inverse
      const auto shares = [&](const PETScWrappers::MPI::Vector &u, double p_ref) {
        Vector<double> b(n - 1), q(n - 1);
        for (std::size_t j = 1; j < n; ++j)
          b(j - 1) = -difference(u, p_ref, j);
        M.vmult(q, b);
        return q;
      };
      const Vector<double> q = shares(physical(solution_), p_out);
      for (std::size_t k = 1; k < n; ++k)
        {
          solution_.add(q(k - 1), exchange_solution_[k - 1]);
          port_flow_[k] = q(k - 1);
          port_flow_[0] -= q(k - 1);
        }
      if (motion_ != nullptr)
        {
          const Vector<double> c = shares(physical(motion_solution_), 0.0);
          for (std::size_t k = 1; k < n; ++k)
            motion_solution_.add(c(k - 1), exchange_solution_[k - 1]);
        }
      // The inlet's data from now on: the loading's unit-flow lift, and
      // Newton's steps (Navier-Stokes keeps the Stokes flow's split).
      std::map<types::global_dof_index, double> lift;
      for (std::size_t k = 0; k < n; ++k)
        for (const auto &[i, v] : port_values_[k])
          lift[i] += port_flow_[k] / Q_ * v;
      set_ghosted(inlet_lift_, lift);
      make_constraints(constraints_, port_flow_, false);
      if (verbose_ && root_)
        for (std::size_t k = 0; k < n; ++k)
          std::fprintf(stderr, "  port %zu: %.6f of the flow\n", k + 1, port_flow_[k] / Q_);
    }

    // The 2x2 map from solves (a) (solution_, flow Q_) and (b) (the reed
    // moving at unit tip velocity), then the added mass.
    void StokesProblem::compute_loading()
    {
      const auto    t     = Clock::now();
      FluidLoading &L     = result_.loading;
      const double  p_out = settings_.outlet_pressure_Pa;
      const auto    b     = physical(motion_solution_);
      L.K_QQ_Pa_s_per_m3 = tested_residual(physical_solution_, p_out, inlet_lift_) / Q_;
      L.K_vQ_Pa_s_per_m  = tested_residual(physical_solution_, p_out, reed_lift_) / Q_;
      L.K_Qv_Pa_s_per_m  = tested_residual(b, 0.0, inlet_lift_);
      L.K_vv_N_s_per_m   = tested_residual(b, 0.0, reed_lift_);
      L.asymmetry        = std::abs(L.K_Qv_Pa_s_per_m - L.K_vQ_Pa_s_per_m) /
                    std::sqrt(std::abs(L.K_QQ_Pa_s_per_m3 * L.K_vv_N_s_per_m));
      L.A_modal_m2                 = -L.K_vQ_Pa_s_per_m / L.K_QQ_Pa_s_per_m3;
      L.damping_fixed_dp_N_s_per_m = L.K_vv_N_s_per_m - L.K_Qv_Pa_s_per_m * L.K_vQ_Pa_s_per_m / L.K_QQ_Pa_s_per_m3;
      // Solve (b)'s integrals: the outflow against the volume the reed sweeps.
      const FlowIntegrals f = evaluate(b, 0.0);
      L.outflow_b_m3_per_s  = f.outlet_flux_m3_per_s;
      L.reed_force_b_N      = f.reed_force_N[2];
      // The discrete motion's flux (where the reed meets a fixed wall, the
      // wall's DoFs hold it at zero).
      L.swept_flow_m3_per_s = inflow(reed_lift_, mesher::reed);
      L.mass_balance_b_rel_error = std::abs(L.outflow_b_m3_per_s - L.swept_flow_m3_per_s) /
                                   std::max(std::abs(L.swept_flow_m3_per_s), 1e-300);
      lap("loading: forces");
      if (motion_->added_mass)
        {
          const PotentialFlow pf = solve_potential_flow(*triangulation_, mapping_, motion_->shape, comm_);
          L.added_mass_kg          = rho_ * pf.energy_integral;
          L.added_mass_boundary_kg = rho_ * pf.boundary_integral;
          L.potential_dofs         = pf.n_dofs;
        }
      for (double v : {L.K_QQ_Pa_s_per_m3, L.K_Qv_Pa_s_per_m, L.K_vQ_Pa_s_per_m, L.K_vv_N_s_per_m, L.added_mass_kg})
        if (!std::isfinite(v))
          throw std::runtime_error("the fluid loading is not finite (" + result_.solver + ", " +
                                   std::to_string(result_.n_dofs) + " DoFs); nothing is reported");
      L.computed     = true;
      L.solve_time_s = seconds_since(t);
      lap("loading: added mass");
    }

    void StokesProblem::store(const FlowIntegrals &s)
    {
      StokesResult &r = result_;
      r.R_gradient_dissipation_Pa_s_per_m3 = s.gradient_dissipation_W / (Q_ * Q_);
      r.kinetic_energy_flux_W              = s.kinetic_energy_flux_W;
      r.inlet_area_m2                      = s.inlet_area_m2;
      r.outlet_area_m2                     = s.outlet_area_m2;
      r.inlet_pressure_Pa                  = s.inlet_pressure_times_area / s.inlet_area_m2;
      r.outlet_pressure_Pa                 = s.outlet_pressure_times_area / s.outlet_area_m2;
      r.inlet_flux_m3_per_s                = s.inlet_flux_m3_per_s;
      r.outlet_flux_m3_per_s               = s.outlet_flux_m3_per_s;
      r.mass_balance_rel_error             = std::abs(s.outlet_flux_m3_per_s - s.inlet_flux_m3_per_s) / Q_;
      r.R_pressure_Pa_s_per_m3             = (r.inlet_pressure_Pa - r.outlet_pressure_Pa) / Q_;
      r.R_dissipation_Pa_s_per_m3          = s.dissipation_W / (Q_ * Q_);
      for (int d = 0; d < 3; ++d)
        r.reed_force_N[d] = s.reed_force_N[d];
      r.A_eff_m2 = r.reed_force_N[2] / (r.inlet_pressure_Pa - r.outlet_pressure_Pa);
      for (double v : {r.R_pressure_Pa_s_per_m3, r.R_dissipation_Pa_s_per_m3, r.mass_balance_rel_error, r.A_eff_m2})
        if (!std::isfinite(v))
          throw std::runtime_error("the Stokes solution gives a non-finite result (" + r.solver + ", " +
                                   std::to_string(r.n_dofs) + " DoFs); nothing is reported");
    }

    // Navier-Stokes: Newton steps from the Stokes flow until R settles.
    void StokesProblem::newton_iteration()
    {
      double change = 1;
      while (change > settings_.newton_tolerance)
        {
          if (result_.newton_iterations == static_cast<unsigned>(settings_.newton_max_iterations))
            throw std::runtime_error("Newton's method for Navier-Stokes did not converge in " +
                                     std::to_string(settings_.newton_max_iterations) + " steps (relative change " +
                                     format_number(change) + "; Re too high for a steady flow?)");
          state_                = solution_;
          const double previous = result_.R_pressure_Pa_s_per_m3;
          auto         t        = Clock::now();
          assemble_system(&state_, false);
          result_.assembly_time_s += seconds_since(t);
          t = Clock::now();
          try
            {
              solve(false, false);
            }
          catch (const std::runtime_error &e)
            {
              throw std::runtime_error(std::string(e.what()) + " in Newton step " +
                                       std::to_string(result_.newton_iterations + 1) +
                                       " of Navier-Stokes: the Schur preconditioner ignores convection; at "
                                       "higher Reynolds numbers use [flow] solver = \"direct\"");
            }
          result_.solve_time_s += seconds_since(t);
          make_physical_solution();
          store(evaluate(physical_solution_, settings_.outlet_pressure_Pa));
          ++result_.newton_iterations;
          change = std::abs(result_.R_pressure_Pa_s_per_m3 / previous - 1);
          if (verbose_ && root_)
            std::fprintf(stderr, "  Newton step %u: R %.9e (change %.1e)\n", result_.newton_iterations,
                         result_.R_pressure_Pa_s_per_m3, change);
        }
    }

    void StokesProblem::output_results(const std::filesystem::path &vtu_dir) const
    {
      DataOut<3> data_out;
      data_out.attach_dof_handler(dof_handler_);
      std::vector<std::string> names{"velocity", "velocity", "velocity", "pressure"};
      std::vector<DataComponentInterpretation::DataComponentInterpretation> kinds(
        3, DataComponentInterpretation::component_is_part_of_vector);
      kinds.push_back(DataComponentInterpretation::component_is_scalar);
      data_out.add_data_vector(physical_solution_, names, DataOut<3>::type_dof_data, kinds);
      data_out.build_patches(mapping_);
      // The output folder is made here, once the solution exists.
      if (Utilities::MPI::this_mpi_process(comm_) == 0)
        std::filesystem::create_directories(vtu_dir);
      MPI_Barrier(comm_);
      data_out.write_vtu_with_pvtu_record(vtu_dir.string() + "/", "flow", 0, comm_, 0, 0);
    }

    StokesResult StokesProblem::run(const std::filesystem::path &vtu_dir)
    {
      make_grid();
      setup_system();
      auto t = Clock::now();
      assemble_system(nullptr, gap_schur_);
      result_.assembly_time_s = seconds_since(t);
      lap("flow: assembly");
      t = Clock::now();
      solve(motion_ != nullptr, ports_.size() > 1);
      result_.solve_time_s = seconds_since(t);
      lap(direct_ ? "flow: solve (MUMPS)" : "flow: solve (FGMRES)");
      split_flow();
      make_physical_solution();
      store(evaluate(physical_solution_, settings_.outlet_pressure_Pa));
      result_.stokes_R_Pa_s_per_m3                      = result_.R_pressure_Pa_s_per_m3;
      result_.stokes_R_gradient_dissipation_Pa_s_per_m3 = result_.R_gradient_dissipation_Pa_s_per_m3;
      if (motion_ != nullptr)
        compute_loading();
      if (settings_.navier_stokes)
        newton_iteration();
      {
        // Each port's flow and pressure drop (of the Stokes flow's split).
        for (std::size_t k = 0; k < ports_.size(); ++k)
          {
            PortFlow    p;
            const auto &c = ports_[k].frame.centre;
            p.centre_m    = {c[0], c[1], c[2]};
            p.area_m2     = ports_[k].area;
            p.round       = ports_[k].round;
            p.flow_m3_per_s = port_flow_[k];
            // the solution's residual tested with the port's unit-flux profile
            p.pressure_drop_Pa = tested_residual(physical_solution_, settings_.outlet_pressure_Pa, port_lift_[k]);
            result_.ports.push_back(p);
          }
      }
      if (!vtu_dir.empty())
        output_results(vtu_dir);
      result_.wall_time_s = seconds_since(start_);
      return result_;
    }
  } // namespace

  StokesResult solve_stokes(const mesher::TetMesh &mesh, const FlowParameters &parameters,
                            const std::filesystem::path &vtu_dir, bool verbose, const ReedMotion *motion,
                            MPI_Comm comm)
  {
    const auto  &s  = parameters.settings;
    const double mu = parameters.fluid.viscosity_Pa_s;
    const double Q  = s.flow_rate_m3_per_s;
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
    if (motion != nullptr && !motion->shape)
      throw InputError("the reed's motion for the fluid loading has no shape");
    StokesProblem problem(mesh, parameters, verbose, motion, comm); // throws InputError without an inlet
    return problem.run(vtu_dir);
  }

  std::pair<double, double> added_mass(const mesher::TetMesh &mesh, const std::function<double(double, double)> &shape,
                                       double density_kg_per_m3)
  {
    Triangulation<3> triangulation;
    mesher::fill_triangulation(mesh, triangulation);
    const MappingFE<3>  mapping(FE_SimplexP<3>(1));
    const PotentialFlow pf = solve_potential_flow(triangulation, mapping, shape, MPI_COMM_SELF);
    return {density_kg_per_m3 * pf.energy_integral, density_kg_per_m3 * pf.boundary_integral};
  }
} // namespace rectify::stokes
