#pragma once
/// @file fast_kernels.hpp
/// @brief Fixed-size replacements for SUNDIALS' generic N_Vector, dense-matrix and dense
/// linear-solver operations on the 14-state problem.
///
/// Debian's SUNDIALS is built without optimisation: its generic vector loops were over half of
/// a run's instructions and its dense LU a third. The kernels below have compile-time sizes so
/// that the compiler unrolls them; they are installed into the op tables of the objects the
/// CVODE wrapper creates, so CVODE itself is unchanged.

#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "vadsim/types.hpp"

namespace vadsim {

/// @brief Newton solves through the 7x7 Schur complement of the second-order structure.
///
/// With y = [u; v] the Jacobian is [[0, I], [K, C]], so CVODE's Newton matrix is
/// A = I - g J = [[I, -g I], [A21, A22]] with A21 = -g K, A22 = I - g C. Eliminating the
/// first block row leaves S dv = b2 - A21 b1 with S = A22 + g A21, then du = b1 + g dv:
/// one 7x7 LU instead of a 14x14 one.
class SchurLU {
 public:
  /// @brief Factor from A (14x14, column-major as SUNDIALS stores it); false on a zero pivot.
  bool factor(const double* a);
  /// @brief x = A^{-1} b; x and b may be the same array.
  void solve(const double* b, double* x) const;

 private:
  double lu_[kDof][kDof];   ///< factors of S, row-major
  double a21_[kDof][kDof];  ///< A21, row-major
  double gamma_ = 0;
  int perm_[kDof];
};

/// @brief z = sum_i c[i] x[i] over 14-long arrays, accumulated in this order (z may alias
/// x[0]). The one kernel behind CVODE's N_VLinearCombination and vadsim's own dense output,
/// so that both round alike.
void linear_combination(int n, const double* c, const double* const* x, double* z);

/// @brief Install the fixed-size kernels on a serial vector of length 14; its clones (every
/// vector CVODE allocates from it) copy the table.
void install_fast_vector_ops(N_Vector v);

/// @brief Install fixed-size copy/scale-add-identity on a 14x14 dense matrix. SUNDIALS' dense
/// clone builds a fresh ops table, so clone is overridden too (CVODE clones A to keep the
/// Jacobian).
void install_fast_matrix_ops(SUNMatrix A);

/// @brief A direct linear solver that factors CVODE's Newton matrix with SchurLU; nullptr if
/// SUNDIALS cannot allocate it. Freed by SUNLinSolFree.
SUNLinearSolver make_schur_lu_solver(SUNContext ctx);

}  // namespace vadsim
