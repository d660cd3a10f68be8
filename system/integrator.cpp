#include "system/integrator.h"

#include <Eigen/Dense>
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <stdexcept>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

namespace rectify::system
{
  namespace
  {
    void check(int flag, const char *call)
    {
      if (flag < 0)
        throw std::runtime_error(std::string("CVODE: ") + call + " failed: " +
                                 CVodeGetReturnFlagName(flag));
    }

    int rhs_callback(sunrealtype t, N_Vector y, N_Vector ydot, void *user)
    {
      auto             *sys = static_cast<OdeSystem *>(user);
      const std::size_t n   = sys->n_states();
      sys->rhs(t, {N_VGetArrayPointer(y), n}, {N_VGetArrayPointer(ydot), n});
      return 0;
    }

    int jac_callback(sunrealtype t, N_Vector y, N_Vector, SUNMatrix J, void *user, N_Vector,
                     N_Vector, N_Vector)
    {
      auto             *sys = static_cast<OdeSystem *>(user);
      const std::size_t n   = sys->n_states();
      SUNMatZero(J);
      sys->jacobian(t, {N_VGetArrayPointer(y), n}, DenseView{SM_DATA_D(J), n});
      return 0;
    }

    int root_callback(sunrealtype t, N_Vector y, sunrealtype *g, void *user)
    {
      auto *sys = static_cast<OdeSystem *>(user);
      sys->roots(t, {N_VGetArrayPointer(y), sys->n_states()}, {g, sys->n_roots()});
      return 0;
    }
    // A dense direct linear solver on Eigen's LU with partial pivoting. For
    // the model's 17 states it is about twice as fast as SUNDIALS' own dense
    // solver as Debian builds it (the solve dominates a step's cost); up to
    // 32 states in fixed-capacity storage, above (a finely segmented outlet
    // line: 46 states with twelve sections) on the heap, where SUNDIALS'
    // solves had taken a quarter of a run's time (docs/benchmarks.md).
    template <int Capacity>
    struct EigenDense
    {
      using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, Capacity, Capacity>;
      using Vector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, Capacity, 1>;
      Eigen::PartialPivLU<Matrix> lu;
      sunindextype                last_flag = 0;

      static EigenDense *of(SUNLinearSolver s) { return static_cast<EigenDense *>(s->content); }
    };

    template <int Capacity>
    SUNLinearSolver make_eigen_dense_solver(SUNContext context, sunindextype n)
    {
      using Content = EigenDense<Capacity>;
      if (Capacity != Eigen::Dynamic && n > Capacity)
        return nullptr;
      SUNLinearSolver s = SUNLinSolNewEmpty(context);
      if (!s)
        return nullptr;
      s->content        = new Content{};
      s->ops->gettype   = [](SUNLinearSolver) { return SUNLINEARSOLVER_DIRECT; };
      s->ops->getid     = [](SUNLinearSolver) { return SUNLINEARSOLVER_CUSTOM; };
      s->ops->initialize = [](SUNLinearSolver) { return int(SUNLS_SUCCESS); };
      s->ops->setup     = [](SUNLinearSolver ls, SUNMatrix A) {
        const auto                                   n = SM_COLUMNS_D(A);
        Eigen::Map<const typename Content::Matrix> M(SM_DATA_D(A), n, n);
        Content::of(ls)->lu.compute(M);
        const double smallest = Content::of(ls)->lu.matrixLU().diagonal().cwiseAbs().minCoeff();
        Content::of(ls)->last_flag = smallest > 0 ? 0 : 1;
        return smallest > 0 ? int(SUNLS_SUCCESS) : int(SUNLS_LUFACT_FAIL);
      };
      s->ops->solve = [](SUNLinearSolver ls, SUNMatrix A, N_Vector x, N_Vector b, sunrealtype) {
        const auto                                   n = SM_COLUMNS_D(A);
        Eigen::Map<const typename Content::Vector> rhs(N_VGetArrayPointer(b), n);
        Eigen::Map<typename Content::Vector>       sol(N_VGetArrayPointer(x), n);
        sol = Content::of(ls)->lu.solve(rhs);
        return int(SUNLS_SUCCESS);
      };
      s->ops->lastflag = [](SUNLinearSolver ls) { return Content::of(ls)->last_flag; };
      s->ops->free     = [](SUNLinearSolver ls) {
        if (ls == nullptr)
          return int(SUNLS_SUCCESS);
        delete Content::of(ls);
        ls->content = nullptr;
        SUNLinSolFreeEmpty(ls);
        return int(SUNLS_SUCCESS);
      };
      return s;
    }
  } // namespace

