r"""What differs between the forms in the structure-of-arrays kernels (:mod:`._soa`).

The form tags ``UD`` and ``COV`` (global tuples) and the helpers that choose the
form's code: the lane steps (:mod:`._soa_ud`, :mod:`._soa_cov`), loading and
storing a lane's state, the per-sample factor Rc, and the rerun of a lane by the
form's scalar kernel.
"""

from ..._config import njit
from ._soa_cov import cov_lane_load, cov_lane_steps, cov_lane_store, cov_rerun
from ._soa_lanes import INL
from ._soa_ud import ud_lane_load, ud_lane_steps, ud_lane_store

_INL = INL
#: the form tags (compared with ``==`` in the helpers below)
UD = (0,)
COV = (0, 0)


# --- what differs between the forms ---
# Each helper tests ``form == COV``. Once the kernel's form (a global tuple) is
# inlined down to the test, numba's dead-branch pruning removes the other branch
# before typing: only one form's code is compiled (checked by hand: a call of an
# undefined function in the covariance branch does not stop the U-D kernel compiling).
# Chosen by overloads instead, the steps were inlined only by LLVM, after its loop
# vectoriser had passed them (the U-D steps ran scalar and much slower;
# benchmarks/bench_batched.py).
@njit(**_INL)
def lane_load(form, Sv, A, B, th, bad, l, NP):
    """Lane l ← the flat state (U-D: A = U, B = D; covariance: A = P, B = u)."""
    if form == COV:
        cov_lane_load(Sv, A, B, th, bad, l, NP)
    else:
        ud_lane_load(Sv, A, B, th, bad, l, NP)


@njit(**_INL)
def lane_store(form, Sv, A, B, th, l, NP):
    """The flat state ← lane l."""
    if form == COV:
        cov_lane_store(Sv, A, B, th, l, NP)
    else:
        ud_lane_store(Sv, A, B, th, l, NP)


@njit(**_INL)
def lane_steps(form, A, B, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc, k0, t0, t1, dthr, NP):
    """Steps t0 ≤ t < t1 of every lane (:func:`._soa_ud.ud_lane_steps`,
    :func:`._soa_cov.cov_lane_steps`)."""
    if form == COV:
        cov_lane_steps(A, B, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc, k0, t0, t1, dthr, NP)
    else:
        ud_lane_steps(A, B, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc, k0, t0, t1, dthr, NP)


@njit(**_INL)
def rerun(form, S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, ntag):
    """One stream by the form's scalar kernel, for a lane marked NaN (covariance:
    P needs the repair the lanes do not do); its code. U-D lanes are never marked."""
    if form == COV:
        return cov_rerun(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, ntag)
    return -1


@njit(**_INL)
def ratio(form, lk, wk):
    """The per-sample factor the steps read as Rc: U-D 1/w, covariance r = λ/w
    (λ where w = 1, as :func:`._covariance._cov_stream`)."""
    if form == COV:
        return lk if wk == 1.0 else lk / wk
    return 1.0 / wk
