r"""RLS with exponential forgetting in square-root (Potter) form: ``RLS(form="sqrt")``.

Same entry points and signature as :mod:`._rls` (the U-D form); only the
covariance block of the state differs: ``[theta (n·p) | S (n·n, by columns) |
0 (n)]`` with :math:`P = S S^T`, S a full n × n matrix (Potter 1963; Bierman
1977, ch. V.2). Per sample, with :math:`f = S^T\varphi` and :math:`h = S f = P\varphi`
(both left over from the previous sample's sweep), r = λ/w:

.. math::

    d = r + f^T f,\quad \varepsilon = y - \varphi^T\theta,\quad
    \theta \leftarrow \theta + h\,\varepsilon/d,\quad
    \gamma = \frac{1}{1 + \sqrt{r/d}},\quad
    S \leftarrow \frac{1}{\sqrt\lambda}\Big(S - \frac{\gamma}{d}\,h f^T\Big),

which is :math:`P \leftarrow (P - P\varphi\varphi^T P/d)/\lambda` exactly
(Potter's update of :math:`S/\sqrt\lambda` with weight 1/w). P = S Sᵀ is
positive semi-definite whatever the rounding.

Speed: the U-D update is sequential across columns (a division per column on
the critical path) and does not vectorise; here one sweep over S per sample,
column by column, updates column j (a vector operation down the column),
forms the next sample's :math:`f_j = S_{:,j}^T\varphi_{k+1}` (a dot product
in eight fixed lanes, so the same bits whatever the vector width), and
accumulates :math:`h \mathrel{+}= S_{:,j} f_j` and :math:`q = f^Tf` — three
multiply-adds and a multiply per entry of S. A sample that was skipped or had
weight 0 makes the next one form f and h afresh, by the same sweep with S left
as it is (s = 1, a = 0: every entry is rewritten unchanged), so ``update``
equals ``run`` bit for bit. For a compile-time n the sweep is
LLVM vector code (``toolchain/_potter_ir.py``: numba does not SLP-vectorise the
unrolled loops of a constant n); the run-time-n kernel runs the same arithmetic
as loops.

Monitoring: the code is the first sample after which a diagonal entry of
P = S Sᵀ left (0, ``opt[0]``) (zero: S lost rank; NaN/inf: overflow), or
whose denominator d = r + φᵀPφ is not finite (data so large that φᵀPφ
overflows: the gain h/d is then 0 and θ would stay put silently), or −1.
The test of d costs nothing per sample: d = inf gives r/d = 0, which drops
the lower bound lo below ``FLOOR`` (see below), so the rule runs at that
sample and d is tested with it.
The rule itself — :math:`\mathrm{diag}(SS^T)_i = \sum_j S_{ij}^2` summed in
order, compared with 0 and ``opt[0]`` (:func:`_diag_inside`) — costs a pass
over S; it is evaluated only when cheap bounds cannot decide. In real
arithmetic, with :math:`P' = (P - hh^T/d)/\lambda` and Cauchy–Schwarz
(:math:`h_i^2 \le P_{ii}\,\varphi^TP\varphi`),

.. math::

    \frac{r}{d\,\lambda} P_{ii} \;\le\; P'_{ii} \;\le\; \frac{P_{ii}}{\lambda},

so a lower bound lo and an upper bound hi on diag(P) follow each sample in O(1):
``lo ← lo (r/d − τ)(1 − τ)/λ``, ``hi ← hi (1 + τ)/λ``, τ = ``SLACK``·(n + 16)
covering the rounding of the sweep (h, f, d and S each to a few (n + 10) ulp)
and of the rule's own sum. While lo > ``FLOOR`` and hi (1 + τ) < ``opt[0]``
(and < ``CEIL``) every entry of the rule is inside; otherwise the rule is
evaluated and lo, hi are reset from its sums. So the code is exactly the
rule's, sample by sample; the rule runs at the first sample of a call and then
once per a few hundred to a few thousand samples (when lo has decayed by
(r/(dλ))ᵏ or hi has grown by λ⁻ᵏ), and at every sample once near the
threshold.
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..toolchain._dims import dim
from ..toolchain._potter_ir import LANES, sweep_n
from ..toolchain._scratch import scratch, scratch2_lines
from ..toolchain._specialise import by_constant_n
from ._bierman import _views
from ._entries import Entries
from ._parallel import batched, segments
from ._step import views

_OPTS = {"fastmath": NJIT["fastmath"]}

#: relative slack τ = SLACK·(n + 16) of the bounds on diag(P) per sample: 64 units
#: of 2⁻⁵³ per (n + 16), over four times what the rounding of one update of S (and
#: of the rule's sum of squares) can move a row's norm² by (module docstring)
SLACK = 64 * 2.0 ** -53
#: a lower bound above FLOOR keeps the rule's sum of squares > 0 (no underflow to 0);
#: an upper bound below CEIL keeps it and h finite
FLOOR, CEIL = 1e-280, 1e300


@njit(**NJIT_INLINE)
def _coldot(F, j, x, NP):
    """Σᵢ F[i, j] x[i] in eight interleaved partial sums, summed pairwise."""
    a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = 0.0
    i = 0
    while i + LANES <= NP:
        a0 += F[i, j] * x[i]
        a1 += F[i + 1, j] * x[i + 1]
        a2 += F[i + 2, j] * x[i + 2]
        a3 += F[i + 3, j] * x[i + 3]
        a4 += F[i + 4, j] * x[i + 4]
        a5 += F[i + 5, j] * x[i + 5]
        a6 += F[i + 6, j] * x[i + 6]
        a7 += F[i + 7, j] * x[i + 7]
        i += LANES
    while i < NP:
        a0 += F[i, j] * x[i]
        i += 1
    return ((a0 + a4) + (a2 + a6)) + ((a1 + a5) + (a3 + a7))


def _sweep(F, f, h, a, s, nxt, NP):
    """F ← s F − a fᵀ column by column; f, h ← those of the next regressor; returns fᵀf."""
    for i in range(NP):
        h[i] = 0.0
    q = 0.0
    for j in range(NP):
        fj = f[j]
        for i in range(NP):
            F[i, j] = s * F[i, j] - a[i] * fj
        fn = _coldot(F, j, nxt, NP)
        f[j] = fn
        q += fn * fn
        for i in range(NP):
            h[i] += F[i, j] * fn
    return q


#: the sweep for a run-time n: compiled once and called (an O(n²) body), not inlined
#: at the loop's two call sites
_sweep_loops = njit(**NJIT)(_sweep)


def _sweep_call(F, f, h, a, s, nxt, NP):
    return _sweep_loops(F, f, h, a, s, nxt, NP)


def _sweep_vector(F, f, h, a, s, nxt, NP):
    return sweep_n(F, f, a, nxt, h, s, NP)


by_constant_n(_sweep, _sweep_vector, _sweep_call, jit_options=_OPTS)


@njit(**NJIT_INLINE)
def _diag_inside(F, rn, dthr, NP):
    """diag(F Fᵀ) into rn (by rows) and whether each entry is in (0, dthr): the rule."""
    for i in range(NP):
        rn[i] = 0.0
    for j in range(NP):
        for i in range(NP):
            rn[i] += F[i, j] * F[i, j]
    inside = True
    for i in range(NP):
        inside &= (rn[i] > 0.0) & (rn[i] < dthr)
    return inside


@njit(**NJIT_INLINE)
def _exact(F, rn, dthr, tau, NP):
    """The rule, and bounds (lo, hi) on the entries of diag(F Fᵀ) to screen the next samples."""
    inside = _diag_inside(F, rn, dthr, NP)
    lo = np.inf
    hi = 0.0
    for i in range(NP):
        lo = min(lo, rn[i])
        hi = max(hi, rn[i])
    if not inside:
        lo = 0.0  # (NaN too) the rule again at the next sample
    return inside, lo * (1.0 - tau), hi * (1.0 + tau)


@njit(**NJIT_INLINE)
def _errors(theta, phi, Y, k, e, E, NP, p):
    for j in range(p):
        s = Y[k, j]
        for i in range(NP):
            s -= phi[i] * theta[i, j]
        e[j] = s
        E[k, j] = s


@njit(**NJIT_INLINE)
def _gain(q, h, a, theta, e, lam, wk, NP, p):
    """a = β h (β = γ s/d = s/(d + √(r d)), d = r + q, q = fᵀf), θ ← θ + h ε/d;
    returns (s, r/d, d). a first: the next sweep waits for it, not for θ."""
    r = lam / wk
    d = r + q
    s = 1.0 / np.sqrt(lam)
    beta = s / (d + np.sqrt(r * d))
    for i in range(NP):
        a[i] = beta * h[i]
    idd = 1.0 / d
    for i in range(NP):
        g = h[i] * idd
        for j in range(p):
            theta[i, j] += g * e[j]
    return s, r * idd, d


@njit(**NJIT_INLINE)
def _potter_stream(S, Phi, Y, lam, w, Th, E, skipped, dthr, NP, p):
    theta, Fs, _ = _views(S, NP, p)
    F = scratch2_lines(NP).T  # by columns, as in S (rows of the stack copy on cache lines)
    for j in range(NP):
        for i in range(NP):
            F[i, j] = Fs[i, j]
    f = scratch(NP)
    h = scratch(NP)
    a = scratch(NP)
    rn = scratch(NP)
    e = scratch(p)
    N = Phi.shape[0]
    store = Th.shape[0] == N
    fresh = False  # f, h (and q = fᵀf) belong to Phi[k]
    q, bad, d = 0.0, -1, 0.0  # d: the last gain's denominator (finite before any)
    tau = SLACK * (NP + 16)
    lo, hi = 0.0, np.inf  # bounds on diag(F Fᵀ) (see the module docstring): none yet
    for k in range(N):
        phi = Phi[k]
        ok = True
        for i in range(NP):
            ok &= phi[i] - phi[i] == 0.0
        for j in range(p):
            ok &= Y[k, j] - Y[k, j] == 0.0
        wk = w[k]
        inside = True
        check = False  # evaluate the rule after this sample
        if ok:
            _errors(theta, phi, Y, k, e, E, NP, p)
        if ok and wk > 0.0:
            if not fresh:  # f, h, q of φ: the sweep with F unchanged (s = 1, a = f = 0)
                for i in range(NP):
                    a[i] = 0.0
                    f[i] = 0.0
                q = _sweep(F, f, h, a, 1.0, phi, NP)
            s, rd, d = _gain(q, h, a, theta, e, lam[k], wk, NP, p)
            q = _sweep(F, f, h, a, s, Phi[k + 1] if k + 1 < N else phi, NP)
            fresh = True
            lo *= (rd - tau) * (1.0 - tau) / lam[k]
            hi *= (1.0 + tau) / lam[k]
            check = bad < 0 and not (lo > FLOOR and hi * (1.0 + tau) < dthr and hi < CEIL)
        elif ok:  # weight 0: the sample only advances the forgetting
            s = 1.0 / np.sqrt(lam[k])
            for j in range(NP):
                for i in range(NP):
                    F[i, j] *= s
            check = True
            fresh = False
        else:
            skipped[k] = True
            for j in range(p):
                E[k, j] = np.nan
            fresh = False
        if check:
            inside, lo, hi = _exact(F, rn, dthr, tau, NP)
            # d = r + φᵀPφ overflowed (inf or NaN: the step h/d was 0): here, not on every
            # sample, since d = inf makes r/d = 0 and so lo ≤ 0, which always sets check
            inside &= d < np.inf
        if bad < 0 and not inside:
            bad = k
        if store:
            for i in range(NP):
                for j in range(p):
                    Th[k, i, j] = theta[i, j]
    for j in range(NP):
        for i in range(NP):
            Fs[i, j] = F[i, j]
    return bad


@njit(**NJIT)
def potter_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N steps; returns the first sample after which a diagonal entry of P left
    (0, ``opt[0]``), or -1."""
    return _potter_stream(S, Phi, Y, lam, w, Th, E, skipped, opt[0], dim(ntag), dim(ptag))


@njit(**NJIT)
def potter_step(S, W, ntag, ptag):
    """One step on the packed sample ``W`` (:mod:`._step`), bit for bit a step of
    :func:`potter_run`; returns its code."""
    Phi, Y, lam, w, Th, E, skipped, dthr = views(W, ntag, ptag)
    return _potter_stream(S, Phi, Y, lam, w, Th, E, skipped, dthr, dim(ntag), dim(ptag))


potter_run_batched = batched(potter_run, "potter_run_batched")
potter_run_segments = segments(potter_run, "potter_run_segments")


#: this module's entry points, by the name adaptid._kernels gives them
ENTRIES = {"POTTER": Entries(potter_run, potter_run_batched, potter_run_segments, step=potter_step)}