  IntegratorStats &IntegratorStats::operator+=(const IntegratorStats &o)
  {
    steps += o.steps;
    rhs_evaluations += o.rhs_evaluations;
    jacobian_evaluations += o.jacobian_evaluations;
    rhs_evaluations_for_fd_jacobian += o.rhs_evaluations_for_fd_jacobian;
    nonlinear_iterations += o.nonlinear_iterations;
    nonlinear_convergence_failures += o.nonlinear_convergence_failures;
    error_test_failures += o.error_test_failures;
    root_function_evaluations += o.root_function_evaluations;
    events += o.events;
    reinitialisations += o.reinitialisations;
    return *this;
  }

  struct Integrator::Impl
  {
    OdeSystem      &system;
    SUNContext      context = nullptr;
    N_Vector        y       = nullptr;
    N_Vector        atol    = nullptr;
    SUNMatrix       matrix  = nullptr;
    SUNLinearSolver solver  = nullptr;
    void           *cvode   = nullptr;
    IntegratorStats finished; // counters of the segments before the last reinit
    long            events = 0, reinits = 0;

    explicit Impl(OdeSystem &s)
      : system(s)
    {}

    ~Impl()
    {
      if (cvode)
        CVodeFree(&cvode);
      if (solver)
        SUNLinSolFree(solver);
      if (matrix)
        SUNMatDestroy(matrix);
      if (atol)
        N_VDestroy(atol);
      if (y)
        N_VDestroy(y);
      if (context)
        SUNContext_Free(&context);
    }

    /// Restarts CVODE at (t, y) after a change of state or tolerances,
    /// keeping the counters. With a fraction of the last step rather than
    /// CVODE's cautious estimate: events (a reed on its seat) come many times
    /// a cycle, and each restart would otherwise climb from a tiny step.
    void restart(double t)
    {
      IntegratorStats done = current();
      done.events = done.reinitialisations = 0;
      finished += done;
      ++reinits;
      sunrealtype h_last = 0;
      check(CVodeGetLastStep(cvode, &h_last), "CVodeGetLastStep");
      check(CVodeReInit(cvode, t, y), "CVodeReInit");
      if (h_last > 0)
        check(CVodeSetInitStep(cvode, 0.1 * h_last), "CVodeSetInitStep");
    }

    IntegratorStats current() const
    {
      IntegratorStats s;
      CVodeGetNumSteps(cvode, &s.steps);
      CVodeGetNumRhsEvals(cvode, &s.rhs_evaluations);
      CVodeGetNumJacEvals(cvode, &s.jacobian_evaluations);
      CVodeGetNumLinRhsEvals(cvode, &s.rhs_evaluations_for_fd_jacobian);
      CVodeGetNumNonlinSolvIters(cvode, &s.nonlinear_iterations);
      CVodeGetNumNonlinSolvConvFails(cvode, &s.nonlinear_convergence_failures);
      CVodeGetNumErrTestFails(cvode, &s.error_test_failures);
      CVodeGetNumGEvals(cvode, &s.root_function_evaluations);
      return s;
    }
  };

