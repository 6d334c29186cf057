#include "vadsim/cvode_solver.hpp"

#include <cvode/cvode_ls.h>

#include <algorithm>
#include <cmath>

namespace vadsim {

namespace {

/// @brief Newton solves through the 7x7 Schur complement of the second-order structure.
///
/// With y = [u; v] the Jacobian is [[0, I], [K, C]], so CVODE's Newton matrix is
/// A = I - g J = [[I, -g I], [A21, A22]] with A21 = -g K, A22 = I - g C. Eliminating the
/// first block row leaves S dv = b2 - A21 b1 with S = A22 + g A21, then du = b1 + g dv:
/// one 7x7 LU instead of a 14x14 one. Sizes are compile-time so the loops unroll; SUNDIALS'
/// generic dense LU (built unoptimised by Debian) was a third of a run's instructions.
struct SchurLU {
  static constexpr int n = kDof;
  double lu[n][n];   // factors of S, row-major
  double a21[n][n];  // A21, row-major
  double gamma = 0;
  int perm[n];

  /// @brief Factor from A (column-major, as SUNDIALS stores it); false on a zero pivot.
  bool factor(const double* a) {
    auto at = [a](int i, int j) { return a[j * kState + i]; };
    gamma = -at(0, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        a21[i][j] = at(n + i, j);
        lu[i][j] = at(n + i, n + j) + gamma * a21[i][j];
      }
    for (int i = 0; i < n; ++i) perm[i] = i;
    for (int k = 0; k < n; ++k) {
      int p = k;
      double best = std::abs(lu[k][k]);
      for (int i = k + 1; i < n; ++i) {
        const double v = std::abs(lu[i][k]);
        if (v > best) {
          best = v;
          p = i;
        }
      }
      if (!(best > 0)) return false;
      if (p != k) {
        for (int j = 0; j < n; ++j) std::swap(lu[k][j], lu[p][j]);
        std::swap(perm[k], perm[p]);
      }
      const double inv = 1.0 / lu[k][k];
      for (int i = k + 1; i < n; ++i) {
        const double l = lu[i][k] * inv;
        lu[i][k] = l;
        for (int j = k + 1; j < n; ++j) lu[i][j] -= l * lu[k][j];
      }
    }
    return true;
  }

