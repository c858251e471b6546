"""Structural-change tests against R strucchange's own results.

Reference values: ``tests/reference/strucchange/reference.json``, written by
``make_reference.R`` in the same folder (R 4.2.2, strucchange 1.5-3, Debian
r-cran-strucchange 1.5-3-1) on strucchange's documented examples: the Nile
(Nile ~ 1), nhtemp (nhtemp ~ 1) and the seatbelt model of ?breakpoints
(log10 UKDriverDeaths on its lags 1 and 12, 1970(1)-1984(12), h = 0.1). The
data are R's datasets exported by that script as CSV. R is not needed to run
these tests.

Tolerances: the reference holds R's doubles to 17 digits, far more than R
prints (7 significant digits). Statistics and processes agree to 1e-9
relative (R's recresid uses a different recursion than the Givens kernel,
and lm.fit a different QR: differences of 1e-11 are observed on the seatbelt
data); p-values to 1e-9 relative or 1e-12 absolute (R computes upper tails as
1 - pchisq(...) and loses everything below 1e-16). Boundaries and the
OLS-CUSUM monitoring critical value are found by R's uniroot/optimize with
their default tolerances (~1.2e-4 and ~1.5e-8): compared at 2e-4 and 1e-6.
Break dates and confidence intervals are integers: exact.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from adaptid.diagnostics import Monitor, breakpoints, chow, efp, fstats, nyblom_hansen

REF_DIR = Path(__file__).resolve().parents[1] / "reference" / "strucchange"
REF = json.loads((REF_DIR / "reference.json").read_text())
RTOL = 1e-9


def _series(name):
    d = np.loadtxt(REF_DIR / f"{name}.csv", delimiter=",", skiprows=1)
    return d[:, 1]


def _models():
    nile, nht, ukd = _series("Nile"), _series("nhtemp"), _series("UKDriverDeaths")
    ly = np.log10(ukd)
    # seatbelt (?breakpoints): cbind(y, lag(y, -1), lag(y, -12)) on 1970(1)..1984(12);
    # UKDriverDeaths starts in 1969(1), so 1970(1) is row 12 (0-based).
    idx = np.arange(12, ly.size)
    Xs = np.column_stack([np.ones(idx.size), ly[idx - 1], ly[idx - 12]])
    return {
        "nile": (np.ones((nile.size, 1)), nile),
        "nhtemp": (np.ones((nht.size, 1)), nht),
        "seatbelt": (Xs, ly[idx]),
    }


MODELS = _models()
KINDS = [("rec-cusum", "Rec-CUSUM"), ("ols-cusum", "OLS-CUSUM"), ("rec-mosum", "Rec-MOSUM"),
         ("ols-mosum", "OLS-MOSUM"), ("re", "RE"), ("me", "ME")]


def r(key):
    return np.array(REF[key], dtype=float)


def assert_p(mine, ref):
    assert mine == pytest.approx(ref, rel=RTOL, abs=1e-12)


def test_seatbelt_data_are_strucchanges():
    # ?breakpoints: 180 monthly observations of the seatbelt model
    X, y = MODELS["seatbelt"]
    assert X.shape == (180, 3)


@pytest.mark.parametrize("model", list(MODELS))
@pytest.mark.parametrize("kind, rkind", KINDS)
def test_efp_equals_strucchange(model, kind, rkind):
    X, y = MODELS[model]
    p = efp(X, y, kind=kind)
    key = f"{model}.efp.{rkind}"
    ref_proc = r(key + ".process")
    ncol = int(r(key + ".ncol")[0])
    mine = p.process.T.ravel() if p.process.ndim == 2 else p.process  # R: column-major
    assert (1 if p.process.ndim == 1 else p.process.shape[1]) == ncol
    np.testing.assert_allclose(mine, ref_proc, rtol=RTOL, atol=RTOL * np.max(np.abs(ref_proc)))
    assert p.statistic == pytest.approx(r(key + ".statistic")[0], rel=RTOL)
    assert_p(p.pvalue, r(key + ".pvalue")[0])
    for alpha, tag in ((0.05, "05"), (0.10, "10")):
        np.testing.assert_allclose(p.boundary(alpha), r(key + f".boundary{tag}"), rtol=0, atol=2e-4)


@pytest.mark.parametrize("model", list(MODELS))
def test_fstats_equal_strucchange(model):
    X, y = MODELS[model]
    fs = fstats(X, y)
    np.testing.assert_allclose(fs.F, r(f"{model}.Fstats.F"), rtol=RTOL)
    assert fs.breakpoint == int(r(f"{model}.Fstats.breakpoint")[0]) - 1   # 0-based
    assert fs.lam == pytest.approx(r(f"{model}.Fstats.lambda")[0], rel=1e-15)
    for kind in ("supF", "aveF", "expF"):
        t = fs.test(kind)
        assert t.statistic == pytest.approx(r(f"{model}.Fstats.{kind}.statistic")[0], rel=RTOL)
        assert_p(t.pvalue, r(f"{model}.Fstats.{kind}.pvalue")[0])


@pytest.mark.parametrize("model", list(MODELS))
def test_chow_and_nyblom_hansen_equal_strucchange(model):
    X, y = MODELS[model]
    N = y.size
    c = chow(X, y, N // 2 - 1)             # R: point = floor(0.5 N), 1-based
    assert c.statistic == pytest.approx(r(f"{model}.chow50.statistic")[0], rel=RTOL)
    assert_p(c.pvalue, r(f"{model}.chow50.pvalue")[0])
    nh = nyblom_hansen(X, y)
    assert nh.statistic == pytest.approx(r(f"{model}.nyblom.statistic")[0], rel=RTOL)
    assert_p(nh.pvalue, r(f"{model}.nyblom.pvalue")[0])


@pytest.mark.parametrize("model", list(MODELS))
def test_breakpoints_equal_strucchange(model):
    X, y = MODELS[model]
    key = f"{model}.breakpoints"
    bp = breakpoints(X, y, h=float(r(key + ".h")[0]))
    np.testing.assert_allclose(bp.rss, r(key + ".RSS"), rtol=RTOL)
    np.testing.assert_allclose(bp.bic, r(key + ".BIC"), rtol=RTOL)
    ref_bp = r(key + ".breakpoints")
    if np.isnan(ref_bp).all():                 # R: NA = no break
        assert bp.n_breaks == 0 and bp.breakpoints.size == 0
    else:
        np.testing.assert_array_equal(bp.breakpoints, ref_bp.astype(int) - 1)
    for m in range(1, bp.max_breaks + 1):
        np.testing.assert_array_equal(bp.breakpoints_for(m), r(f"{key}.m{m}").astype(int) - 1)
    mb = int(r(key + ".ci_breaks")[0])
    for level, tag in ((0.95, "95"), (0.90, "90")):
        ci = bp.confint(level, m=mb)
        np.testing.assert_array_equal(ci + 1, r(f"{key}.confint{tag}").reshape(mb, 3))
    np.testing.assert_allclose(bp.coef(mb).ravel(), r(key + ".coef"), rtol=RTOL)


@pytest.mark.parametrize("kind, rkind", [("ols-cusum", "OLS-CUSUM"), ("me", "ME")])
def test_monitor_equals_strucchange(kind, rkind):
    # make_reference.R: efp(y ~ 1, data = Nile[1:25], type, h = 0.5); mefp(alpha = 0.05,
    # period = 4); monitor() on the whole series.
    nile = _series("Nile")
    key = f"nile.monitor.{rkind}"
    mon = Monitor(np.ones(25), nile[:25], kind=kind, alpha=0.05, horizon=4, h=0.5)
    alarm = mon.run(np.ones(75), nile[25:])
    assert alarm == int(r(key + ".breakpoint")[0]) - 1
    tol = 1e-6 if kind == "ols-cusum" else 1e-12   # R's optimize() tolerance vs a table lookup
    assert mon.critical_value == pytest.approx(r(key + ".critval")[0], rel=tol)
    np.testing.assert_allclose(mon.process.ravel(), r(key + ".process"), rtol=RTOL)
    np.testing.assert_allclose(mon.boundary, r(key + ".boundary"), rtol=tol)


def test_strucchange_tables_read_from_the_package_data_file():
    # The tables of strucchange 1.5-3's R/sysdata.rda, as export_tables.R wrote them into
    # src/adaptid/diagnostics/data/sc_tables.json: shapes, the corner entries (R's
    # sc.beta.sup[1, ], sc.me[1, ], sc.meanL2[1, 1], monitorMECritvalTable[1, 1, 1, "max"])
    # exactly, read-only arrays and one reading of the file.
    from adaptid.diagnostics import _sc_tables as T

    shapes = {"SC_BETA_SUP": (1000, 3), "SC_BETA_AVE": (1000, 5), "SC_BETA_EXP": (1000, 5),
              "SC_ME": (60, 4), "SC_MEANL2": (25, 15), "SC_MEANL2_P": (15,),
              "MONITOR_ME_PROB": (50,), "MONITOR_ME": (3, 5, 50)}
    assert set(T.tables()) == set(T.__all__) == set(shapes) | {"MONITOR_ME_WINSIZE",
                                                                "MONITOR_ME_PERIOD"}
    for name, shape in shapes.items():
        a = getattr(T, name)
        assert a.shape == shape and a.dtype == np.float64 and not a.flags.writeable, name
    assert T.SC_BETA_SUP[0].tolist() == [-0.0648467, 0.99671156, 1.2573241]
    assert T.SC_BETA_SUP[24].tolist() == [-1.78738608, 1.17220925, 4.4726701]
    assert T.SC_BETA_AVE[0, 0] == -0.0183718 and T.SC_BETA_EXP[0, 0] == -0.00205601
    assert T.SC_ME[0].tolist() == [0.7552, 0.8017, 0.8444, 0.8977] and T.SC_ME[-1, -1] == 2.0326
    assert T.SC_MEANL2[0, 0] == 0.860612275599396 and T.SC_MEANL2[-1, -1] == 4.77196771776676
    assert T.SC_MEANL2_P.tolist() == [0.995, 0.99, 0.98, 0.97, 0.96, 0.95, 0.94, 0.93, 0.92,
                                      0.91, 0.9, 0.875, 0.85, 0.825, 0.8]
    assert T.MONITOR_ME_WINSIZE == (0.25, 0.5, 1.0) and T.MONITOR_ME_PERIOD == (2, 4, 6, 8, 10)
    assert T.MONITOR_ME_PROB.tolist() == [round(0.95 + i / 1000, 3) for i in range(50)]
    assert T.MONITOR_ME[0, 0, 0] == 1.22762665817831
    assert T.MONITOR_ME[-1, -1, -1] == 3.94102916093653
    assert T.SC_ME is T.SC_ME and T.tables() is T.tables()           # read once, then cached
    with pytest.raises(AttributeError):
        T.SC_NOT_A_TABLE
    import tomllib                                                  # shipped in wheel and sdist
    root = Path(__file__).resolve().parents[2]
    project = tomllib.loads((root / "pyproject.toml").read_text())
    assert "diagnostics/data/*" in project["tool"]["setuptools"]["package-data"]["adaptid"]
    assert "include src/adaptid/diagnostics/data/sc_tables.json" in (
        root / "MANIFEST.in").read_text().splitlines()
