#include "vadsim/cvode_solver.hpp"

#include <cvode/cvode_ls.h>

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
}

int CvodeSolver::step(double tout, double& tret) {
  const int flag = CVode(h_.mem, tout, h_.y, &tret, CV_ONE_STEP);
  check(flag, "CVode", tret);
  t_last_ = tret;
  return flag;
}

void CvodeSolver::interpolate(double t, N_Vector out) const {
  check(CVodeGetDky(h_.mem, t, 0, out), "CVodeGetDky", t);
}

const int* CvodeSolver::roots_found() {
  check(CVodeGetRootInfo(h_.mem, roots_), "CVodeGetRootInfo", t_last_);
  return roots_;
}

}  // namespace vadsim
