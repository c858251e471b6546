r"""The estimation engine shared by ``adaptid fit`` and ``adaptid demo``.

Recursive runs are done in chunks (each one compiled ``run`` call), reading
the estimator's ``P`` at every chunk end: that gives the ±2σ bands of the
report and drives the progress bar, and the result is bit-for-bit the one
of a single ``run`` (the estimator's state carries over exactly).

Standard errors of a recursive estimate follow the one rule of
:func:`adaptid.recursive_fit_stats` (σ̂² from the final estimate's
residuals weighted by each sample's factor in the estimator's cost; see the
user guide, "Standard errors of a recursive fit"); with ``--resume`` the
sums run over the samples of this run. For ``batch`` the standard errors
are :func:`adaptid.lstsq`'s.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from adaptid.estimators._factory import METHODS as _RECURSIVE
from adaptid.estimators._factory import method_options, required_options
from adaptid.estimators._stateread import MAX_WINDOW

from ._errors import CLIError

__all__ = ["MethodSpec", "EquationFit", "fit_equation", "run_chunked", "METHODS", "OPTIONS"]

METHODS = _RECURSIVE + ("batch",)

#: The estimator options of the command line: flag -> (the factory's keyword, what
#: "--method M needs FLAG ..." says of it). Which method takes or needs an option
#: is read from the factory's table (:func:`adaptid.estimators._factory.method_options`,
#: ``required_options``), never restated here; ``batch`` takes none of them.
OPTIONS = {
    "--window": ("window", "M (the number of samples in the window)"),
    "--forgetting": ("forgetting", ""),
    "--process-cov": ("process_cov",
                      "Q (variance of the parameters' random-walk step per sample)"),
    "--noise-var": ("noise_var", ""),
    "--step": ("step", "MU (the adaptation gain, > 0)"),
    "--eps": ("eps", ""),
}
#: flags whose message has always read "applies to --method A or B" without "only"
_WITHOUT_ONLY = ("--forgetting",)


@dataclass
class MethodSpec:
    """The estimation method and its options, as given on the command line.

    ``None`` means "not given" (the library's default is used), so that
    inconsistent combinations can be named.
    """

    method: str | None = None
    forgetting: float | None = None
    window: int | None = None
    process_cov: float | None = None
    noise_var: float | None = None
    P0: float | str | None = None  # a float, or "diffuse"
    step: float | None = None   # lms, nlms
    eps: float | None = None    # nlms
    default: str = "rls"        # without --method ("batch" for a model option: see _modelfit)
    delta: float | None = None           # fastrls (issue 38; cli/_fastrls.py)
    fastrls_method: str | None = None    # fastrls: "ftf" or "lattice"

    @property
    def resolved(self) -> str:
        return self.method or self.default

    def check(self, *, resume=None, save_state=None):
        """Raise CLIError for an inconsistent combination of options."""
        m = self.method
        if m is not None and m not in METHODS:
            raise CLIError(f"--method must be one of {', '.join(METHODS)}, fastrls, got {m!r}")
        for flag, val in (("--delta", self.delta), ("--fastrls-method", self.fastrls_method)):
            if val is not None:  # --method fastrls runs in cli/_fastrls.py, not here
                raise CLIError(f"{flag} applies to --method fastrls only, not --method "
                               f"{self.resolved}")
        if resume is not None:
            if m == "batch":
                raise CLIError("--resume does not apply to --method batch (no state to continue)")
        else:
            m = self.resolved
            # two calls keep the order of the messages: a missing --window first
            check_options(m, (("--window", self.window),))
            check_options(m, (("--forgetting", self.forgetting),
                              ("--process-cov", self.process_cov), ("--noise-var", self.noise_var)))
            if self.P0 is not None and m == "batch":
                raise CLIError("--P0 does not apply to --method batch (batch least squares has no prior)")
            check_gradient(m, self.step, self.eps, self.P0)
        if save_state is not None and (self.method == "batch"):
            raise CLIError("--save-state does not apply to --method batch (no recursive state)")
        if self.window is not None and self.window < 1:
            raise CLIError(f"--window must be a positive integer, got {self.window}")
        if self.window is not None and self.window > MAX_WINDOW:
            # the largest window a state file holds; a buffer beyond it is gigabytes
            raise CLIError(f"--window must be at most {MAX_WINDOW:.0e}, got {self.window}")
        check_ranges(forgetting=self.forgetting, P0=self.P0, process_cov=self.process_cov,
                     noise_var=self.noise_var)

    def make(self, n: int, nan_policy: str):
        """A fresh estimator for n parameters (None for batch), from ``adaptid.estimator``."""
        from adaptid.estimators import estimator

        m = self.resolved
        if m == "batch":
            return None
        if m == "window" and self.window < n:
            raise CLIError(f"--window must be at least the number of parameters ({n}), got {self.window}")
        given = {"P0": self.P0}
        given.update((key, getattr(self, key)) for key, _ in OPTIONS.values())
        allowed = method_options(m)
        kw = {k: v for k, v in given.items() if v is not None and k in allowed}
        try:
            return estimator(m, n, nan_policy=nan_policy, **kw)
        except ValueError as err:
            raise CLIError(str(err)) from None

    def adopt(self, est, n: int, nan_policy: str, path):
        """Check a resumed estimator against the options given; set its nan policy."""
        from adaptid.estimators._factory import method_of

        method = method_of(est)
        if self.method is not None and self.method != method:
            raise CLIError(f"--method {self.method} differs from the state file {path} "
                           f"(a {type(est).__name__}, --method {method})")
        if est.n_params != n:
            raise CLIError(f"--resume {path}: the state has {est.n_params} parameters, the "
                           f"regressors given have {n}")
        checks = [("--forgetting", self.forgetting, getattr(est, "forgetting", None)),
                  ("--window", self.window, getattr(est, "window", None)),
                  ("--noise-var", self.noise_var, getattr(est, "noise_var", None)),
                  ("--step", self.step, getattr(est, "step", None)),
                  ("--eps", self.eps, getattr(est, "eps", None))]
        for opt, given, have in checks:
            if given is None:
                continue
            if have is None:
                raise CLIError(f"{opt} does not apply to the {type(est).__name__} in {path}")
            if not _same(given, have):
                raise CLIError(f"{opt} {given:g} differs from the state file {path} ({have:g}); "
                               "the state fixes the estimator's options")
        if self.process_cov is not None:
            pc = getattr(est, "process_cov", None)
            if pc is None:
                raise CLIError(f"--process-cov does not apply to the {type(est).__name__} in {path}")
            if not np.array_equal(pc, np.eye(n) * self.process_cov):
                raise CLIError(f"--process-cov {self.process_cov:g} differs from the state file {path}")
        if self.P0 is not None:
            raise CLIError("--P0 does not apply with --resume (the state file holds P)")
        self.method = method
        if getattr(est, "window", None) is not None:
            self.window = est.window
        if est.nan_policy != nan_policy:
            st = est.get_state()
            st["options"]["nan_policy"] = nan_policy
            est = type(est).from_state(st)
        return est

    def label(self, est=None) -> str:
        m = self.resolved
        if m == "rls":
            lam = getattr(est, "forgetting", self.forgetting if self.forgetting is not None else 1.0)
            return f"RLS λ={_fmt_opt(lam)}"
        if m == "window":
            return f"window M={getattr(est, 'window', self.window)}"
        if m == "kalman":
            return "Kalman"
        if m in _GRADIENT:
            return f"{m.upper()} μ={_fmt_opt(getattr(est, 'step', self.step))}"
        return "batch LS"


#: Ranges of the numeric options where float64 arithmetic holds (docs/guide.md,
#: "Numbers the shell accepts"): a prior, random-walk or noise variance beyond
#: 10^±100 times the data's scale leaves too little of the float64 exponent range
#: (±308) for the products P·φφᵀ·P of an update (P0 = 1e308 gives θ wrong in the
#: second digit, 1e200 still right); λ ≥ 1e-100 keeps P0/λ ≤ 1e200.
RANGES = {
    "--forgetting": (1e-100, 1.0, "in [1e-100, 1]"),
    "--P0": (1e-100, 1e100, "in [1e-100, 1e100]"),
    "--process-cov": (0.0, 1e100, "0 or in (0, 1e100]"),
    "--noise-var": (1e-100, 1e100, "in [1e-100, 1e100]"),
}
_REASON = ("outside it float64 arithmetic overflows or loses the estimate "
           "(see 'Numbers the shell accepts' in the user guide)")


def parse_P0(text):
    """``--P0``: a number, or ``diffuse`` (exact diffuse start); None if not given."""
    if text is None:
        return None
    if text.strip().lower() == "diffuse":
        return "diffuse"
    try:
        return float(text)
    except ValueError:
        raise CLIError(f"--P0 must be a number or 'diffuse', got {text!r}") from None


def check_ranges(*, forgetting=None, P0=None, process_cov=None, noise_var=None):
    """Raise CLIError naming the option for a value outside :data:`RANGES`."""
    if P0 == "diffuse":
        P0 = None  # no range to check
    for opt, val in (("--forgetting", forgetting), ("--P0", P0),
                     ("--process-cov", process_cov), ("--noise-var", noise_var)):
        if val is None:
            continue
        lo, hi, text = RANGES[opt]
        if not (math.isfinite(val) and lo <= val <= hi):
            raise CLIError(f"{opt} must be {text}, got {val:g}; {_REASON}")


def _takes(m, key) -> bool:
    """Whether method ``m``'s estimator takes option ``key`` (the factory's table)."""
    return m != "batch" and key in method_options(m)


def check_options(m, given):
    """Raise CLIError for an option ``m`` does not take, then for one it needs.

    ``given``: (flag, value or None) pairs of :data:`OPTIONS`, checked in order.
    """
    for flag, val in given:
        key = OPTIONS[flag][0]
        if val is not None and not _takes(m, key):
            takers = " or ".join(mm for mm in _RECURSIVE if _takes(mm, key))
            only = "" if flag in _WITHOUT_ONLY else " only"
            raise CLIError(f"{flag} applies to --method {takers}{only}, not --method {m}")
    needed = () if m == "batch" else required_options(m)
    for flag, val in given:
        key, what = OPTIONS[flag]
        if val is None and key in needed:
            raise CLIError(f"--method {m} needs {flag} {what}".rstrip())


#: the gradient methods: those whose estimator takes a step size
_GRADIENT = tuple(m for m in _RECURSIVE if _takes(m, "step"))


def check_gradient(m, step, eps, P0):
    """The options of the gradient methods (--step, --eps) and what they exclude."""
    check_options(m, (("--step", step), ("--eps", eps)))
    if step is not None and not (math.isfinite(step) and step > 0):
        raise CLIError(f"--step must be finite and > 0, got {step:g}")
    if eps is not None and not (math.isfinite(eps) and eps >= 0):
        raise CLIError(f"--eps must be finite and >= 0, got {eps:g}")
    if P0 is not None and m != "batch" and not _takes(m, "P0"):
        raise CLIError(f"--P0 does not apply to --method {m} (a gradient method has no "
                       "covariance)")


def _cov_or_nan(est):
    """P, or NaN for the gradient estimators (no covariance: NaN bands and stderr)."""
    try:
        return est.P
    except AttributeError:
        n = est.n_params
        return np.full((n, n), np.nan)


def _fmt_opt(v) -> str:
    try:
        return f"{float(v):g}"
    except (TypeError, ValueError):
        return str(v)


def _same(a, b) -> bool:
    try:
        return float(a) == float(b)
    except (TypeError, ValueError):
        return False


@dataclass
class EquationFit:
    """The estimate of one regression ``y = Φθ + e`` and what the report needs."""

    title: str
    method: str
    label: str
    names: list
    theta: np.ndarray            # (n,)
    stderr: np.ndarray           # (n,)
    cov: np.ndarray              # (n, n): sigma2 * P / R2, or lstsq's cov
    sigma2: float
    n_samples: int
    n_skipped: int
    error: np.ndarray            # (N,) a-priori errors (recursive) or residuals (batch)
    index: np.ndarray            # (N,) sample index of each regression row
    track: np.ndarray | None = None      # (N, n) estimates after each sample
    ends: np.ndarray | None = None       # (K,) row index of each chunk end
    band: np.ndarray | None = None       # (K, n) one standard error at each chunk end
    cov_ends: np.ndarray | None = None   # (K, n, n) covariance at each chunk end
    estimator: object = None
    n_rebuilds: int = 0
    warnings: list = field(default_factory=list)
    cusum: object = None
    rms_error: float = float("nan")


def run_chunked(est, Phi, y, *, n_chunks=200, advance=None):
    """Run ``est`` over (Phi, y) in up to ``n_chunks`` compiled calls.

    Returns ``(theta (N, n), error (N,), skipped (N,), ends (K,), P (K, n, n),
    n_rebuilds)``; ``ends[j]`` is the 0-based row after which ``P[j]`` was read.
    """
    N = len(y)
    K = max(1, min(int(n_chunks), N))
    edges = np.unique(np.linspace(0, N, K + 1).round().astype(np.int64))
    thetas, errors, skipped, Ps, ends = [], [], [], [], []
    rebuilds = 0
    for a, b in zip(edges[:-1], edges[1:]):
        tr = est.run(Phi[a:b], y[a:b])
        thetas.append(tr.theta)
        errors.append(tr.error)
        skipped.append(tr.skipped)
        rebuilds += tr.n_rebuilds
        Ps.append(_cov_or_nan(est))
        ends.append(b - 1)
        if advance is not None:
            advance(int(b - a))
    n = est.n_params
    if not thetas:
        return (np.empty((0, n)), np.empty(0), np.zeros(0, bool), np.empty(0, np.int64),
                np.empty((0, n, n)), 0)
    return (np.concatenate(thetas), np.concatenate(errors), np.concatenate(skipped),
            np.asarray(ends, dtype=np.int64), np.stack(Ps), rebuilds)


def fit_equation(title, names, Phi, y, index, spec: MethodSpec, *, nan_policy="raise",
                 est=None, n_chunks=200, advance=None, want_cusum=False,
                 runner=None) -> EquationFit:
    """Estimate one regression with the method of ``spec`` (or continue ``est``).

    ``runner(est, n_chunks=, advance=)``, if given, runs the estimator instead of
    :func:`run_chunked` over ``(Phi, y)`` and returns what it returns (the
    streaming model objects of ``--arx``/``--ar``/``--fir``, see ``_modelfit``);
    ``Phi`` and ``y`` are then the same regression, for the statistics.
    """
    N, n = Phi.shape
    caught = []
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        if spec.resolved == "batch" and est is None:
            fit = _fit_batch(title, names, Phi, y, index, spec, advance)
        else:
            fresh = est is None
            if fresh:
                est = spec.make(n, nan_policy)
            start_updates = est.n_updates
            try:
                run = runner or (lambda e, **kw: run_chunked(e, Phi, y, **kw))
                th, err, skipped, ends, Ps, rebuilds = run(est, n_chunks=n_chunks,
                                                           advance=advance)
            except ValueError as e:
                raise CLIError(f"{title}: {e}") from None
            warm = min(10 * n, N // 2) if (fresh or start_updates == 0) else 0
            stats = _fit_stats(est, Phi, y, skipped)
            sigma2, scale = stats.sigma2, stats.scale
            cov = scale * _cov_or_nan(est)
            band = np.sqrt(np.maximum(scale * np.diagonal(Ps, axis1=1, axis2=2), 0.0))
            finite = np.isfinite(err)
            fit = EquationFit(
                title=title, method=spec.resolved, label=spec.label(est), names=list(names),
                theta=np.asarray(est.theta, dtype=np.float64).copy(),
                stderr=stats.stderr, cov=cov, sigma2=sigma2,
                n_samples=N, n_skipped=int(np.count_nonzero(skipped)), error=err, index=index,
                track=th, ends=ends, band=band, cov_ends=scale * Ps, estimator=est,
                n_rebuilds=int(rebuilds),
                rms_error=float(np.sqrt(np.mean(err[warm:][finite[warm:]] ** 2)))
                if finite[warm:].any() else float("nan"))
        if want_cusum:
            fit.cusum = _cusum(Phi, y)
    for w in rec:
        msg = " ".join(str(w.message).split())
        if msg not in caught:
            caught.append(msg)
    fit.warnings = caught
    return fit


def _fit_stats(est, Phi, y, skipped):
    """σ̂² and standard errors by the one rule (``adaptid.recursive_fit_stats``)."""
    from adaptid.estimators import recursive_fit_stats

    with np.errstate(invalid="ignore", over="ignore"):
        return recursive_fit_stats(est, Phi, y, used=~np.asarray(skipped, dtype=bool))


def _fit_batch(title, names, Phi, y, index, spec, advance):
    import adaptid

    ok = np.isfinite(Phi).all(axis=1) & np.isfinite(y)
    n = Phi.shape[1]
    if ok.sum() < n:
        raise CLIError(f"{title}: {int(ok.sum())} usable sample(s) for {n} parameters; "
                       "batch least squares needs at least as many samples as parameters")
    try:
        res = adaptid.lstsq(Phi[ok], y[ok])
    except ValueError as e:
        raise CLIError(f"{title}: {e}") from None
    if advance is not None:
        advance(len(y))
    err = np.full(len(y), np.nan)
    err[ok] = res.residuals
    return EquationFit(
        title=title, method="batch", label=spec.label(), names=list(names),
        theta=np.asarray(res.theta, dtype=np.float64), stderr=np.asarray(res.stderr),
        cov=np.asarray(res.cov), sigma2=float(res.sigma2), n_samples=len(y),
        n_skipped=int((~ok).sum()), error=err, index=index,
        rms_error=float(np.sqrt(np.mean(res.residuals ** 2))))


#: break dating is O(N² n²) (Bai & Perron's programme): only up to this many samples
MAX_BREAK_DATING = 20000


def _cusum(Phi, y):
    """The constancy tests of the report over the complete rows, or None.

    CUSUM and CUSUM of squares of the recursive residuals, the F statistics
    of every candidate break (supF), break dating by BIC (up to
    :data:`MAX_BREAK_DATING` samples) and the battery of
    :func:`adaptid.diagnostics.change_tests` whose ``no_change`` is the
    report's verdict.
    """
    from adaptid.diagnostics import (breakpoints, change_tests, cusum, cusum_squares, fstats,
                                     recursive_residuals)

    ok = np.isfinite(Phi).all(axis=1) & np.isfinite(y)
    Phi, y = Phi[ok], y[ok]
    rows = np.flatnonzero(ok)
    if len(y) <= Phi.shape[1] + 2:
        return None
    try:
        w = recursive_residuals(Phi, y)
    except ValueError:
        return None
    k = rows[Phi.shape[1]:]
    good = np.isfinite(w)
    if good.sum() < 3:
        return None
    try:
        res = cusum(w[good])
        squares = cusum_squares(w[good])
    except ValueError:
        return None
    out = {"rows": k[good], "result": res, "squares": squares, "all_rows": rows,
           "fstats": None, "breaks": (), "tests": None}
    try:
        out["tests"] = change_tests(Phi, y)
        out["fstats"] = fstats(Phi, y)
        if len(y) <= MAX_BREAK_DATING:
            bp = breakpoints(Phi, y)
            out["breaks"] = tuple(rows[np.asarray(bp.breakpoints, dtype=int)])
    except ValueError:  # too short for the F tests: the CUSUMs alone
        pass
    return out