  /// @brief x = A^{-1} b; x and b may be the same array.
  void solve(const double* b, double* x) const {
    double r[n], y[n], dv[n];
    for (int i = 0; i < n; ++i) {
      double s = b[n + i];
      for (int j = 0; j < n; ++j) s -= a21[i][j] * b[j];
      r[i] = s;
    }
    for (int i = 0; i < n; ++i) {
      double s = r[perm[i]];
      for (int j = 0; j < i; ++j) s -= lu[i][j] * y[j];
      y[i] = s;
    }
    for (int i = n - 1; i >= 0; --i) {
      double s = y[i];
      for (int j = i + 1; j < n; ++j) s -= lu[i][j] * dv[j];
      dv[i] = s / lu[i][i];
    }
    for (int i = 0; i < n; ++i) {
      x[i] = b[i] + gamma * dv[i];
      x[n + i] = dv[i];
    }
  }
};

SUNLinearSolver_Type fixed_lu_type(SUNLinearSolver) { return SUNLINEARSOLVER_DIRECT; }
SUNLinearSolver_ID fixed_lu_id(SUNLinearSolver) { return SUNLINEARSOLVER_CUSTOM; }
int fixed_lu_init(SUNLinearSolver) { return SUNLS_SUCCESS; }

int fixed_lu_setup(SUNLinearSolver S, SUNMatrix A) {
  auto* c = static_cast<SchurLU*>(S->content);
  // A zero pivot is recoverable: CVODE retries with a smaller step.
  return c->factor(SM_DATA_D(A)) ? SUNLS_SUCCESS : SUNLS_LUFACT_FAIL;
}

int fixed_lu_solve(SUNLinearSolver S, SUNMatrix, N_Vector x, N_Vector b, sunrealtype) {
  static_cast<const SchurLU*>(S->content)->solve(NV_DATA_S(b), NV_DATA_S(x));
  return SUNLS_SUCCESS;
}

sunindextype fixed_lu_lastflag(SUNLinearSolver) { return 0; }

int fixed_lu_free(SUNLinearSolver S) {
  if (!S) return SUNLS_SUCCESS;
  delete static_cast<SchurLU*>(S->content);
  S->content = nullptr;
  SUNLinSolFreeEmpty(S);
  return SUNLS_SUCCESS;
}

// Fixed-size kernels for the 14-long serial vectors. Debian's SUNDIALS is built without
// optimisation, and its generic loops were over half of all instructions of a run.
using VMap = Eigen::Map<State>;
using CMap = Eigen::Map<const State>;
inline VMap vm(N_Vector v) { return VMap(NV_DATA_S(v)); }
inline CMap cm(N_Vector v) { return CMap(NV_DATA_S(v)); }

void fast_linearsum(sunrealtype a, N_Vector x, sunrealtype b, N_Vector y, N_Vector z) {
  vm(z) = a * cm(x) + b * cm(y);
}
void fast_const(sunrealtype c, N_Vector z) { vm(z).setConstant(c); }
void fast_prod(N_Vector x, N_Vector y, N_Vector z) { vm(z) = cm(x).cwiseProduct(cm(y)); }
void fast_div(N_Vector x, N_Vector y, N_Vector z) { vm(z) = cm(x).cwiseQuotient(cm(y)); }
void fast_scale(sunrealtype c, N_Vector x, N_Vector z) { vm(z) = c * cm(x); }
void fast_abs(N_Vector x, N_Vector z) { vm(z) = cm(x).cwiseAbs(); }
void fast_inv(N_Vector x, N_Vector z) { vm(z) = cm(x).cwiseInverse(); }
void fast_addconst(N_Vector x, sunrealtype b, N_Vector z) { vm(z) = cm(x).array() + b; }
sunrealtype fast_dotprod(N_Vector x, N_Vector y) { return cm(x).dot(cm(y)); }
sunrealtype fast_maxnorm(N_Vector x) { return cm(x).cwiseAbs().maxCoeff(); }
sunrealtype fast_wsqrsum(N_Vector x, N_Vector w) {
  return cm(x).cwiseProduct(cm(w)).squaredNorm();
}
sunrealtype fast_wrmsnorm(N_Vector x, N_Vector w) {
  return std::sqrt(fast_wsqrsum(x, w) / kState);
}
sunrealtype fast_min(N_Vector x) { return cm(x).minCoeff(); }
void fast_compare(sunrealtype c, N_Vector x, N_Vector z) {
  vm(z) = (cm(x).array().abs() >= c).cast<double>().matrix();
}
int fast_linearcombination(int n, sunrealtype* c, N_Vector* X, N_Vector z) {
  // z may alias X[0]: accumulate in a temporary.
  State acc = c[0] * cm(X[0]);
  for (int i = 1; i < n; ++i) acc += c[i] * cm(X[i]);
  vm(z) = acc;
  return 0;
}
int fast_scaleaddmulti(int n, sunrealtype* a, N_Vector x, N_Vector* Y, N_Vector* Z) {
  const State xv = cm(x);
  for (int i = 0; i < n; ++i) vm(Z[i]) = a[i] * xv + cm(Y[i]);
  return 0;
}

/// @brief Install the fixed-size kernels on a serial vector of length 14; its clones
/// (every vector CVODE allocates from it) copy the table.
void install_fast_ops(N_Vector v) {
  N_Vector_Ops o = v->ops;
  o->nvlinearsum = fast_linearsum;
  o->nvconst = fast_const;
  o->nvprod = fast_prod;
  o->nvdiv = fast_div;
  o->nvscale = fast_scale;
  o->nvabs = fast_abs;
  o->nvinv = fast_inv;
  o->nvaddconst = fast_addconst;
  o->nvdotprod = fast_dotprod;
  o->nvmaxnorm = fast_maxnorm;
  o->nvwrmsnorm = fast_wrmsnorm;
  o->nvwsqrsumlocal = fast_wsqrsum;
  o->nvmin = fast_min;
  o->nvcompare = fast_compare;
  o->nvlinearcombination = fast_linearcombination;
  o->nvscaleaddmulti = fast_scaleaddmulti;
}

int fast_mat_copy(SUNMatrix A, SUNMatrix B) {
  std::copy(SM_DATA_D(A), SM_DATA_D(A) + kState * kState, SM_DATA_D(B));
  return 0;
}
int fast_mat_scaleaddi(sunrealtype c, SUNMatrix A) {
  Eigen::Map<Mat14> m(SM_DATA_D(A));
  m *= c;
  m.diagonal().array() += 1.0;
  return 0;
}

SUNMatrix fast_mat_clone(SUNMatrix A);

/// @brief Install fixed-size kernels on a 14x14 dense matrix; SUNDIALS' dense clone builds a
/// fresh ops table, so clone is overridden too (CVODE clones A to keep the Jacobian).
void install_fast_mat_ops(SUNMatrix A) {
  A->ops->copy = fast_mat_copy;
  A->ops->scaleaddi = fast_mat_scaleaddi;
  A->ops->clone = fast_mat_clone;
}

SUNMatrix fast_mat_clone(SUNMatrix A) {
  SUNMatrix B = SUNDenseMatrix(SM_ROWS_D(A), SM_COLUMNS_D(A), A->sunctx);
  if (B) install_fast_mat_ops(B);
  return B;
}

SUNLinearSolver make_fixed_lu(SUNContext ctx) {
  SUNLinearSolver S = SUNLinSolNewEmpty(ctx);
  if (!S) return nullptr;
  S->ops->gettype = fixed_lu_type;
  S->ops->getid = fixed_lu_id;
  S->ops->initialize = fixed_lu_init;
  S->ops->setup = fixed_lu_setup;
  S->ops->solve = fixed_lu_solve;
  S->ops->lastflag = fixed_lu_lastflag;
  S->ops->free = fixed_lu_free;
  S->content = new SchurLU();
  return S;
}

}  // namespace

void CvodeSolver::error_handler(int, const char* module, const char* function, char* msg,
                                void* data) {
  auto* self = static_cast<CvodeSolver*>(data);
  self->last_error_ = std::string(module ? module : "") + "::" + (function ? function : "") +
                      ": " + (msg ? msg : "");
}

void CvodeSolver::check(int flag, const char* call, double t) const {
  if (flag < 0) throw SolverError(call, t, flag, last_error_);
}

CvodeSolver::CvodeSolver(int n, int n_roots, Method method, double rtol,
                         const Eigen::Ref<const Eigen::VectorXd>& atol, void* user_data,
                         CVRhsFn rhs, CVLsJacFn jac, CVRootFn roots)
    : n_roots_(n_roots) {
  auto need = [](const void* p, const char* call) {
    if (!p) throw SolverError(call, 0.0, 0, "allocation failed");
  };
  if (SUNContext_Create(nullptr, &h_.ctx) != 0) throw SolverError("SUNContext_Create", 0, 0, "");
  if (n != kState) throw SolverError("CvodeSolver", 0, 0, "the kernels are sized for 14 states");
  need(h_.y = N_VNew_Serial(n, h_.ctx), "N_VNew_Serial");
  install_fast_ops(h_.y);
  need(h_.work = N_VClone(h_.y), "N_VClone");
  need(h_.atol = N_VClone(h_.y), "N_VClone");
  for (int i = 0; i < n; ++i) NV_Ith_S(h_.atol, i) = atol[i];
  N_VConst(0.0, h_.y);
  need(h_.A = SUNDenseMatrix(n, n, h_.ctx), "SUNDenseMatrix");
  install_fast_mat_ops(h_.A);
  need(h_.LS = make_fixed_lu(h_.ctx), "SUNLinSolNewEmpty");
  need(h_.mem = CVodeCreate(method == Method::BDF ? CV_BDF : CV_ADAMS, h_.ctx), "CVodeCreate");
  void* mem = h_.mem;
  check(CVodeSetErrHandlerFn(mem, &CvodeSolver::error_handler, this), "CVodeSetErrHandlerFn", 0);
  check(CVodeInit(mem, rhs, 0.0, h_.y), "CVodeInit", 0);
  check(CVodeSVtolerances(mem, rtol, h_.atol), "CVodeSVtolerances", 0);
  check(CVodeSetUserData(mem, user_data), "CVodeSetUserData", 0);
  check(CVodeSetLinearSolver(mem, h_.LS, h_.A), "CVodeSetLinearSolver", 0);
  check(CVodeSetJacFn(mem, jac), "CVodeSetJacFn", 0);
  check(CVodeRootInit(mem, n_roots, roots), "CVodeRootInit", 0);
  // Budgets are enforced by the caller over the whole run, not per call.
  check(CVodeSetMaxNumSteps(mem, -1), "CVodeSetMaxNumSteps", 0);
  check(CVodeSetMaxHnilWarns(mem, -1), "CVodeSetMaxHnilWarns", 0);
  check(CVodeSetNoInactiveRootWarn(mem), "CVodeSetNoInactiveRootWarn", 0);
}

CvodeSolver::Handles::~Handles() {
  if (mem) CVodeFree(&mem);
  if (LS) SUNLinSolFree(LS);
  if (A) SUNMatDestroy(A);
  if (atol) N_VDestroy(atol);
  if (work) N_VDestroy(work);
  if (y) N_VDestroy(y);
  if (ctx) SUNContext_Free(&ctx);
}

void CvodeSolver::set_max_step(double h) { check(CVodeSetMaxStep(h_.mem, h), "CVodeSetMaxStep", 0); }

void CvodeSolver::fold_stats() {
  const SolverStats s = stats();
  done_ = s;
}

SolverStats CvodeSolver::stats() const {
  SolverStats s = done_;
  if (!initialised_) return s;
  using Getter = int (*)(void*, long*);
  struct Counter {
    Getter get;
    long SolverStats::*field;
    const char* call;
  };
  static const Counter counters[] = {
      {CVodeGetNumSteps, &SolverStats::steps, "CVodeGetNumSteps"},
      {CVodeGetNumRhsEvals, &SolverStats::rhs_evals, "CVodeGetNumRhsEvals"},
      {CVodeGetNumJacEvals, &SolverStats::jac_evals, "CVodeGetNumJacEvals"},
      {CVodeGetNumLinSolvSetups, &SolverStats::lin_setups, "CVodeGetNumLinSolvSetups"},
      {CVodeGetNumErrTestFails, &SolverStats::err_test_fails, "CVodeGetNumErrTestFails"},
      {CVodeGetNumNonlinSolvIters, &SolverStats::nonlin_iters, "CVodeGetNumNonlinSolvIters"},
      {CVodeGetNumNonlinSolvConvFails, &SolverStats::nonlin_conv_fails,
       "CVodeGetNumNonlinSolvConvFails"},
      {CVodeGetNumGEvals, &SolverStats::root_evals, "CVodeGetNumGEvals"},
  };
  for (const auto& c : counters) {
    long v = 0;
    check(c.get(h_.mem, &v), c.call, 0);
    s.*c.field += v;
  }
  return s;
}

void CvodeSolver::restart(double t0, const Eigen::Ref<const Eigen::VectorXd>& y0,
                          double t_stop) {
  for (Eigen::Index i = 0; i < y0.size(); ++i) NV_Ith_S(h_.y, i) = y0[i];
  if (initialised_) {
    fold_stats();
    done_.reinits += 1;
  }
  check(CVodeReInit(h_.mem, t0, h_.y), "CVodeReInit", t0);

  initialised_ = true;
  check(CVodeSetStopTime(h_.mem, t_stop), "CVodeSetStopTime", t0);
}

int CvodeSolver::step(double tout, double& tret) {
  const int flag = CVode(h_.mem, tout, h_.y, &tret, CV_ONE_STEP);
  check(flag, "CVode", tret);
  return flag;
}

void CvodeSolver::interpolate(double t, N_Vector out) const {
  check(CVodeGetDky(h_.mem, t, 0, out), "CVodeGetDky", t);
}

const int* CvodeSolver::roots_found() {
  check(CVodeGetRootInfo(h_.mem, roots_), "CVodeGetRootInfo", 0);
  return roots_;
}

}  // namespace vadsim
