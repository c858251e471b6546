r"""Fast RLS on a tapped delay line: the QR-decomposition least-squares lattice.

The kernels of ``FastRLS(method="lattice")``, split from :mod:`._fastrls` (the
FTF), which re-exports :func:`lattice_run` and :func:`lattice_run_batched`.

State of one stream, ``S`` of length 7n + 2 (+ n² + n with the θ track)::

    S = [ theta (n) | xf (n) | eps (n+1) | c (n) | s (n) | yq (n) | x (n) | efor
          | R (n·n, row-major upper triangle) | z (n) ]

``xf`` the transformed forward prediction variables, ``eps`` the normalised
a-posteriori backward prediction errors of orders 0..n-1 and, last, the square
root of the conversion factor γ; ``c``, ``s`` the rotation angles; ``yq`` the
rotated reference (the tap multipliers of the normalised lattice); ``efor`` the
square root of the forward prediction-error energy (Regalia & Bellanger 1991;
SLICOT FD01AD, whose variable names these are). ``R``, ``z``: the square-root
information array of the same problem (Givens QRD-RLS, McWhirter 1983) from
which θ = R⁻¹z is read when the θ track is on (``opt[2] != 0``).
``opt = [lambda, delta, track]``; ``theta0`` the prior mean (y − θ₀ᵀφ enters
the lattice).
"""

import numpy as np
from numba import prange

from ..._config import NJIT, NJIT_INLINE, NJIT_PARALLEL, njit


@njit(**NJIT_INLINE)
def _givens(a, b):
    """(c, s, r): c·a + s·b = r ≥ 0, −s·a + c·b = 0 for a ≥ 0 (LAPACK dlartg's)."""
    r = np.sqrt(a * a + b * b)
    if r == 0.0:
        return 1.0, 0.0, 0.0
    return a / r, b / r, r


@njit(**NJIT_INLINE)
def _forward(S, n, f, ls):
    """The forward prediction rotations of the input f; returns the order-n error."""
    xf, c, s = n, 3 * n + 1, 4 * n + 1
    for i in range(n):
        t = S[xf + i] * ls
        S[xf + i] = S[s + i] * f + S[c + i] * t
        f = S[c + i] * f - S[s + i] * t
    return f


@njit(**NJIT_INLINE)
def _joint(S, n, g, ls):
    """The joint-process rotations of the reference g; returns the a-priori error."""
    c, s, yq = 3 * n + 1, 4 * n + 1, 5 * n + 1
    for i in range(n):
        t = S[yq + i] * ls
        S[yq + i] = S[s + i] * g + S[c + i] * t
        g = S[c + i] * g - S[s + i] * t
    return g / S[2 * n + n]


@njit(**NJIT_INLINE)
def _joint_forward(S, n, g, f, ls):
    """:func:`_joint` of the previous sample and :func:`_forward` of this one in one
    loop: both rotate by the same angles, and their two chains of dependent
    multiply-adds overlap (the same operations as the two loops, in the same order).
    Returns (a-priori error of the previous sample, forward error of this one)."""
    xf, c, s, yq = n, 3 * n + 1, 4 * n + 1, 5 * n + 1
    for i in range(n):
        ci, si = S[c + i], S[s + i]
        t = S[xf + i] * ls
        S[xf + i] = si * f + ci * t
        f = ci * f - si * t
        t = S[yq + i] * ls
        S[yq + i] = si * g + ci * t
        g = ci * g - si * t
    return g / S[2 * n + n], f


@njit(**NJIT_INLINE)
def _reflect(S, n, f, ls, W):
    """Reflection rotations, new backward errors; W[2n+1+i] = Σ_{j≥i} eps_j² (j < n).

    The rotation of stage i has r_i = sqrt(Q_i), Q_i = efor² + Σ_{j≥i} xf_j² (the
    running sum of squares, so the chain from stage to stage is one multiply-add,
    not a square root), cos = r_(i+1)/r_i and sin = xf_i/r_i by one reciprocal.
    """
    xf, ep = n, 2 * n
    efor = S[7 * n + 1] * ls
    t = np.sqrt(f * f + efor * efor)
    f = f * S[ep + n] / t if t > 0.0 else 0.0
    S[7 * n + 1] = t
    q = t * t
    rp = t
    u = 0.0
    W[3 * n + 1] = 0.0
    for i in range(n - 1, -1, -1):
        x = S[xf + i]
        q = x * x + q
        r = np.sqrt(q)
        inv = np.true_divide(1.0, r)  # inf at r = 0, not selected below
        ok = r != 0.0
        cc = rp * inv if ok else 1.0
        ss = x * inv if ok else 0.0
        e = S[ep + i]
        e1 = cc * e - ss * f
        S[ep + i + 1] = e1
        f = cc * f + ss * e
        if i < n - 1:
            u = e1 * e1 + u
            W[2 * n + 2 + i] = u
        rp = r
    S[ep] = f
    W[2 * n + 1] = f * f + u


