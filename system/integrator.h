// CVODE (BDF, Newton, dense direct linear solver) behind a small interface:
// an OdeSystem gives the right-hand side, its Jacobian, root functions and an
// event handler; the Integrator advances it through events (CVodeReInit after
// each state or mode change). Every SUNDIALS return code is checked.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

namespace rectify::system
{
  /// Column-major dense matrix view (the layout of SUNDIALS' dense matrices).
  struct DenseView
  {
    double     *data;
    std::size_t n;
    double     &operator()(std::size_t row, std::size_t col) const { return data[col * n + row]; }
  };

  class OdeSystem
  {
  public:
    virtual ~OdeSystem() = default;
    virtual std::size_t n_states() const = 0;
    /// ydot = f(t, y). Precondition: y.size() == ydot.size() == n_states().
    virtual void rhs(double t, std::span<const double> y, std::span<double> ydot) const = 0;
    /// J = df/dy, all entries written (J arrives zeroed).
    virtual void jacobian(double t, std::span<const double> y, DenseView J) const = 0;
    /// For each component i of f, the states f_i reads (a superset of row
    /// i's nonzeros in df/dy, in any discrete mode); empty: unknown. With it
    /// the difference-quotient Jacobian perturbs states that no f_i reads
    /// together in one evaluation of f (a coloured Jacobian, equal to the
    /// column-by-column one bit for bit).
    virtual std::vector<std::vector<std::size_t>> rhs_reads() const { return {}; }
    /// Root functions; every root is located where its function crosses zero
    /// from above (direction -1).
    virtual std::size_t n_roots() const { return 0; }
    virtual void        roots(double, std::span<const double>, std::span<double>) const {}
    /// Called at a located root (`found[i] != 0` for the roots that fired).
    /// May change y and the system's discrete mode; returns true if it did
    /// (then CVODE restarts there). A root that changes nothing leaves
    /// CVODE's steps as they were.
    virtual bool handle_events(double, std::span<double>, std::span<const int>) { return false; }
  };

  struct IntegratorOptions
  {
    double              relative_tolerance = 1e-6;
    std::vector<double> absolute_tolerances;   ///< one per state
    bool                finite_difference_jacobian = false;
    /// Where CVODE's Newton matrix I - gamma J is formed. false: here, in
    /// one pass over the saved J, its difference quotients (with the
    /// system's rhs_reads()) a colour of columns per evaluation of f. true:
    /// CVODE's own routines (copy, scale, add I; quotients column by
    /// column). The same matrix to the last bit, in more work (the tests
    /// compare the two).
    bool                cvode_linear_system = false;
    /// true: SUNDIALS's own serial vector operations, as Debian builds them
    /// (unoptimised); false: the same operations compiled here
    /// (system/serial_vector_ops.h). The same run to the last bit, slower
    /// (the tests compare the two).
    bool                library_vector_ops = false;
    long                max_steps_between_outputs   = 1000000;
    bool                quiet = false; ///< no CVODE messages on stderr (failures still throw)
    /// Highest BDF order CVODE may use (0: its own, 5). Orders 1-2 are
    /// A-stable; 3-5 are not near the imaginary axis, where a lightly damped
    /// fast mode lies (Model::max_bdf_order).
    int                 max_order = 0;
  };

  /// CVODE counters, summed over every reinitialisation.
  struct IntegratorStats
  {
    long steps = 0, rhs_evaluations = 0, jacobian_evaluations = 0,
         rhs_evaluations_for_fd_jacobian = 0, nonlinear_iterations = 0,
         nonlinear_convergence_failures = 0, error_test_failures = 0,
         root_function_evaluations = 0, events = 0, reinitialisations = 0;
    IntegratorStats &operator+=(const IntegratorStats &other);
  };

  class Integrator
  {
  public:
    Integrator(OdeSystem &system, double t0, std::span<const double> y0,
               const IntegratorOptions &options);
    ~Integrator();
    Integrator(const Integrator &)            = delete;
    Integrator &operator=(const Integrator &) = delete;

    /// Advances to t_out (> time()), handling every event on the way.
    /// Throws std::runtime_error with CVODE's flag name if the solver fails.
    void advance_to(double t_out);

    /// New tolerances from here on (CVODE restarts, as after an event).
    void set_tolerances(double relative, std::span<const double> absolute);

    double                  time() const { return t_; }
    std::span<const double> state() const;
    IntegratorStats         stats() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
    double                t_;
  };

  /// The file this process loaded CVODE from: Debian's library, or the one
  /// scripts/cvode.sh built (`rectify --version` says which).
  std::string cvode_library();
} // namespace rectify::system
