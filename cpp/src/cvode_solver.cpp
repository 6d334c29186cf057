#include "vadsim/cvode_solver.hpp"

#include <cvode/cvode_ls.h>

#include <cmath>
#include <limits>

#include "vadsim/fast_kernels.hpp"

namespace vadsim {

void CvodeSolver::error_handler(int, const char* module, const char* function, char* msg,
                                void* data) {
  auto* self = static_cast<CvodeSolver*>(data);
  self->last_error_ = std::string(module ? module : "") + "::" + (function ? function : "") +
                      ": " + (msg ? msg : "");
}

void CvodeSolver::check(int flag, const char* call, double t) const {
  if (flag < 0) throw SolverError(call, t, flag, last_error_);
}

CvodeSolver::CvodeSolver(int n_roots, Method method, double rtol, const State& atol,
                         void* user_data, CVRhsFn rhs, CVLsJacFn jac, CVRootFn roots)
    : n_roots_(n_roots) {
  auto need = [](const void* p, const char* call) {
    if (!p) throw SolverError(call, 0.0, 0, "allocation failed");
  };
  if (n_roots < 0 || n_roots > kMaxRoots)
    throw SolverError("CVodeRootInit", 0, 0, "at most 10 root functions");
  if (SUNContext_Create(nullptr, &h_.ctx) != 0) throw SolverError("SUNContext_Create", 0, 0, "");
  need(h_.y = N_VNew_Serial(kState, h_.ctx), "N_VNew_Serial");
  install_fast_vector_ops(h_.y);
  need(h_.work = N_VClone(h_.y), "N_VClone");
  need(h_.atol = N_VClone(h_.y), "N_VClone");
  need(h_.capture = N_VCloneEmpty(h_.y), "N_VCloneEmpty");
  h_.capture->content = &nordsieck_;
  h_.capture->ops->nvlinearcombination = &CvodeSolver::record_columns;
  for (int i = 0; i < kState; ++i) NV_Ith_S(h_.atol, i) = atol[i];
  N_VConst(0.0, h_.y);
  need(h_.A = SUNDenseMatrix(kState, kState, h_.ctx), "SUNDenseMatrix");
  install_fast_matrix_ops(h_.A);
  need(h_.LS = make_schur_lu_solver(h_.ctx), "SUNLinSolNewEmpty");
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
  if (capture) N_VFreeEmpty(capture);  // its content is the solver's, not a serial vector
  if (y) N_VDestroy(y);
  if (ctx) SUNContext_Free(&ctx);
}

void CvodeSolver::set_max_step(double h) {
  check(CVodeSetMaxStep(h_.mem, h), "CVodeSetMaxStep", t_last_);
}

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
    check(c.get(h_.mem, &v), c.call, t_last_);
    s.*c.field += v;
  }
  return s;
}

void CvodeSolver::restart(double t0, const State& y0, double t_stop) {
  for (int i = 0; i < kState; ++i) NV_Ith_S(h_.y, i) = y0[i];
  if (initialised_) {
    fold_stats();
    done_.reinits += 1;
  }
  t_last_ = t0;
  check(CVodeReInit(h_.mem, t0, h_.y), "CVodeReInit", t0);
  initialised_ = true;
  check(CVodeSetStopTime(h_.mem, t_stop), "CVodeSetStopTime", t0);
  nordsieck_.current = false;
}

int CvodeSolver::step(double tout, double& tret) {
  const int flag = CVode(h_.mem, tout, h_.y, &tret, CV_ONE_STEP);
  check(flag, "CVode", tret);
  t_last_ = tret;
  nordsieck_.current = false;
  return flag;
}

int CvodeSolver::record_columns(int n, sunrealtype*, N_Vector* X, N_Vector z) {
  auto* nd = static_cast<Nordsieck*>(z->content);
  nd->seen_n = n;
  for (int i = 0; i < n && i < Nordsieck::kMaxColumns; ++i) nd->seen[i] = NV_DATA_S(X[i]);
  return 0;
}

bool CvodeSolver::load_nordsieck() const {
  Nordsieck& nd = nordsieck_;
  check(CVodeGetCurrentTime(h_.mem, &nd.tn), "CVodeGetCurrentTime", t_last_);
  // After a step CVODE's h is the step just taken (cvCompleteStep sets hu = h; a new h is
  // applied only when the next step starts): the h that CVodeGetDky divides by.
  check(CVodeGetLastStep(h_.mem, &nd.hu), "CVodeGetLastStep", t_last_);
  check(CVodeGetLastOrder(h_.mem, &nd.q), "CVodeGetLastOrder", t_last_);
  nd.h = nd.hu;
  if (nd.q < 0 || nd.q >= Nordsieck::kMaxColumns || !(nd.h != 0)) return false;
  if (nd.q > nd.captured) {
    nd.seen_n = 0;
    check(CVodeGetDky(h_.mem, nd.tn, 0, h_.capture), "CVodeGetDky", nd.tn);
    if (nd.seen_n != nd.q + 1) return false;  // not the sum CVodeGetDky is known to form
    for (int j = 0; j <= nd.q; ++j) nd.zn[j] = nd.seen[nd.q - j];
    nd.captured = nd.q;
  }
  nd.current = true;
  return true;
}

void CvodeSolver::interpolate(double t, N_Vector out) const {
  Nordsieck& nd = nordsieck_;
  if (own_dense_output_ && (nd.current || load_nordsieck())) {
    // CVodeGetDky's window, with its slack: outside it CVODE reports the error below.
    const double fuzz = 100.0 * std::numeric_limits<double>::epsilon() *
                        (std::abs(nd.tn) + std::abs(nd.hu)) * (nd.hu < 0 ? -1.0 : 1.0);
    const double tp = nd.tn - nd.hu - fuzz, tn1 = nd.tn + fuzz;
    if (!((t - tp) * (t - tn1) > 0)) {
      evaluate_interpolant(t, nd.tn, nd.h, nd.q, nd.zn, NV_DATA_S(out));
      return;
    }
  }
  check(CVodeGetDky(h_.mem, t, 0, out), "CVodeGetDky", t);
}

void CvodeSolver::evaluate_interpolant(double t, double tn, double h, int q,
                                      const double* const* zn, double* out) {
  const double s = (t - tn) / h;
  double c[kMaxColumns];
  const double* x[kMaxColumns];
  int n = 0;
  for (int j = q; j >= 0; --j, ++n) {
    c[n] = 1.0;
    for (int i = 0; i < j; ++i) c[n] *= s;
    x[n] = zn[j];
  }
  linear_combination(n, c, x, out);
}

bool CvodeSolver::last_interpolant(StepInterpolant& out) const {
  Nordsieck& nd = nordsieck_;
  if (!own_dense_output_ || !(nd.current || load_nordsieck())) return false;
  out.tn = nd.tn;
  out.h = nd.h;
  out.q = nd.q;
  for (int j = 0; j <= nd.q; ++j) out.zn[j] = nd.zn[j];
  return true;
}

void CvodeSolver::interpolate_with_cvode(double t, N_Vector out) const {
  check(CVodeGetDky(h_.mem, t, 0, out), "CVodeGetDky", t);
}

int CvodeSolver::last_order() const {
  int q = 0;
  check(CVodeGetLastOrder(h_.mem, &q), "CVodeGetLastOrder", t_last_);
  return q;
}

const int* CvodeSolver::roots_found() {
  check(CVodeGetRootInfo(h_.mem, roots_), "CVodeGetRootInfo", t_last_);
  return roots_;
}

}  // namespace vadsim
