"""Least squares by normal equations, for the irradiance factorisation.

:func:`aquaspec.transport.lightfield.compiled.irradiance_factors` fits the
logarithm of the irradiance table (``n`` bands by ``P = n_depth n_mu`` nodes,
8-64 by a few thousand) with alternating least squares: 40 sweeps of two
solves, with ``2 + rank`` and ``rank`` unknowns (``rank`` 4-8), for each rank
tried. With :func:`numpy.linalg.lstsq` (an SVD of the ``P x (2 + rank)``
matrix per solve, 175-257 calls per setup) that took 0.7-4.9 s on a loaded
2-core host, most of it multi-threaded BLAS overhead (a 4160 x 6 lstsq: 7 ms
threaded, 0.4 ms on one thread). Here each solve forms the small Gram matrix
``A^T A`` and its right-hand side (one matrix product over ``P``) and solves
the ``k x k`` system, and the starting point (the leading rows of an SVD)
comes from the eigendecomposition of the ``n x n`` matrix ``R R^T``: 10-160 ms
per rank on the same host (the choice in a 640 x 360 render: 0.11-0.16 s with
lstsq, 16-30 ms).

Why this is safe here: normal equations square the condition number, so a
solve loses about ``eps cond(A)^2`` relative accuracy where lstsq loses
``eps cond(A)`` (plus ``eps cond(A)^2 tan(theta)`` for a large residual,
which lstsq shares). The unknowns are first scaled to unit column norm
(Jacobi), which removes the disparity of scales (the column of ones, depths
to 100 m, functions scaled by singular values); what is left is small,
because the columns are far from collinear (ones against depth; the
functions start orthogonal and the sweeps keep them near it). Measured on
the tables (Jerlov I, IB, II, 3C, 7C; 8, 16 and 32 bands; overcast and
sun-sky; with and without a seabed; ranks 4-8; 64 x 65 nodes) every scaled
Gram matrix had a condition number below 7, and the fitted irradiance
agreed with the lstsq version to 4e-13 of the table's largest value (the
factors to 2e-9 of their largest). The guard: a Gram matrix whose scaled
condition number exceeds :data:`GRAM_CONDITION_LIMIT` (``eps`` times it is
2e-8) is solved by :func:`numpy.linalg.lstsq` instead. The start's
eigenvectors are resolved to about ``eps`` over the relative gap after the
last one kept; measured gaps were 1e-9 to 3e-4 of the largest eigenvalue,
and below :data:`SUBSPACE_GAP_LIMIT` the start is :func:`numpy.linalg.svd`'s
(the sweeps then refine it either way).
"""

from __future__ import annotations

import numpy as np

#: Largest condition number of a (scaled) Gram matrix solved by its normal
#: equations; above it the solve is a :func:`numpy.linalg.lstsq`.
GRAM_CONDITION_LIMIT = 1e8
#: Smallest gap ``lambda_rank - lambda_{rank+1}`` between the eigenvalues of
#: ``R R^T``, relative to the largest, for which :func:`leading_rows` takes
#: the eigenvectors; below it the subspace comes from an SVD of ``R``.
SUBSPACE_GAP_LIMIT = 1e-9


def normal_lstsq(a, b) -> np.ndarray:
    """``x`` minimising ``||a x - b||`` column by column, as ``numpy.linalg.lstsq(a, b)[0]``.

    ``a`` (M, k) with ``M >> k``, ``b`` (M, m): the ``k x k`` normal
    equations with the unknowns scaled to unit column norm of ``a``, solved
    through an eigendecomposition that also gives their condition number;
    beyond :data:`GRAM_CONDITION_LIMIT` (or with a zero column) the
    :func:`numpy.linalg.lstsq` solve.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    gram = a.T @ a
    norm = np.sqrt(np.diag(gram))
    if np.all(norm > 0) and np.all(np.isfinite(gram)):
        scale = 1.0 / norm
        lam, q = np.linalg.eigh(gram * scale[:, None] * scale[None, :])
        if lam[0] * GRAM_CONDITION_LIMIT > lam[-1]:
            rhs = scale[:, None] * (a.T @ b)
            return scale[:, None] * (q @ ((q.T @ rhs) / lam[:, None]))
    return np.linalg.lstsq(a, b, rcond=None)[0]


def leading_rows(r, rank: int) -> np.ndarray:
    """The first ``rank`` rows of ``S V^T`` for the SVD ``r = U S V^T`` of ``r`` (n, P), ``n < P``.

    From the eigendecomposition of ``r r^T = U S^2 U^T`` as ``U_rank^T r``;
    the sign of each row is fixed by its largest entry of ``U`` (positive).
    An SVD when the gap after the ``rank``-th eigenvalue is under
    :data:`SUBSPACE_GAP_LIMIT` of the largest.
    """
    r = np.asarray(r, dtype=float)
    lam, u = np.linalg.eigh(r @ r.T)
    lam, u = lam[::-1], u[:, ::-1]
    following = lam[rank] if rank < lam.size else 0.0
    if lam[rank - 1] - following > SUBSPACE_GAP_LIMIT * lam[0]:
        u = u[:, :rank]
    else:
        u, _, _ = np.linalg.svd(r, full_matrices=False)
        u = u[:, :rank]
    u = u * np.sign(u[np.argmax(np.abs(u), axis=0), np.arange(rank)])
    return u.T @ r
