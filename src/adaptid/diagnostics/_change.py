r"""A battery of structural-change tests with one verdict (for reports and fleets)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import kstwobign

from .._validation import check_choice, check_scalar
from ._format import format_num, format_pval, frame, htest_text, short_repr
from ._cusum import cusum_squares
from ._efp import efp
from ._fstats import fstats
from ._nyblom import nyblom_hansen
from ._recursive import recursive_residuals
from ._sc_common import regression_data

__all__ = ["ChangeTest", "ChangeTests", "change_tests", "CHANGE_TESTS"]

#: Names of the tests of :func:`change_tests`, in order.
CHANGE_TESTS = ("cusum", "cusum2", "supF", "re", "nyblom")


@dataclass(frozen=True)
class ChangeTest:
    """One test: ``name``, ``statistic``, ``pvalue``, ``reject`` at α, ``break_index`` (or None)."""

    name: str
    statistic: float
    pvalue: float
    reject: bool
    break_index: int | None

    def __repr__(self) -> str:
        return short_repr("ChangeTest", name=self.name, statistic=self.statistic,
                          pvalue=self.pvalue, reject=self.reject, break_index=self.break_index)

    def summary(self) -> str:
        """The test in the layout of R's ``print.htest``."""
        extra = [] if self.break_index is None else [f"break index (0-based): {self.break_index}"]
        return htest_text(f"{self.name} test", "X, y", [(self.name, self.statistic)],
                          self.pvalue, extra)

    def to_frame(self):
        """One row: ``test``, ``statistic``, ``pvalue``, ``reject``, ``break_index``."""
        return frame([(self.name, self.statistic, self.pvalue, self.reject, self.break_index)],
                     ("test", "statistic", "pvalue", "reject", "break_index"))

    def to_dict(self) -> dict:
        return {"name": self.name, "statistic": self.statistic, "pvalue": self.pvalue,
                "reject": self.reject, "break_index": self.break_index}


@dataclass(frozen=True)
class ChangeTests:
    """Results of :func:`change_tests`; ``tests`` maps a name to a :class:`ChangeTest`."""

    tests: dict
    alpha: float

    @property
    def no_change(self) -> bool:
        """True only if no test rejects constancy at level α (every test agrees)."""
        return not any(t.reject for t in self.tests.values())

    @property
    def rejected(self) -> tuple:
        """Names of the tests that reject."""
        return tuple(name for name, t in self.tests.items() if t.reject)

    def __getitem__(self, name) -> ChangeTest:
        return self.tests[name]

    def __repr__(self) -> str:
        head = f"ChangeTests(alpha={self.alpha:g}, no_change={self.no_change})"
        return "\n".join([head] + [f"  {t!r}" for t in self.tests.values()])

    def summary(self) -> str:
        """One line per test: statistic, p-value as R prints it, verdict, break index."""
        rows = [("test", "statistic", "p-value", "reject", "break")]
        for k, t in self.tests.items():
            rows.append((k, format_num(t.statistic), format_pval(t.pvalue), str(t.reject),
                         "" if t.break_index is None else str(t.break_index)))
        w = [max(len(r[j]) for r in rows) for j in range(5)]
        lines = ["  ".join(c.ljust(w[j]) if j == 0 else c.rjust(w[j]) for j, c in enumerate(r))
                 for r in rows]
        head = f"Tests of parameter constancy at level {self.alpha:g}"
        verdict = "no change" if self.no_change else "change: " + ", ".join(self.rejected)
        return "\n".join(["", "\t" + head, "", *lines, "", verdict, ""])

    def to_frame(self):
        """One row per test: ``statistic``, ``pvalue``, ``reject``, ``break_index`` (index: name)."""
        names = list(self.tests)
        return frame([(t.statistic, t.pvalue, t.reject, t.break_index) for t in self.tests.values()],
                     ("statistic", "pvalue", "reject", "break_index"), index=names)

    def to_dict(self) -> dict:
        return {"alpha": self.alpha, "no_change": self.no_change,
                "tests": {k: v.to_dict() for k, v in self.tests.items()}}


