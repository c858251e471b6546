r"""Asymptotic p-values of the structural-change tests, as R strucchange 1.5-3.

Each function transcribes one branch of strucchange's ``pvalue.efp`` or
``pvalue.Fstats`` (file R/efp.R and R/Fstats.R of strucchange 1.5-3);
the tables it interpolates are in :mod:`._sc_tables`, exported verbatim
from strucchange's R/sysdata.rda by
``tests/reference/strucchange/export_tables.R``. R's ``approx(...,
rule = 2)`` (linear interpolation, clamped at the ends) is
:func:`numpy.interp` on the pairs sorted by abscissa.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.stats import chi2, norm

from . import _sc_tables as _T

__all__ = ["pvalue_efp", "pvalue_fstats", "efp_critical_value"]

# pvalue.efp, "Brownian motion increments" branch (Rec-MOSUM): critical
# values of Chu, Hornik & Kuan (1995), typed in from strucchange 1.5-3
# R/efp.R; rows h = 0.05 ... 0.50, columns p = 0.2, 0.15, 0.1, 0.05, 0.025,
# 0.01 (before the sqrt(h) rescaling strucchange applies).
_BMI_TABLE = np.array([
    [3.2165, 2.9795, 2.8289, 2.7099, 2.6061, 2.5111, 2.4283, 2.3464, 2.2686, 2.2255],
    [3.3185, 3.0894, 2.9479, 2.8303, 2.7325, 2.6418, 2.5609, 2.4840, 2.4083, 2.3668],
    [3.4554, 3.2368, 3.1028, 2.9874, 2.8985, 2.8134, 2.7327, 2.6605, 2.5899, 2.5505],
    [3.6622, 3.4681, 3.3382, 3.2351, 3.1531, 3.0728, 3.0043, 2.9333, 2.8743, 2.8334],
    [3.8632, 3.6707, 3.5598, 3.4604, 3.3845, 3.3102, 3.2461, 3.1823, 3.1229, 3.0737],
    [4.1009, 3.9397, 3.8143, 3.7337, 3.6626, 3.5907, 3.5333, 3.4895, 3.4123, 3.3912],
]).T
_BMI_P = np.array([0.2, 0.15, 0.1, 0.05, 0.025, 0.01])
_TABLE_H = np.arange(1, 11) * 0.05
_BBI_P = np.array([0.1, 0.05, 0.025, 0.01])


def _approx(x, xp, fp):
    """R's ``approx(xp, fp, x, rule = 2)``."""
    order = np.argsort(xp, kind="stable")
    return float(np.interp(x, np.asarray(xp)[order], np.asarray(fp)[order]))


def _bm_max(x: float, k: int) -> float:
    # Brown, Durbin & Evans (1975) boundary-crossing probability of a
    # Brownian motion over the lines +-(x + 2 x t), with strucchange's
    # linear approximation 1 - 0.1465 x below x = 0.3.
    if x < 0.3:
        p = 1.0 - 0.1465 * x
    else:
        p = 2.0 * (1.0 - norm.cdf(3 * x) + np.exp(-4 * x * x) * (norm.cdf(x) + norm.cdf(5 * x) - 1.0)
                   - np.exp(-16 * x * x) * (1.0 - norm.cdf(x)))
    return float(1.0 - (1.0 - p) ** k)


def _bb_max(x: float, k: int) -> float:
    # Kolmogorov distribution of the sup of |Brownian bridge|, 100 terms.
    if x < 0.1:
        return 1.0
    i = np.arange(1, 101, dtype=np.float64)
    s = np.sum(np.exp(-2.0 * i * i * x * x) * (-1.0) ** i)
    return float(1.0 - (1.0 + 2.0 * s) ** k)


def _bb_meanl2(x: float, k: int) -> float:
    k = min(k, 25)
    crit = _T.SC_MEANL2[k - 1]
    return _approx(x, np.r_[0.0, crit], np.r_[1.0, 1.0 - _T.SC_MEANL2_P])


def _bmi_max(x: float, k: int, h: float) -> float:
    table = _BMI_TABLE * np.sqrt(_TABLE_H)[:, None]
    ipl = np.array([_approx(h, _TABLE_H, table[:, i]) for i in range(table.shape[1])])
    p = _approx(x, np.r_[0.0, ipl], np.r_[1.0, _BMI_P])
    return float(1.0 - (1.0 - p) ** k)


def _bbi_max(x: float, k: int, h: float) -> float:
    k = min(k, 6)
    table = _T.SC_ME[(k - 1) * 10:k * 10]
    ipl = np.array([_approx(h, _TABLE_H, table[:, i]) for i in range(table.shape[1])])
    return _approx(x, np.r_[0.0, ipl], np.r_[1.0, _BBI_P])


def pvalue_efp(x: float, lim_process: str, *, k: int, h: float | None = None,
               functional: str = "max") -> float:
    """strucchange's ``pvalue.efp(x, lim.process, alt.boundary = FALSE, functional, h, k)``."""
    x = float(x)
    if lim_process == "Brownian motion":
        return _bm_max(x, k)
    if lim_process == "Brownian bridge":
        return _bb_meanl2(x, k) if functional == "meanL2" else _bb_max(x, k)
    if lim_process == "Brownian motion increments":
        return _bmi_max(x, k, h)
    if lim_process == "Brownian bridge increments":
        return _bbi_max(x, k, h)
    raise ValueError(lim_process)  # pragma: no cover - internal


def efp_critical_value(alpha: float, lim_process: str, *, k: int, h: float | None = None) -> float:
    """Root of ``pvalue_efp(c) = alpha`` on (0, 20), as strucchange's ``boundary.efp``.

    strucchange uses ``uniroot`` with its default tolerance (about 1.2e-4);
    here the root is solved to machine precision, so R's boundaries agree
    to that tolerance only.
    """
    def f(c):
        return pvalue_efp(c, lim_process, k=k, h=h) - alpha

    return float(brentq(f, 0.0, 20.0, xtol=1e-13, rtol=1e-15))


def pvalue_fstats(x: float, kind: str, k: int, lam: float) -> float:
    """strucchange's ``pvalue.Fstats(x, type, k, lambda)`` (Hansen 1997).

    ``lam`` is Andrews' λ = ((N − from)·to)/(from·(N − to)); the trimming
    τ = 1/(1 + √λ) selects (and interpolates between) the rows of Hansen's
    response surface; ``k`` > 40 uses k = 40 as strucchange does.
    """
    k = min(int(k), 40)
    beta = {"supF": _T.SC_BETA_SUP, "aveF": _T.SC_BETA_AVE, "expF": _T.SC_BETA_EXP}[kind]
    m = beta.shape[1] - 1
    tau = lam if lam < 1 else 1.0 / (1.0 + np.sqrt(lam))
    beta = beta[(k - 1) * 25:k * 25]
    dummy = beta[:, :m] @ (float(x) ** np.arange(m))
    dummy = dummy * (dummy > 0)
    pp = chi2.sf(dummy, beta[:, m])
    if tau == 0.5:
        return float(chi2.sf(x, k))
    if tau <= 0.01:
        return float(pp[24])
    if tau >= 0.49:
        return float(((0.5 - tau) * pp[0] + (tau - 0.49) * chi2.sf(x, k)) * 100)
    taua = (0.51 - tau) * 50
    tau1 = int(np.floor(taua))
    # R indexes pp[tau1] and pp[tau1 + 1] from 1
    return float((tau1 + 1 - taua) * pp[tau1 - 1] + (taua - tau1) * pp[tau1])
