"""The linear algebra of the compiled steady solver (numba): the bordered block system.

The Newton matrix of the steady state is bordered block-diagonal (a 6 x 6 block per sphere, one
offset per nut): :func:`factorise` factors the shifted sphere blocks (:func:`lu_factor`, partial
pivoting, as LAPACK's ``gesv``) and forms each nut's Schur complement once per set of blocks;
:func:`newton_step` eliminates the blocks with those factors (:func:`lu_solve`), at a cost
linear in the sphere count. Used by :mod:`ballscrew_twin.kernels.steady_solver` (whose
dependency stamp covers this file). Dimensionless: the rows are scaled residuals.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .solver_settings import DIAGONAL_SHIFT


@njit(cache=True, error_model="numpy")
def lu_factor(a, perm):
    """LU factors of one n x n matrix with partial pivoting, in place: ``a`` becomes the unit
    lower factor (below the diagonal) and the upper one, ``perm`` (n,) the row order.

    Returns False when a pivot is exactly zero (singular, as LAPACK's ``gesv`` behind
    ``np.linalg.solve``), the factors then undefined.
    """
    n = a.shape[0]
    for r in range(n):
        perm[r] = r
    for k in range(n):
        pivot = k
        best = abs(a[k, k])
        for r in range(k + 1, n):
            if abs(a[r, k]) > best:
                best = abs(a[r, k])
                pivot = r
        if pivot != k:
            for c in range(n):
                a[k, c], a[pivot, c] = a[pivot, c], a[k, c]
            perm[k], perm[pivot] = perm[pivot], perm[k]
        if a[k, k] == 0.0:
            return False
        for r in range(k + 1, n):
            a[r, k] /= a[k, k]
            for c in range(k + 1, n):
                a[r, c] -= a[r, k] * a[k, c]
    return True


@njit(cache=True, error_model="numpy")
def lu_solve(a, perm, rhs, out):
    """Solve A x = rhs into ``out`` with the factors ``a``, ``perm`` of :func:`lu_factor`."""
    n = a.shape[0]
    for r in range(n):
        out[r] = rhs[perm[r]]
    for r in range(n):  # forward substitution, unit lower factor
        for c in range(r):
            out[r] -= a[r, c] * out[c]
    for r in range(n - 1, -1, -1):  # back substitution
        for c in range(r + 1, n):
            out[r] -= a[r, c] * out[c]
        out[r] /= a[r, r]


@njit(cache=True, error_model="numpy")
def factorise(jac, nut, free, lu, perm, inv_e, schur):
    """Factors of the Newton matrix with the sphere blocks ``jac`` (B, 7, 7), for
    :func:`newton_step`: each shifted block's LU factors into ``lu`` (B, free, free) and
    ``perm`` (B, free), J_i^-1 C_i into ``inv_e`` (B, free) and each nut's Schur complement
    S_k = sum_i (G_i (1 + DIAGONAL_SHIFT) - A_i J_i^-1 C_i) into ``schur`` (2,).

    Sphere blocks are shifted by DIAGONAL_SHIFT |diagonal| and the nut terms scaled by
    (1 + DIAGONAL_SHIFT), as the reference's ``_damped_step``; only the first ``free`` unknowns
    of each sphere move (the rates are frozen at zero speed). The factors serve every step
    taken with the same blocks (computed once per solve when they are reused).

    Returns:
        False when a sphere block is exactly singular.
    """
    rhs_e = np.empty(free)
    schur[0] = 0.0
    schur[1] = 0.0
    for i in range(jac.shape[0]):
        block = lu[i]
        for r in range(free):
            shift = DIAGONAL_SHIFT * (abs(jac[i, r, r]) + 1e-30)
            for c in range(free):
                block[r, c] = jac[i, r, c]
            block[r, r] += shift
            rhs_e[r] = jac[i, r, 6]
        if not lu_factor(block, perm[i]):
            return False
        lu_solve(block, perm[i], rhs_e, inv_e[i])
        k = nut[i]
        schur[k] += jac[i, 6, 6] * (1.0 + DIAGONAL_SHIFT)
        for r in range(free):
            schur[k] -= jac[i, 6, r] * inv_e[i, r]
    return True


@njit(cache=True, error_model="numpy")
def newton_step(res, nut_res, jac, nut, free, lu, perm, inv_e, schur, inv_r, dz, de):
    """Newton step of the bordered system with the sphere blocks eliminated (Schur complement),
    from the factors of :func:`factorise`: de_k = (-g_k + sum_i A_i J_i^-1 r_i) / S_k,
    dz_i = -(J_i^-1 r_i + J_i^-1 C_i de_k). Writes dz (B, 6) and de (2,); ``inv_r`` (B, free)
    is scratch."""
    count = res.shape[0]
    coupling = np.zeros(2)
    for i in range(count):
        lu_solve(lu[i], perm[i], res[i, :free], inv_r[i])
        k = nut[i]
        for r in range(free):
            coupling[k] += jac[i, 6, r] * inv_r[i, r]
    for k in range(2):
        rhs = -nut_res[k] + coupling[k]
        de[k] = rhs / schur[k] if schur[k] != 0.0 else 0.0
    for i in range(count):
        for r in range(6):
            dz[i, r] = -(inv_r[i, r] + inv_e[i, r] * de[nut[i]]) if r < free else 0.0