@njit(**NJIT_INLINE)
def _angles(S, n, W):
    """New rotation angles from the backward errors (vectorised: no chain).

    r_i = sqrt(T_n + Σ_{j≥i} eps_j²), T_n = max(0, 1 − Σ_j eps_j²) (r_n = √γ),
    cos_i = r_(i+1)/r_i, sin_i = eps_i/r_i by one reciprocal.
    """
    ep, c, s = 2 * n, 3 * n + 1, 4 * n + 1
    tn = max(0.0, 1.0 - W[2 * n + 1])
    for i in range(n + 1):
        W[i] = np.sqrt(tn + W[2 * n + 1 + i])
    for i in range(n):
        W[n + 1 + i] = np.true_divide(1.0, W[i])  # inf at r = 0, not selected below
    for i in range(n):
        S[c + i] = W[i + 1] * W[n + 1 + i] if W[i] != 0.0 else 1.0
    for i in range(n):
        S[s + i] = S[ep + i] * W[n + 1 + i] if W[i] != 0.0 else 0.0
    S[ep + n] = W[n]


@njit(**NJIT)
def _qr_track(S, n, yk, ls):
    """Rotate the row [φ_k, y_k] into the square-root information array (R, z)."""
    R, z, x = 7 * n + 2, 7 * n + 2 + n * n, 6 * n + 1
    for i in range(n * n + n):
        S[R + i] *= ls
    # the working row lives in theta's slots (θ is recomputed below)
    for j in range(n):
        S[j] = S[x + j]
    w = yk
    for i in range(n):
        cc, ss, r = _givens(S[R + i * n + i], S[i])
        S[R + i * n + i] = r
        for j in range(i + 1, n):
            a = S[R + i * n + j]
            S[R + i * n + j] = cc * a + ss * S[j]
            S[j] = cc * S[j] - ss * a
        a = S[z + i]
        S[z + i] = cc * a + ss * w
        w = cc * w - ss * a
    for i in range(n - 1, -1, -1):  # θ = R⁻¹ z
        v = S[z + i]
        for j in range(i + 1, n):
            v -= S[R + i * n + j] * S[j]
        S[i] = v / S[R + i * n + i]


@njit(**NJIT)
def lattice_run(S, u, y, opt, theta0, Th, E, skipped):
    """Run the QR lattice over u, y from state S (in place); as :func:`ftf_run`.

    Without the θ track (``opt[2] == 0``) θ stays θ₀ and ``Th`` must have 0 rows.
    Returns 0 (the lattice has no rescue). The joint process of a sample is
    run with the forward rotations of the next one (:func:`_joint_forward`),
    and the last one's after the loop: the same operations, overlapped.
    """
    n = theta0.shape[0]
    ls = np.sqrt(opt[0])
    track = opt[2] != 0.0
    store = Th.shape[0] > 0
    prior = False
    for i in range(n):
        prior = prior or theta0[i] != 0.0
    x = 6 * n + 1
    W = np.empty(3 * n + 2)
    kp = -1  # the sample whose joint process is pending
    yp = 0.0
    for k in range(u.shape[0]):
        uk, yk = u[k], y[k]
        if not (np.isfinite(uk) and np.isfinite(yk)):
            skipped[k] = True
            E[k] = np.nan
        else:
            skipped[k] = False
            for i in range(n - 1, 0, -1):
                S[x + i] = S[x + i - 1]
            S[x] = uk
            if kp >= 0:
                E[kp], f = _joint_forward(S, n, yp, uk, ls)
            else:
                f = _forward(S, n, uk, ls)
            _reflect(S, n, f, ls, W)
            _angles(S, n, W)
            kp = k
            yp = yk
            if prior:
                for i in range(n):
                    yp -= theta0[i] * S[x + i]
            if track:
                _qr_track(S, n, yk, ls)
        if store:
            for i in range(n):
                Th[k, i] = S[i]
    if kp >= 0:
        E[kp] = _joint(S, n, yp, ls)
    return 0


@njit(**NJIT_PARALLEL)
def lattice_run_batched(S, U, Y, opt, theta0, Th, E, skipped, rescues):
    """B independent streams of :func:`lattice_run` in parallel (leading axis B)."""
    for b in prange(U.shape[0]):
        rescues[b] = lattice_run(S[b], U[b], Y[b], opt, theta0, Th[b], E[b], skipped[b])
