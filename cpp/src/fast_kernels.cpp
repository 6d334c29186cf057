#include "vadsim/fast_kernels.hpp"

#include <algorithm>
#include <cmath>

namespace vadsim {

bool SchurLU::factor(const double* a) {
  constexpr int n = kDof;
  auto at = [a](int i, int j) { return a[j * kState + i]; };
  gamma_ = -at(0, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      a21_[i][j] = at(n + i, j);
      lu_[i][j] = at(n + i, n + j) + gamma_ * a21_[i][j];
    }
  for (int i = 0; i < n; ++i) perm_[i] = i;
  for (int k = 0; k < n; ++k) {
    int p = k;
    double best = std::abs(lu_[k][k]);
    for (int i = k + 1; i < n; ++i) {
      const double v = std::abs(lu_[i][k]);
      if (v > best) {
        best = v;
        p = i;
      }
    }
    if (!(best > 0)) return false;
    if (p != k) {
      for (int j = 0; j < n; ++j) std::swap(lu_[k][j], lu_[p][j]);
      std::swap(perm_[k], perm_[p]);
    }
    const double inv = 1.0 / lu_[k][k];
    for (int i = k + 1; i < n; ++i) {
      const double l = lu_[i][k] * inv;
      lu_[i][k] = l;
      for (int j = k + 1; j < n; ++j) lu_[i][j] -= l * lu_[k][j];
    }
  }
  return true;
}

void SchurLU::solve(const double* b, double* x) const {
  constexpr int n = kDof;
  double r[n], y[n], dv[n];
  for (int i = 0; i < n; ++i) {
    double s = b[n + i];
    for (int j = 0; j < n; ++j) s -= a21_[i][j] * b[j];
    r[i] = s;
  }
  for (int i = 0; i < n; ++i) {
    double s = r[perm_[i]];
    for (int j = 0; j < i; ++j) s -= lu_[i][j] * y[j];
    y[i] = s;
  }
  for (int i = n - 1; i >= 0; --i) {
    double s = y[i];
    for (int j = i + 1; j < n; ++j) s -= lu_[i][j] * dv[j];
    dv[i] = s / lu_[i][i];
  }
  for (int i = 0; i < n; ++i) {
    x[i] = b[i] + gamma_ * dv[i];
    x[n + i] = dv[i];
  }
}

namespace {

// The SUNLinearSolver op table around SchurLU.
SUNLinearSolver_Type schur_type(SUNLinearSolver) { return SUNLINEARSOLVER_DIRECT; }
SUNLinearSolver_ID schur_id(SUNLinearSolver) { return SUNLINEARSOLVER_CUSTOM; }
int schur_init(SUNLinearSolver) { return SUNLS_SUCCESS; }

int schur_setup(SUNLinearSolver S, SUNMatrix A) {
  auto* c = static_cast<SchurLU*>(S->content);
  // A zero pivot is recoverable: CVODE retries with a smaller step.
  return c->factor(SM_DATA_D(A)) ? SUNLS_SUCCESS : SUNLS_LUFACT_FAIL;
}

int schur_solve(SUNLinearSolver S, SUNMatrix, N_Vector x, N_Vector b, sunrealtype) {
  static_cast<const SchurLU*>(S->content)->solve(NV_DATA_S(b), NV_DATA_S(x));
  return SUNLS_SUCCESS;
}

sunindextype schur_lastflag(SUNLinearSolver) { return 0; }

int schur_free(SUNLinearSolver S) {
  if (!S) return SUNLS_SUCCESS;
  delete static_cast<SchurLU*>(S->content);
  S->content = nullptr;
  SUNLinSolFreeEmpty(S);
  return SUNLS_SUCCESS;
}

// Fixed-size kernels for the 14-long serial vectors.
constexpr int kMaxCombination = 16;
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
  const double* x[kMaxCombination];
  if (n > kMaxCombination) {
    // Longer than any Nordsieck array CVODE keeps (order 12 + 1): not reached, but correct.
    State acc = c[0] * cm(X[0]);
    for (int i = 1; i < n; ++i) acc += c[i] * cm(X[i]);
    vm(z) = acc;
    return 0;
  }
  for (int i = 0; i < n; ++i) x[i] = NV_DATA_S(X[i]);
  linear_combination(n, c, x, NV_DATA_S(z));
  return 0;
}
int fast_scaleaddmulti(int n, sunrealtype* a, N_Vector x, N_Vector* Y, N_Vector* Z) {
  const State xv = cm(x);
  for (int i = 0; i < n; ++i) vm(Z[i]) = a[i] * xv + cm(Y[i]);
  return 0;
}

// Fixed-size kernels for the 14x14 dense matrices.
int fast_mat_copy(SUNMatrix A, SUNMatrix B) {
  std::copy(SM_DATA_D(A), SM_DATA_D(A) + kState * kState, SM_DATA_D(B));
  return 0;
}
int fast_mat_scaleaddi(sunrealtype c, SUNMatrix A) {
  // A plain loop: as Eigen's m *= c, m.diagonal() += 1 element by element, but GCC otherwise
  // split Eigen's unrolled product differently from one build to the next.
  double* m = SM_DATA_D(A);
  for (int i = 0; i < kState * kState; ++i) m[i] *= c;
  for (int i = 0; i < kState; ++i) m[i * (kState + 1)] += 1.0;
  return 0;
}
SUNMatrix fast_mat_clone(SUNMatrix A) {
  SUNMatrix B = SUNDenseMatrix(SM_ROWS_D(A), SM_COLUMNS_D(A), A->sunctx);
  if (B) install_fast_matrix_ops(B);
  return B;
}

}  // namespace

void linear_combination(int n, const double* c, const double* const* x, double* z) {
  // z may alias x[0]: accumulate in a temporary.
  State acc = c[0] * Eigen::Map<const State>(x[0]);
  for (int i = 1; i < n; ++i) acc += c[i] * Eigen::Map<const State>(x[i]);
  Eigen::Map<State> out(z);
  out = acc;
}

void install_fast_vector_ops(N_Vector v) {
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

void install_fast_matrix_ops(SUNMatrix A) {
  A->ops->copy = fast_mat_copy;
  A->ops->scaleaddi = fast_mat_scaleaddi;
  A->ops->clone = fast_mat_clone;
}

SUNLinearSolver make_schur_lu_solver(SUNContext ctx) {
  SUNLinearSolver S = SUNLinSolNewEmpty(ctx);
  if (!S) return nullptr;
  S->ops->gettype = schur_type;
  S->ops->getid = schur_id;
  S->ops->initialize = schur_init;
  S->ops->setup = schur_setup;
  S->ops->solve = schur_solve;
  S->ops->lastflag = schur_lastflag;
  S->ops->free = schur_free;
  S->content = new SchurLU();
  return S;
}

}  // namespace vadsim
