"""The symmetric pencil K x = omega^2 M x with a dense, possibly ill-conditioned mass matrix.

Generalised coordinates give a full mass matrix M, and mechanisms with very unequal
masses or lengths make it ill-conditioned: Vieille's double pendulum (1849) with m = 1e-3,
m' = 1e3, a = 1, b = 1e-3 has cond(M) ~ 1e12. Forming M^-1/2 K M^-1/2 from an
eigendecomposition of M (the path of `vibra.normal_modes`) then loses up to 12 digits of the
lowest frequencies. This module keeps them:

1. Diagonal equilibration. With D = diag(M)^-1/2, M_s = D M D has a unit diagonal; a
   kinetic energy whose conditioning comes from the units or sizes of the coordinates
   (angles of long and short rods) becomes well conditioned. M is accepted when
   the Cholesky factorisation M_s = L L^T succeeds and cond(M_s) < 1 / (n eps): it is refused
   only when singular or indefinite to working precision, with its condition number.
2. When K is positive definite, K_s = D K D is equilibrated and factored the same way,
   K_s = R^T R, and the squared frequencies are the squared singular values of
   G = R L^-T, computed by one-sided Jacobi (LAPACK gejsv) after a pivoted QR that moves
   the grading of K_s to one side (see `_jacobi`): every frequency to a relative accuracy
   of about eps (cond(M_s) + cond(K_s)), the small ones not measured against the large
   ones ("pencil-jacobi"). Pencils graded by diagonal scalings over 1e-6..1e6 on both M and K
   (cond up to 1e24) keep 15 digits.
3. Otherwise (K indefinite or singular) the equilibrated pencil (K_s, M_s) is solved by
   LAPACK sygv ("pencil-cholesky"), accurate to eps * ||L^-1 K_s L^-T|| absolutely.

The error figure reported per mode is first-order perturbation theory for relative
perturbations of the entries of K_s and M_s of a few ulps:
|d(omega^2)| <= c n eps (cond(M_s) + cond(K_s)) omega^2 on the Jacobi path, plus the
absolute term c n eps ||L^-1 K_s L^-T|| on the Cholesky path: honest, and for the double
pendulum above within about 30 times of the true error.
"""

from __future__ import annotations

from vibra.solvers.structured.equilibrated import (
    check_mass_matrix, equilibrated_cholesky, pencil_result, scaled_condition,
)

__all__ = ["check_mass_matrix", "scaled_condition", "equilibrated_cholesky", "pencil_result"]
