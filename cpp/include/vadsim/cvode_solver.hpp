#pragma once
/// @file cvode_solver.hpp
/// @brief RAII owner of a SUNDIALS context, vectors, dense matrix, linear solver and CVODE
/// memory: nothing leaks when a run throws, every flag is turned into a SolverError naming the
/// call and the time, and the statistics survive the re-initialisation at every contact event.
///
/// It knows nothing of the model or of the event loop: it integrates whatever callbacks it is
/// given, on the 14-state problem the fast kernels are sized for.

#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <string>

#include "vadsim/errors.hpp"
#include "vadsim/results.hpp"
#include "vadsim/run_options.hpp"
#include "vadsim/types.hpp"

namespace vadsim {

/// @brief One CVODE integrator for the 14-state problem with fixed callbacks.
class CvodeSolver {
 public:
  /// @brief Most root functions a problem may have (two per surface).
  static constexpr int kMaxRoots = 2 * kSurfaces;

  /// @brief Creates every SUNDIALS object and sets CVODE up; throws SolverError naming the
  /// call that failed. atol is per state component.
  CvodeSolver(int n_roots, Method method, double rtol, const State& atol, void* user_data,
              CVRhsFn rhs, CVLsJacFn jac, CVRootFn roots);
  ~CvodeSolver() = default;
  CvodeSolver(const CvodeSolver&) = delete;
  CvodeSolver& operator=(const CvodeSolver&) = delete;

  /// @brief Restart from (t0, y0): the first call initialises, later ones re-initialise and
  /// fold the statistics of the previous segment into stats().
  void restart(double t0, const State& y0, double t_stop);
  /// @brief One internal step (CV_ONE_STEP); returns CV_SUCCESS, CV_ROOT_RETURN or
  /// CV_TSTOP_RETURN, throws on failure.
  int step(double tout, double& tret);
  /// @brief The interpolated solution at t within the last step (CVODE's dense output):
  /// the same polynomial, sums and rounding as CVodeGetDky(t, 0), evaluated here from the
  /// Nordsieck array (see Nordsieck).
  void interpolate(double t, N_Vector out) const;
  /// @brief CVodeGetDky(t, 0) itself: the reference interpolate() must equal bit for bit
  /// (ctest dense_output).
  void interpolate_with_cvode(double t, N_Vector out) const;
  /// @brief The order of the last step (CVodeGetLastOrder).
  int last_order() const;

  /// @brief Most columns of a Nordsieck array (Adams order 12 + 1).
  static constexpr int kMaxColumns = 13;
  /// @brief The last step's interpolant as CVODE holds it: y(t) = sum_j s^j zn[j],
  /// s = (t - tn) / h, j = 0..q, valid on [tn - h, tn]. The columns point into CVODE's
  /// memory: copy them before the next step.
  struct StepInterpolant {
    double tn = 0, h = 0;
    int q = -1;
    const double* zn[kMaxColumns] = {};
  };
  /// @brief The last step's interpolant; false where vadsim cannot read the Nordsieck array
  /// (then only CVodeGetDky can interpolate, and no copy of the step can be kept).
  bool last_interpolant(StepInterpolant& out) const;
  /// @brief sum_j s^j zn[j] with s = (t - tn) / h, formed exactly as CVodeGetDky forms it
  /// (the same coefficients, order of terms and kernel): interpolate() and a kept copy of a
  /// step give the same bits.
  static void evaluate_interpolant(double t, double tn, double h, int q,
                                   const double* const* zn, double* out);
  /// @brief Which roots fired at the last CV_ROOT_RETURN: +1 rising, -1 falling, 0 none.
  const int* roots_found();

  void set_max_step(double h);
  /// @brief The solution vector CVODE steps in place.
  N_Vector y() const { return h_.y; }
  /// @brief A scratch vector of the same layout (for interpolation).
  N_Vector work() const { return h_.work; }
  /// @brief Statistics of all finished segments plus the running one.
  SolverStats stats() const;

 private:
  void check(int flag, const char* call, double t) const;
  void fold_stats();
  static void error_handler(int code, const char* module, const char* function, char* msg,
                            void* data);

  /// @brief vadsim's own evaluation of CVODE's interpolant.
  ///
  /// Why: a diagnosis run samples the steady window twice at 20 kHz (the sensor grid and the
  /// summary), some 400,000 interpolations, and Debian's CVODE is compiled without
  /// optimisation, so CVodeGetDky's call overhead was 18 % of such a run. The interpolant is
  /// sum_j s^j zn[j], s = (t - tn) / h, over the Nordsieck array zn[0..q], which CVODE does
  /// not expose; one CVodeGetDky per change of order into a vector whose linear-combination
  /// op only records its arguments (CVODE passes zn[q], ..., zn[0]) gives its columns, which
  /// CVODE allocates once. tn, h and q are read per step through the public getters. The
  /// coefficients and the sum are formed exactly as CVodeGetDky forms them, with the same
  /// kernel (linear_combination), so every sample is bit-identical to CVODE's (ctest
  /// dense_output). Where anything does not fit (an order beyond the columns captured, a t
  /// outside the last step), CVodeGetDky itself answers.
  struct Nordsieck {
    static constexpr int kMaxColumns = CvodeSolver::kMaxColumns;
    const double* zn[kMaxColumns] = {};     ///< data of zn[0..captured]
    int captured = -1;                      ///< highest column captured
    bool current = false;                   ///< tn, h, q hold for the last step
    double tn = 0, h = 0, hu = 0;
    int q = 0;
    // What the recording op saw in the last CVodeGetDky into the capture vector.
    int seen_n = 0;
    const double* seen[kMaxColumns] = {};
  };
  /// @brief Reads tn, h and q of the last step, capturing columns when q grew; false when the
  /// capture did not give what CVodeGetDky is documented to sum (then CVodeGetDky is used).
  bool load_nordsieck() const;
  static int record_columns(int n, sunrealtype* c, N_Vector* X, N_Vector z);

  /// @brief The SUNDIALS objects; a member, so a constructor that throws half-way still
  /// frees what it had created.
  struct Handles {
    SUNContext ctx = nullptr;
    N_Vector y = nullptr, work = nullptr, atol = nullptr;
    N_Vector capture = nullptr;  ///< content-less vector whose only op records columns
    SUNMatrix A = nullptr;
    SUNLinearSolver LS = nullptr;
    void* mem = nullptr;
    Handles() = default;
    Handles(const Handles&) = delete;
    Handles& operator=(const Handles&) = delete;
    ~Handles();
  } h_;
  int n_roots_;
  bool initialised_ = false;
  double t_last_ = 0;  ///< the latest time CVODE reached: the time of a getter's failure
  SolverStats done_;
  std::string last_error_;
  int roots_[kMaxRoots] = {};
  mutable Nordsieck nordsieck_;
  bool own_dense_output_ = true;
};

}  // namespace vadsim
