r"""F statistics for a single break at an unknown date (R strucchange's ``Fstats``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp
from scipy.stats import f as f_dist

from .._kernels.layers._breakpoints import prefix_rss
from .._validation import check_choice, check_int, check_scalar, param_error
from ._pvalues import pvalue_fstats
from ._format import frame, htest_text, short_repr
from ._sc_common import new_axes, outside_legend, regression_data

__all__ = ["FstatsResult", "FTest", "ChowResult", "fstats", "chow"]


@dataclass(frozen=True)
class FTest:
    """One of supF, aveF, expF: ``kind``, ``statistic``, ``pvalue``."""

    kind: str
    statistic: float
    pvalue: float

    def __repr__(self) -> str:
        return short_repr("FTest", kind=self.kind, statistic=self.statistic, pvalue=self.pvalue)

    def summary(self) -> str:
        """The test as strucchange's ``print(sctest(Fstats(...), type=...))`` prints it."""
        name = self.kind[:-1] + ".F"  # strucchange's sup.F, ave.F, exp.F
        return htest_text(f"{self.kind} test", "X, y", [(name, self.statistic)], self.pvalue)

    def to_frame(self):
        """One row: ``test``, ``statistic``, ``pvalue`` (a pandas DataFrame)."""
        return frame([(self.kind, self.statistic, self.pvalue)], ("test", "statistic", "pvalue"))


@dataclass(frozen=True, eq=False)
class FstatsResult:
    r"""The F statistics of every candidate break (from :func:`fstats`).

    Attributes
    ----------
    F : ndarray, shape (m,)
        :math:`F_j` for a break after sample ``candidates[j]``, as
        strucchange's ``Fstats(...)$Fstats`` (the Wald form, n × the
        classical Chow F).
    candidates : ndarray of int, shape (m,)
        0-based index of the last sample of the first segment (R's
        ``point`` minus one).
    n_obs, n_params : int
        N and n.
    lam : float
        Andrews' λ = ((N − from)·to)/(from·(N − to)) of the trimming.
    rss_full : float
        Residual sum of squares without a break.
    """

    F: np.ndarray
    candidates: np.ndarray
    n_obs: int
    n_params: int
    lam: float
    rss_full: float

    def __repr__(self) -> str:
        t = self.test("supF")
        return short_repr("FstatsResult", supF=t.statistic, pvalue=t.pvalue,
                          breakpoint=self.breakpoint, candidates=self.candidates.size,
                          n_obs=self.n_obs)

    def summary(self) -> str:
        """supF, aveF and expF as strucchange's ``sctest`` prints each, and the break."""
        return "".join(self.test(k).summary() for k in ("supF", "aveF", "expF")) + \
            f"break after sample (0-based): {self.breakpoint}\n"

    def to_frame(self):
        """One row per test (supF, aveF, expF): ``test``, ``statistic``, ``pvalue``, ``breakpoint``."""
        rows = []
        for k in ("supF", "aveF", "expF"):
            t = self.test(k)
            rows.append((k, t.statistic, t.pvalue, self.breakpoint if k == "supF" else None))
        return frame(rows, ("test", "statistic", "pvalue", "breakpoint"))

    @property
    def breakpoint(self) -> int:
        """0-based last sample before the break that maximises F (R's ``breakpoint`` − 1)."""
        return int(self.candidates[int(np.argmax(self.F))])

    def test(self, kind="supF") -> FTest:
        r"""supF (Andrews 1993), aveF or expF (Andrews & Ploberger 1994) with Hansen's p-value.

        .. math::

            \sup F = \max_j F_j, \quad
            \mathrm{ave}F = \frac1m\sum_j F_j, \quad
            \exp F = \log\Bigl(\frac1m\sum_j e^{F_j/2}\Bigr).

        The p-value is strucchange's ``pvalue.Fstats``: Hansen's (1997)
        response-surface approximation at the trimming's λ; with a single
        candidate (λ = 1) supF and aveF use the exact F(n, N − 2n) test of
        the Chow F = F₁/n, as strucchange.
        """
        kind = check_choice(kind, "kind", ("supF", "aveF", "expF"))
        if kind == "supF":
            stat = float(np.max(self.F))
        elif kind == "aveF":
            stat = float(np.mean(self.F))
        else:
            stat = float(logsumexp(0.5 * self.F) - np.log(self.F.size))
        k, N = self.n_params, self.n_obs
        if self.lam == 1 and kind != "expF":
            p = float(f_dist.sf(stat, k, N - 2 * k))   # strucchange's own (sic) choice
        else:
            p = pvalue_fstats(stat, kind, k, self.lam)
        return FTest(kind, stat, p)

    def plot(self, ax=None, *, alpha=0.05):
        """Plot F against the candidate break and the supF critical line; returns the Figure.

        ``ax`` (optional): draw there (the Figure returned is ``ax.figure``).
        """
        from scipy.optimize import brentq

        ax = new_axes(ax)
        ax.plot(self.candidates, self.F, lw=1, label="F statistics")
        crit = brentq(lambda c: pvalue_fstats(c, "supF", self.n_params, self.lam) - alpha, 0.0, 500.0)
        ax.axhline(crit, color="r", ls="--", lw=1, label=f"supF {100 * (1 - alpha):g} % critical value")
        ax.axvline(self.breakpoint, color="k", ls=":", lw=1,
                   label=f"most likely break ({self.breakpoint})")
        ax.set_xlabel("last sample before the break")
        ax.set_ylabel("F statistic")
        outside_legend(ax)
        return ax.figure