def change_tests(X, y, *, alpha=0.05, trim=0.15, tests=CHANGE_TESTS):
    r"""Run the recursive CUSUM, CUSUM of squares, supF, RE and Nyblom–Hansen tests.

    Parameters
    ----------
    X : array_like, shape (N, n)
        Regressors (1-D: one column).
    y : array_like, shape (N,)
        Observations; N ≥ 2n + 4 or so for every test to be defined.
    alpha : float, optional
        Level of each test. Default 0.05 (no multiplicity correction
        across the five: the verdict is deliberately sensitive).
    trim : float, optional
        Trimming of the supF candidates. Default 0.15.
    tests : sequence of str, optional
        Which of :data:`CHANGE_TESTS` to run (default all; the fleet runs
        one per device).

    Returns
    -------
    ChangeTests
        ``tests["cusum"|"cusum2"|"supF"|"re"|"nyblom"]`` each with
        ``statistic``, ``pvalue``, ``reject``, ``break_index`` (0-based
        sample where the statistic is attained: the supF date and the peak
        of the RE process estimate the break date; the largest deviation of
        the CUSUM of squares from its mean line; the CUSUM's scaled peak,
        only indicative; None for Nyblom–Hansen), and ``no_change`` — True
        only if every test agrees that there is no change.

    Notes
    -----
    * ``cusum``: :func:`efp` ``"rec-cusum"`` (Brown, Durbin & Evans;
      strucchange's p-value) — power against changes of the mean
      direction of the regressors, none against a change of the
      coefficient of a zero-mean regressor;
    * ``cusum2``: :func:`cusum_squares`, rejecting when it crosses its
      Edgerton–Wells band (at the tabulated level nearest α: 0.2, 0.1,
      0.05, 0.02, 0.01); its ``pvalue`` is the asymptotic one,
      :math:`P(\sup|B| > \sqrt{m/2 - 1}\,\max_r|s_r - r/m|)` with B a
      Brownian bridge (the leading term of Edgerton–Wells), for
      multiple-testing control — mainly variance changes;
    * ``supF``: :func:`fstats` (Andrews 1993; Hansen's p-value) — power
      against any coefficient change, and a break date;
    * ``re``: :func:`efp` ``"re"`` (Ploberger, Krämer & Kontrus 1989);
    * ``nyblom``: :func:`nyblom_hansen` — coefficients and variance.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.diagnostics import change_tests
    >>> rng = np.random.default_rng(3)
    >>> x = rng.standard_normal(500)
    >>> y = np.where(np.arange(500) < 300, 1.0, 1.5) * x + 0.3 * rng.standard_normal(500)
    >>> ct = change_tests(np.column_stack([np.ones(500), x]), y)
    >>> ct.no_change, ct["cusum"].reject, ct["supF"].reject, ct["supF"].break_index
    (False, False, True, 299)
    """
    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    X, y = regression_data(X, y)
    N, n = X.shape
    tests = tuple(tests)
    for name in tests:
        check_choice(name, "tests", CHANGE_TESTS)
    out = {}
    for name in CHANGE_TESTS:
        if name in tests:
            out[name] = _RUN[name](X, y, alpha, trim)
    return ChangeTests(tests=out, alpha=alpha)


def _cusum(X, y, alpha, trim):
    rc = efp(X, y, kind="rec-cusum")
    p = rc.pvalue
    return ChangeTest("cusum", rc.statistic, p, bool(p < alpha), rc.break_index)


def _cusum2(X, y, alpha, trim):
    n = X.shape[1]
    w = recursive_residuals(X, y)
    levels = np.array([0.2, 0.1, 0.05, 0.02, 0.01])
    cs = cusum_squares(w, float(levels[np.argmin(np.abs(np.log(levels / alpha)))]))
    dev = np.abs(cs.statistic - (cs.upper + cs.lower) / 2)
    # asymptotic p-value: sqrt(m/2 - 1) max|s_r - r/m| -> sup|Brownian bridge|
    # (Kolmogorov), the leading term of Edgerton & Wells' response surface
    p2 = float(kstwobign.sf(np.sqrt(max(w.size / 2.0 - 1.0, 1.0)) * np.max(dev)))
    return ChangeTest("cusum2", float(np.max(dev)), p2, cs.crossed, n + int(np.argmax(dev)))


def _supf(X, y, alpha, trim):
    fs = fstats(X, y, trim=trim)
    t = fs.test("supF")
    return ChangeTest("supF", t.statistic, t.pvalue, bool(t.pvalue < alpha), fs.breakpoint)


def _re(X, y, alpha, trim):
    re = efp(X, y, kind="re")
    p = re.pvalue
    return ChangeTest("re", re.statistic, p, bool(p < alpha), re.break_index)


def _nyblom(X, y, alpha, trim):
    nh = nyblom_hansen(X, y)
    return ChangeTest("nyblom", nh.statistic, nh.pvalue, bool(nh.pvalue < alpha), None)


_RUN = {"cusum": _cusum, "cusum2": _cusum2, "supF": _supf, "re": _re, "nyblom": _nyblom}
