r"""Per-group fit statistics and change tests, and the fleet's verdict.

σ̂², RMS and standard errors by the rule of :func:`adaptid.recursive_fit_stats`
per segment; the change tests with a p-value (:func:`adaptid.diagnostics.change_tests`)
or the Brown-Durbin-Evans CUSUM crossing; multiple-testing control across devices.
"""

from __future__ import annotations

import numbers

import numpy as np

#: tests with a p-value (adaptid.diagnostics.change_tests), and BDE's CUSUM crossing
_PVALUE_TESTS = ("supF", "re", "cusum", "cusum2")
_CHANGE_TESTS = _PVALUE_TESTS + ("a-priori", "recursive")
_MULTIPLE = ("bh", "bonferroni", "none")


def _constant_forgetting(est):
    """The estimator's constant λ (1 for Kalman and for a forgetting strategy).

    A strategy's λₖ are not returned by ``run_segments``, so its factors are
    taken as 1, as :func:`adaptid.recursive_fit_stats` does without
    ``forgetting=``.
    """
    lam = getattr(est, "forgetting", None)
    if isinstance(lam, numbers.Real) and not isinstance(lam, bool):
        return float(lam)
    return 1.0


def _bde_a(alpha):
    from ..diagnostics._cusum import _bde_critical_value
    return _bde_critical_value(alpha)


def _statistics(est, res, Phi, Y, offsets, alpha_a, change_test, burn_in):
    """σ̂², residual RMS, standard errors and the CUSUM flag of every segment."""
    from .._kernels.layers._fleet import residual_ss_kernel
    G = offsets.shape[0] - 1
    n = Phi.shape[1]
    used = ~res.skipped
    window = int(getattr(est, "window", 0) or 0)
    ss, wss, neff = np.empty(G), np.empty(G), np.empty(G)
    count = np.empty(G, dtype=np.int64)
    residual_ss_kernel(Phi, Y, used, offsets, np.ascontiguousarray(res.theta), window,
                       _constant_forgetting(est), ss, wss, neff, count)
    # the rule of adaptid.recursive_fit_stats, per segment
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        dof = neff - n
        sigma2 = np.where(dof > 0, wss / np.where(dof > 0, dof, 1.0), np.nan)
        rms = np.sqrt(ss / count)
        noise_var = float(getattr(est, "noise_var", 1.0))
        if res.P is None:  # gradient methods (lms, nlms): no covariance, NaN stderr
            stderr = np.full((G, n), np.nan)
        else:
            diagP = np.clip(np.diagonal(res.P, axis1=1, axis2=2), 0.0, None)
            stderr = np.sqrt(diagP * (sigma2 / noise_var)[:, None])

    pvalue = np.full(G, np.nan)
    if change_test in _PVALUE_TESTS:
        ratio, pvalue, first = _pvalue_tests(Phi, Y, used, offsets, change_test, alpha_a[1])
    else:
        ratio, first = _bde_tests(res, Phi, Y, used, offsets, alpha_a[0], change_test, burn_in)
    return {"sigma2": sigma2, "rms": rms, "stderr": stderr, "ratio": ratio, "first": first,
            "pvalue": pvalue}


def _pvalue_tests(Phi, Y, used, offsets, change_test, alpha):
    """Per group: the statistic, p-value and break sample of one test of
    :func:`adaptid.diagnostics.change_tests` on the group's used samples
    (each test one compiled pass; a loop over groups, not over samples)."""
    from ..diagnostics import change_tests
    G = offsets.shape[0] - 1
    stat, pval = np.full(G, np.nan), np.full(G, np.nan)
    first = np.full(G, -1, dtype=np.int64)
    for g in range(G):
        rows = np.flatnonzero(used[offsets[g]:offsets[g + 1]]) + offsets[g]
        try:
            t = change_tests(Phi[rows], Y[rows], alpha=alpha, tests=(change_test,))[change_test]
        except ValueError:  # too few samples for the test: no verdict
            continue
        stat[g], pval[g] = t.statistic, t.pvalue
        if t.break_index is not None and t.pvalue < alpha:
            first[g] = rows[t.break_index]
    return stat, pval, first


def _bde_tests(res, Phi, Y, used, offsets, alpha_a, change_test, burn_in):
    """Brown–Durbin–Evans CUSUM crossing of every segment (compiled): (ratio, first)."""
    from .._kernels.layers._fleet import cusum_errors_kernel, recursive_residuals_segments
    G = offsets.shape[0] - 1
    n = Phi.shape[1]
    ratio = np.empty(G)
    first = np.empty(G, dtype=np.int64)
    if change_test == "a-priori":
        if burn_in is None:  # 10 % of the used samples, at least 10·n
            burn = np.maximum(10 * n, np.ceil(0.1 * res.n_samples)).astype(np.int64)
        else:
            burn = np.full(G, burn_in, dtype=np.int64)
        cusum_errors_kernel(res.error, used, offsets, burn, alpha_a, ratio, first)
        return ratio, first
    if used.all():
        Pc, Yc, oc, rows = Phi, Y, offsets, None
    else:
        rows = np.flatnonzero(used)
        Pc, Yc = np.ascontiguousarray(Phi[rows]), np.ascontiguousarray(Y[rows])
        oc = np.zeros_like(offsets)
        np.cumsum(res.n_samples, out=oc[1:])
    w = np.empty(Pc.shape[0])
    recursive_residuals_segments(Pc, Yc, oc, w)
    ok = np.isfinite(w)
    cusum_errors_kernel(np.where(ok, w, 0.0), ok, oc, np.zeros(G, dtype=np.int64),
                        alpha_a, ratio, first)
    if rows is not None:
        first = np.where(first >= 0, rows[np.maximum(first, 0)], -1)
    return ratio, first


def _benjamini_hochberg(p, alpha):
    """Rejections of the Benjamini–Hochberg (1995) step-up procedure at FDR α (NaN: none)."""
    p = np.asarray(p, dtype=float)
    ok = np.flatnonzero(np.isfinite(p))
    reject = np.zeros(p.shape, dtype=bool)
    if ok.size:
        order = ok[np.argsort(p[ok], kind="stable")]
        m = ok.size
        below = p[order] <= alpha * np.arange(1, m + 1) / m
        if below.any():
            reject[order[: int(np.flatnonzero(below)[-1]) + 1]] = True
    return reject


def _fleet_verdict(out, alpha, multiple):
    """``change`` from the p-values of every device, with multiple-testing control;
    ``change_at`` kept only for the devices flagged."""
    p = out["change_pvalue"].to_numpy(dtype=float)
    if multiple == "bh":
        flag = _benjamini_hochberg(p, alpha)
    else:
        level = alpha / max(int(np.isfinite(p).sum()), 1) if multiple == "bonferroni" else alpha
        flag = np.isfinite(p) & (p <= level)
    out["change"] = flag
    out.loc[~flag, "change_at"] = np.nan