def _rss_split(X, y):
    """RSS of rows 0..t (fwd[t]) and of rows t..N-1 (bwd[t]), two compiled passes."""
    N = X.shape[0]
    fwd = np.empty(N)
    prefix_rss(X, y, fwd)
    rev = np.empty(N)
    prefix_rss(np.ascontiguousarray(X[::-1]), np.ascontiguousarray(y[::-1]), rev)
    return fwd, rev[::-1]


def _window(N, n, trim, from_, to):
    """R's ``from``/``to`` (1-based last sample of segment 1) from trim or from_/to."""
    if from_ is not None and trim is not None:
        raise param_error("from_", "given without trim (trim is from_ as a fraction, "
                          "symmetric)", from_)
    if from_ is None:
        trim = 0.15 if trim is None else trim
        trim = check_scalar(trim, "trim", low=0.0, high=0.5, low_open=True, high_open=True)
        frm = int(np.floor(trim * N))
        return frm, N - frm
    frm = _point(from_, "from_", N)
    stop = N - frm if to is None else _point(to, "to", N)
    return frm, stop


def _point(v, name, N):
    """A fraction in (0, 1) → floor(v·N); a number ≥ 1 → that 1-based observation."""
    v = check_scalar(v, name, low=0.0, high=float(N), low_open=True)
    if v < 1.0:
        return int(np.floor(v * N))
    if v != int(v):
        raise param_error(name, "a fraction in (0, 1) or a whole 1-based observation number",
                          v)
    return int(v)