  Integrator::Integrator(OdeSystem &system, double t0, std::span<const double> y0,
                         const IntegratorOptions &options)
    : impl_(std::make_unique<Impl>(system))
    , t_(t0)
  {
    const auto n = static_cast<sunindextype>(system.n_states());
    if (y0.size() != system.n_states() || options.absolute_tolerances.size() != y0.size())
      throw std::logic_error("Integrator: state or tolerance size mismatch");
    Impl &m = *impl_;
    check(SUNContext_Create(nullptr, &m.context), "SUNContext_Create");
    m.y    = N_VNew_Serial(n, m.context);
    m.atol = N_VNew_Serial(n, m.context);
    if (!m.y || !m.atol)
      throw std::runtime_error("CVODE: cannot allocate vectors");
    std::copy(y0.begin(), y0.end(), N_VGetArrayPointer(m.y));
    std::copy(options.absolute_tolerances.begin(), options.absolute_tolerances.end(),
              N_VGetArrayPointer(m.atol));

    m.cvode = CVodeCreate(CV_BDF, m.context);
    if (!m.cvode)
      throw std::runtime_error("CVODE: CVodeCreate failed");
    if (options.quiet)
      check(CVodeSetErrFile(m.cvode, nullptr), "CVodeSetErrFile");
    check(CVodeInit(m.cvode, rhs_callback, t0, m.y), "CVodeInit");
    check(CVodeSetUserData(m.cvode, &system), "CVodeSetUserData");
    check(CVodeSVtolerances(m.cvode, options.relative_tolerance, m.atol), "CVodeSVtolerances");
    m.matrix = SUNDenseMatrix(n, n, m.context);
    // Eigen's LU: fixed capacity up to 32 states (every model but a finely
    // segmented outlet line), on the heap above
    m.solver = n <= 32 ? make_eigen_dense_solver<32>(m.context, n) :
                         make_eigen_dense_solver<Eigen::Dynamic>(m.context, n);
    if (!m.matrix || !m.solver)
      throw std::runtime_error("CVODE: cannot allocate the dense linear solver");
    check(CVodeSetLinearSolver(m.cvode, m.solver, m.matrix), "CVodeSetLinearSolver");
    if (!options.finite_difference_jacobian)
      check(CVodeSetJacFn(m.cvode, jac_callback), "CVodeSetJacFn");
    check(CVodeSetMaxNumSteps(m.cvode, options.max_steps_between_outputs), "CVodeSetMaxNumSteps");
    if (options.max_order > 0)
      check(CVodeSetMaxOrd(m.cvode, options.max_order), "CVodeSetMaxOrd");
    if (system.n_roots() > 0)
      {
        check(CVodeRootInit(m.cvode, static_cast<int>(system.n_roots()), root_callback),
              "CVodeRootInit");
        std::vector<int> directions(system.n_roots(), -1);
        check(CVodeSetRootDirection(m.cvode, directions.data()), "CVodeSetRootDirection");
      }
  }

  Integrator::~Integrator() = default;

  std::span<const double> Integrator::state() const
  {
    return {N_VGetArrayPointer(impl_->y), impl_->system.n_states()};
  }

  IntegratorStats Integrator::stats() const
  {
    IntegratorStats s = impl_->finished;
    s += impl_->current();
    s.events            = impl_->events;
    s.reinitialisations = impl_->reinits;
    return s;
  }

  void Integrator::set_tolerances(double relative, std::span<const double> absolute)
  {
    Impl &m = *impl_;
    if (absolute.size() != m.system.n_states())
      throw std::logic_error("Integrator: tolerance size mismatch");
    std::copy(absolute.begin(), absolute.end(), N_VGetArrayPointer(m.atol));
    check(CVodeSVtolerances(m.cvode, relative, m.atol), "CVodeSVtolerances");
    // CVODE sets up its error weights for new tolerances only when it
    // (re)starts: restart here, as after an event.
    m.restart(t_);
  }

  void Integrator::advance_to(double t_out)
  {
    Impl            &m = *impl_;
    std::vector<int> found(m.system.n_roots());
    while (t_ < t_out)
      {
        sunrealtype t    = t_;
        const int   flag = CVode(m.cvode, t_out, m.y, &t, CV_NORMAL);
        check(flag, "CVode");
        t_ = t;
        if (flag != CV_ROOT_RETURN)
          continue;
        check(CVodeGetRootInfo(m.cvode, found.data()), "CVodeGetRootInfo");
        ++m.events;
        std::span<double> y(N_VGetArrayPointer(m.y), m.system.n_states());
        if (m.system.handle_events(t_, y, found))
          m.restart(t_);
      }
  }
} // namespace rectify::system
