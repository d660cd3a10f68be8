#include "system/integrator.h"

#include "system/serial_vector_ops.h"

#include <Eigen/Dense>
#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cvode/cvode.h>
#include <dlfcn.h>
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

    /// What CVODE's callbacks reach through user_data: the system and, for
    /// the linear system formed here, CVODE's memory, the saved Jacobian and
    /// the difference quotients' colouring.
    struct Callbacks
    {
      OdeSystem      *system = nullptr;
      void           *cvode  = nullptr;
      bool            difference_quotients = false;
      Eigen::MatrixXd J;                 ///< the Jacobian of the last evaluation
      N_Vector        weights = nullptr; ///< CVODE's error weights, copied for each Jacobian
      /// colours[c]: columns perturbed together; rows[j]: the components that read state j
      std::vector<std::vector<std::size_t>> colours, rows;
      std::vector<double>                   increments;
      long                                  evaluations = 0; ///< f evaluations for Jacobians
    };

    OdeSystem &system_of(void *user) { return *static_cast<Callbacks *>(user)->system; }

    int rhs_callback(sunrealtype t, N_Vector y, N_Vector ydot, void *user)
    {
      auto             &sys = system_of(user);
      const std::size_t n   = sys.n_states();
      sys.rhs(t, {N_VGetArrayPointer(y), n}, {N_VGetArrayPointer(ydot), n});
      return 0;
    }

    int jac_callback(sunrealtype t, N_Vector y, N_Vector, SUNMatrix J, void *user, N_Vector,
                     N_Vector, N_Vector)
    {
      auto             &sys = system_of(user);
      const std::size_t n   = sys.n_states();
      SUNMatZero(J);
      sys.jacobian(t, {N_VGetArrayPointer(y), n}, DenseView{SM_DATA_D(J), n});
      return 0;
    }

    /// CVODE's dense difference-quotient Jacobian (cvLsDenseDQJac, SUNDIALS
    /// 6.4), its increments and arithmetic unchanged, into cb.J, with the
    /// columns of one colour perturbed in one evaluation of f: no component
    /// reads two of them, so each of its entries is the quotient CVODE forms
    /// alone. tmp1, tmp2: work vectors.
    int difference_jacobian(Callbacks &cb, sunrealtype t, N_Vector y, N_Vector fy, N_Vector tmp1, N_Vector tmp2)
    {
      const std::size_t n = cb.system->n_states();
      if (CVodeGetErrWeights(cb.cvode, cb.weights) < 0)
        return -1;
      // CVODE's step size while it sets up (after any rescaling): next_h
      // equals h there (cvRescale, cvDoErrorTest)
      sunrealtype h = 0;
      if (CVodeGetCurrentStep(cb.cvode, &h) < 0)
        return -1;
      const sunrealtype uround = SUN_UNIT_ROUNDOFF;
      const sunrealtype srur   = std::sqrt(uround);
      const sunrealtype fnorm  = N_VWrmsNorm(fy, cb.weights);
      const sunrealtype min_increment =
        fnorm != 0.0 ? 1000.0 * std::abs(h) * uround * static_cast<sunrealtype>(n) * fnorm : 1.0;
      const double *ewt = N_VGetArrayPointer(cb.weights);
      const double *f0  = N_VGetArrayPointer(fy);
      const double *f   = N_VGetArrayPointer(tmp1);
      const double *y0  = N_VGetArrayPointer(y);
      N_VScale(1.0, y, tmp2);
      double *yp = N_VGetArrayPointer(tmp2);
      for (const auto &colour : cb.colours)
        {
          for (std::size_t j : colour)
            {
              cb.increments[j] = std::max(srur * std::abs(y0[j]), min_increment / ewt[j]);
              yp[j] += cb.increments[j];
            }
          cb.system->rhs(t, {yp, n}, {N_VGetArrayPointer(tmp1), n});
          ++cb.evaluations;
          for (std::size_t j : colour)
            {
              yp[j]                = y0[j];
              const double inverse = 1.0 / cb.increments[j];
              for (std::size_t i : cb.rows[j])
                cb.J(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = inverse * (f[i] - f0[i]);
            }
        }
      return 0;
    }

    /// A = I - gamma J for CVODE's Newton iteration, J re-evaluated unless
    /// CVODE finds the saved one good enough (jok): what CVODE's own
    /// cvLsLinSys computes (zero, evaluate, save; or copy the saved one;
    /// then scale and add I), entry for entry, in one pass over J.
    int linear_system_callback(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix A, sunbooleantype jok,
                               sunbooleantype *jcur, sunrealtype gamma, void *user, N_Vector tmp1, N_Vector tmp2,
                               N_Vector)
    {
      auto             &cb = *static_cast<Callbacks *>(user);
      const std::size_t n  = cb.system->n_states();
      *jcur                = !jok;
      if (!jok)
        {
          cb.J.setZero();
          if (cb.difference_quotients)
            {
              if (const int flag = difference_jacobian(cb, t, y, fy, tmp1, tmp2); flag != 0)
                return flag;
            }
          else
            cb.system->jacobian(t, {N_VGetArrayPointer(y), n}, DenseView{cb.J.data(), n});
        }
      Eigen::Map<Eigen::MatrixXd> M(SM_DATA_D(A), static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
      M.noalias() = (-gamma) * cb.J;
      M.diagonal().array() += 1.0;
      return 0;
    }

    /// Greedy colouring of the columns: a column joins the first colour none
    /// of whose columns shares a reading component with it. Columns no
    /// component reads are left out (zero). Without `reads`, every column
    /// alone and read by every component (CVODE's own quotients).
    void colour_columns(const std::vector<std::vector<std::size_t>> &reads, std::size_t n, Callbacks &cb)
    {
      cb.rows.assign(n, {});
      cb.colours.clear();
      cb.increments.assign(n, 0.0);
      if (reads.empty())
        {
          for (std::size_t j = 0; j < n; ++j)
            {
              cb.colours.push_back({j});
              for (std::size_t i = 0; i < n; ++i)
                cb.rows[j].push_back(i);
            }
          return;
        }
      if (reads.size() != n)
        throw std::logic_error("Integrator: rhs_reads has one entry per state");
      for (std::size_t i = 0; i < reads.size(); ++i)
        for (std::size_t j : reads[i])
          {
            if (j >= n)
              throw std::logic_error("Integrator: rhs_reads names a state beyond n_states");
            if (cb.rows[j].empty() || cb.rows[j].back() != i)
              cb.rows[j].push_back(i);
          }
      std::vector<std::vector<char>> used; // used[c][i]: colour c's columns are read by component i
      for (std::size_t j = 0; j < n; ++j)
        {
          if (cb.rows[j].empty())
            continue;
          std::size_t c = 0;
          for (; c < used.size(); ++c)
            if (std::none_of(cb.rows[j].begin(), cb.rows[j].end(), [&](std::size_t i) { return used[c][i]; }))
              break;
          if (c == used.size())
            {
              used.emplace_back(n, 0);
              cb.colours.emplace_back();
            }
          cb.colours[c].push_back(j);
          for (std::size_t i : cb.rows[j])
            used[c][i] = 1;
        }
    }

    int root_callback(sunrealtype t, N_Vector y, sunrealtype *g, void *user)
    {
      auto &sys = system_of(user);
      sys.roots(t, {N_VGetArrayPointer(y), sys.n_states()}, {g, sys.n_roots()});
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
    Callbacks       callbacks;
    SUNContext      context = nullptr;
    N_Vector        y       = nullptr;
    N_Vector        atol    = nullptr;
    SUNMatrix       matrix  = nullptr;
    SUNLinearSolver solver  = nullptr;
    void           *cvode   = nullptr;
    IntegratorStats finished; // counters of the segments before the last reinit
    long            events = 0, reinits = 0;
    long            max_steps = 0; ///< per output interval and segment between events (CVODE's mxstep)

    explicit Impl(OdeSystem &s)
      : system(s)
    {
      callbacks.system = &s;
    }

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
      if (callbacks.weights)
        N_VDestroy(callbacks.weights);
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
    if (!options.library_vector_ops)
      { // before CVodeInit, which clones its own vectors from y
        use_optimised_serial_ops(m.y);
        use_optimised_serial_ops(m.atol);
      }
    std::copy(y0.begin(), y0.end(), N_VGetArrayPointer(m.y));
    std::copy(options.absolute_tolerances.begin(), options.absolute_tolerances.end(),
              N_VGetArrayPointer(m.atol));

    m.cvode = CVodeCreate(CV_BDF, m.context);
    if (!m.cvode)
      throw std::runtime_error("CVODE: CVodeCreate failed");
    if (options.quiet)
      check(CVodeSetErrFile(m.cvode, nullptr), "CVodeSetErrFile");
    check(CVodeInit(m.cvode, rhs_callback, t0, m.y), "CVodeInit");
    m.callbacks.cvode = m.cvode;
    check(CVodeSetUserData(m.cvode, &m.callbacks), "CVodeSetUserData");
    check(CVodeSVtolerances(m.cvode, options.relative_tolerance, m.atol), "CVodeSVtolerances");
    m.matrix = SUNDenseMatrix(n, n, m.context);
    // Eigen's LU: fixed capacity up to 32 states (every model but a finely
    // segmented outlet line), on the heap above
    m.solver = n <= 32 ? make_eigen_dense_solver<32>(m.context, n) :
                         make_eigen_dense_solver<Eigen::Dynamic>(m.context, n);
    if (!m.matrix || !m.solver)
      throw std::runtime_error("CVODE: cannot allocate the dense linear solver");
    check(CVodeSetLinearSolver(m.cvode, m.solver, m.matrix), "CVodeSetLinearSolver");
    if (options.cvode_linear_system)
      { // CVODE's own: its cvLsLinSys, with its column-by-column quotients or our Jacobian
        if (!options.finite_difference_jacobian)
          check(CVodeSetJacFn(m.cvode, jac_callback), "CVodeSetJacFn");
      }
    else
      {
        m.callbacks.difference_quotients = options.finite_difference_jacobian;
        m.callbacks.J                    = Eigen::MatrixXd::Zero(n, n);
        if (options.finite_difference_jacobian)
          {
            colour_columns(system.rhs_reads(), system.n_states(), m.callbacks);
            m.callbacks.weights = N_VNew_Serial(n, m.context);
            if (!m.callbacks.weights)
              throw std::runtime_error("CVODE: cannot allocate vectors");
            if (!options.library_vector_ops)
              use_optimised_serial_ops(m.callbacks.weights);
          }
        check(CVodeSetLinSysFn(m.cvode, linear_system_callback), "CVodeSetLinSysFn");
      }
    check(CVodeSetMaxNumSteps(m.cvode, options.max_steps_between_outputs), "CVodeSetMaxNumSteps");
    m.max_steps = options.max_steps_between_outputs;
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
    s.rhs_evaluations_for_fd_jacobian += impl_->callbacks.evaluations;
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
    // CVODE's step limit holds per call; a root that changes nothing ends a
    // call without ending the segment, so the limit is kept here across them
    long segment_start = m.current().steps;
    while (t_ < t_out)
      {
        sunrealtype t    = t_;
        const int   flag = CVode(m.cvode, t_out, m.y, &t, CV_NORMAL);
        check(flag, "CVode");
        t_ = t;
        if (m.current().steps - segment_start > m.max_steps)
          throw std::runtime_error("CVODE: CVode failed: CV_TOO_MUCH_WORK (more than " + std::to_string(m.max_steps) +
                                   " steps toward the next output time)");
        if (flag != CV_ROOT_RETURN)
          continue;
        check(CVodeGetRootInfo(m.cvode, found.data()), "CVodeGetRootInfo");
        std::span<double> y(N_VGetArrayPointer(m.y), m.system.n_states());
        if (m.system.handle_events(t_, y, found))
          { // an event; a root that changes nothing (one the system only logs) is not one
            ++m.events;
            m.restart(t_);
            segment_start = m.current().steps;
          }
      }
  }

  std::string cvode_library()
  {
    Dl_info info{};
    if (dladdr(reinterpret_cast<void *>(&CVodeCreate), &info) == 0 || info.dli_fname == nullptr)
      return "unknown";
    char resolved[PATH_MAX];
    return realpath(info.dli_fname, resolved) != nullptr ? resolved : info.dli_fname;
  }
} // namespace rectify::system