def fstats(X, y, *, trim=None, from_=None, to=None):
    r"""Chow F statistics for a break at every candidate date (R strucchange's ``Fstats``).

    Parameters
    ----------
    X : array_like, shape (N, n)
        Regressors (1-D: one column).
    y : array_like, shape (N,)
        Observations.
    trim : float, optional
        Fraction of the sample excluded at each end, in (0, 0.5).
        Candidates are R's points ``from = floor(trim N)`` … ``N − from``
        (1-based last sample of the first segment), clipped to
        [n + 1, N − n − 1]. Default 0.15 (when ``from_`` is not given).
    from_, to : float, optional
        R's asymmetric window ``Fstats(from =, to =)``: a fraction in
        (0, 1) (``floor(v N)``) or a 1-based observation number (the last
        sample of the first segment); ``to`` defaults to ``N − from``.
        ``from_`` replaces ``trim`` (give one of them). The p-values use
        λ = (N − from)·to / (from·(N − to)) (Hansen 1997), as R does.

    Returns
    -------
    FstatsResult
        ``F``, ``candidates``, ``breakpoint``, ``test(kind)``, ``plot()``.

    Notes
    -----
    For a break after sample j,

    .. math::

        F_j = \frac{S - S_1(j) - S_2(j)}{(S_1(j) + S_2(j))/(N - 2n)},

    S the RSS without a break and :math:`S_1, S_2` those of the two
    segments (Andrews 1993, eq. 4.3 in its Wald form; strucchange
    ``Fstats``). All :math:`S_1(j)` and :math:`S_2(j)` come from two
    compiled passes of recursive residuals (forward and on the reversed
    sample), O(N n²) in all.

    References
    ----------
    .. [1] D. W. K. Andrews, "Tests for parameter instability and
       structural change with unknown change point", Econometrica
       61(4):821–856, 1993.
    .. [2] D. W. K. Andrews, W. Ploberger, "Optimal tests when a nuisance
       parameter is present only under the alternative", Econometrica
       62(6):1383–1414, 1994.
    .. [3] B. E. Hansen, "Approximate asymptotic p values for
       structural-change tests", J. Business & Economic Statistics
       15(1):60–67, 1997.

    Examples
    --------
    A change of the slope of a zero-mean regressor (invisible to the
    recursive CUSUM) is dated by supF:

    >>> import numpy as np
    >>> from adaptid.diagnostics import fstats
    >>> rng = np.random.default_rng(1)
    >>> x = rng.standard_normal(400)
    >>> y = np.where(np.arange(400) < 250, 1.0, 1.5) * x + 0.2 * rng.standard_normal(400)
    >>> fs = fstats(np.column_stack([np.ones(400), x]), y)
    >>> abs(fs.breakpoint - 249) <= 5, fs.test("supF").pvalue < 0.001
    (True, True)
    """
    X, y = regression_data(X, y)
    N, n = X.shape
    frm, to = _window(N, n, trim, from_, to)
    if frm >= to:
        raise param_error("to", f"after from_ ({frm}) and before N = {N}", to)
    frm = max(frm, n + 1)
    to = min(to, N - n - 1)
    if frm > to:
        raise param_error("X", f"long enough for a break with {n} parameters per segment "
                          f"(N >= {2 * n + 2})", f"<shape {X.shape}>")
    fwd, bwd = _rss_split(X, y)
    points = np.arange(frm, to + 1)          # R's 1-based point = rows 1..point in segment 1
    S = fwd[-1]
    u = fwd[points - 1] + bwd[points]
    F = (S - u) / (u / (N - 2 * n))
    lam = ((N - frm) * to) / (frm * (N - to))
    return FstatsResult(F=F, candidates=points - 1, n_obs=N, n_params=n, lam=float(lam),
                        rss_full=float(S))


@dataclass(frozen=True)
class ChowResult:
    """Chow test: ``statistic`` (classical F), ``pvalue`` (F(n, N − 2n)), ``at``."""

    statistic: float
    pvalue: float
    at: int

    def __repr__(self) -> str:
        return short_repr("ChowResult", statistic=self.statistic, pvalue=self.pvalue, at=self.at)

    def summary(self) -> str:
        """The test as strucchange's ``print(sctest(..., type = "Chow"))`` prints it."""
        return htest_text("Chow test", "X, y", [("F", self.statistic)], self.pvalue,
                          [f"break after sample (0-based): {self.at}"])

    def to_frame(self):
        """One row: ``test``, ``statistic``, ``pvalue``, ``at``."""
        return frame([("chow", self.statistic, self.pvalue, self.at)],
                     ("test", "statistic", "pvalue", "at"))


def chow(X, y, at):
    r"""Chow (1960) test of a break after sample ``at`` (0-based; strucchange ``sctest(type = "Chow")``).

    Parameters
    ----------
    X : array_like, shape (N, n)
    y : array_like, shape (N,)
    at : int
        0-based index of the last sample of the first segment, with
        n ≤ at ≤ N − n − 2 (both segments longer than n).

    Returns
    -------
    ChowResult
        ``statistic`` :math:`F = \frac{(S - S_1 - S_2)/n}{(S_1 + S_2)/(N - 2n)}`
        and its p-value from the F(n, N − 2n) distribution.

    References
    ----------
    .. [1] G. C. Chow, "Tests of equality between sets of coefficients in
       two linear regressions", Econometrica 28(3):591–605, 1960.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.diagnostics import chow
    >>> y = np.r_[np.zeros(50), np.ones(50)] + np.random.default_rng(0).standard_normal(100)
    >>> chow(np.ones(100), y, 49).pvalue < 0.01
    True
    """
    X, y = regression_data(X, y)
    N, n = X.shape
    at = check_int(at, "at", low=n, high=N - n - 2)
    fwd, bwd = _rss_split(X, y)
    S, u = fwd[-1], fwd[at] + bwd[at + 1]
    F = ((S - u) / n) / (u / (N - 2 * n))
    return ChowResult(float(F), float(f_dist.sf(F, n, N - 2 * n)), at)
