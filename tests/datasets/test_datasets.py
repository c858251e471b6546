"""Tests of adaptid.datasets: packaged files, loaders, MATLAB helpers, dryer ARX."""

import hashlib
import importlib.util
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from adaptid.datasets import (
    DAISY_NAMES,
    central_difference,
    load_daisy,
    load_emps,
    matlab_decimate,
    matlab_filtfilt,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

# sha256 and sizes as recorded in shared/data/emps/SOURCE.md and
# shared/data/daisy/SOURCE.md (checksums of the upstream files).
CHECKSUMS = {
    "DATA_EMPS.mat": ("6cf6814ae14618795da0101aae2bb97ff0c6351b0501b5492751b02b07facf7e", 626039),
    "DATA_EMPS_PULSES.mat": ("0eab75bb1f6b16228ee78791343a88bf9bfd9a51036ac9807d7b5fc11c0e1704", 630990),
    "dryer.dat": ("adcb2f5a1d9e174d08dd49f7f037626745b5e69cbda0bc1e8dca2a7c687d4538", None),
    "robot_arm.dat": ("4ee167a8a28ce0da868d1b42f6a2fe0c456ea0e56b60c70915bf6d4a2a933635", None),
    "CD_player_arm.dat": ("a2ef4bf51c3102487a0690c7a68d97f3b1966cd07319580011a97fc0af904eaa", None),
    "exchanger.dat": ("cfb5a447fb573f87de33760e156cbf5da1f9802ae8a03a1b3c39ce8eb656fa6c", None),
}


def _load_example(name):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# --------------------------------------------------------------------------
# packaged files
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(CHECKSUMS))
def test_packaged_file_checksum(name):
    digest, size = CHECKSUMS[name]
    data = resources.files("adaptid.datasets").joinpath("data", name).read_bytes()
    assert hashlib.sha256(data).hexdigest() == digest
    if size is not None:
        assert len(data) == size


def test_provenance_readme_is_packaged_and_lists_every_checksum():
    text = resources.files("adaptid.datasets").joinpath("data", "README.md").read_text(encoding="utf-8")
    for name, (digest, _) in CHECKSUMS.items():
        assert name in text and digest in text


# --------------------------------------------------------------------------
# EMPS loader (facts from shared/data/emps/SOURCE.md)
# --------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["estimation", "validation"])
def test_load_emps(kind):
    d = load_emps(kind)
    assert d.kind == kind
    for name in ("t", "qm", "qg", "vir"):
        arr = getattr(d, name)
        assert arr.shape == (24841,) and arr.dtype == np.float64
    assert d.gtau == 35.15065188248547
    assert d.kp == pytest.approx(160.18, abs=5e-3)   # SOURCE.md prints 2 decimals
    assert d.kv == pytest.approx(243.45, abs=5e-3)
    assert d.Ts == 1e-3
    assert d.t[0] == pytest.approx(0.0, abs=1e-6) and d.t[-1] == pytest.approx(24.84, abs=1e-6)
    # 1 kHz with a jitter of ~2e-8 s
    assert np.max(np.abs(np.diff(d.t) - 1e-3)) < 1e-7
    np.testing.assert_array_equal(d.force, d.gtau * d.vir)
    if kind == "validation":
        assert d.pulses_N.shape == (24841,) and d.pulses_N.dtype == np.float64
        assert d.pulses_N.max() > 0 and np.all(d.pulses_N == np.round(d.pulses_N))
    else:
        assert d.pulses_N is None


def test_load_emps_bad_kind():
    with pytest.raises(ValueError, match="kind must be one of 'estimation', 'validation', got 'test'"):
        load_emps("test")
    with pytest.raises(TypeError, match="kind must be a str, got 1"):
        load_emps(1)


# --------------------------------------------------------------------------
# DaISy loader (column facts from shared/data/daisy/SOURCE.md)
# --------------------------------------------------------------------------
def test_daisy_names():
    assert DAISY_NAMES == ("dryer", "robot_arm", "CD_player_arm", "exchanger")


@pytest.mark.parametrize("name, u_shape, y_shape, Ts", [
    ("dryer", (1000,), (1000,), 0.08),
    ("robot_arm", (1024,), (1024,), None),
    ("CD_player_arm", (2048, 2), (2048, 2), None),
    ("exchanger", (4000,), (4000,), 1.0),
])
def test_load_daisy_shapes(name, u_shape, y_shape, Ts):
    d = load_daisy(name)
    assert d.name == name
    assert d.u.shape == u_shape and d.y.shape == y_shape
    assert d.u.dtype == np.float64 and d.u.flags.c_contiguous and d.y.flags.c_contiguous
    assert d.Ts == Ts
    assert d.data.shape[1] == len(d.columns)
    assert "Contributor" in d.description


def test_load_daisy_columns():
    dryer = load_daisy("dryer")
    assert set(np.unique(dryer.u)) == {3.41, 6.41}          # binary heater voltage
    # SOURCE.md prints the ranges rounded: y 3.20 ... 6.25, q 0.1 ... 0.7, th 92.8 ... 101.4
    assert round(dryer.y.min(), 2) == 3.20 and round(dryer.y.max(), 2) == 6.25
    np.testing.assert_array_equal(dryer.u, dryer.data[:, 0])
    np.testing.assert_array_equal(dryer.y, dryer.data[:, 1])

    ex = load_daisy("exchanger")
    np.testing.assert_array_equal(ex.time, np.arange(1.0, 4001.0))
    assert round(ex.u.min(), 1) == 0.1 and round(ex.u.max(), 1) == 0.7       # liquid flow rate
    assert round(ex.y.min(), 1) == 92.8 and round(ex.y.max(), 1) == 101.4     # outlet temperature
    assert ex.columns == ("time", "q", "th")

    cd = load_daisy("CD_player_arm")
    np.testing.assert_array_equal(cd.u, cd.data[:, :2])
    np.testing.assert_array_equal(cd.y, cd.data[:, 2:])
    assert cd.time is None and load_daisy("robot_arm").time is None


def test_load_daisy_bad_name():
    with pytest.raises(ValueError, match=r"name must be one of 'dryer', 'robot_arm', "
                                         r"'CD_player_arm', 'exchanger', got 'dryer2'"):
        load_daisy("dryer2")
    with pytest.raises(TypeError, match="name must be a str"):
        load_daisy(None)


# --------------------------------------------------------------------------
# MATLAB-compatible helpers
# --------------------------------------------------------------------------
def naive_matlab_filtfilt(b, a, x):
    """MATLAB filtfilt, written out: odd extension of 3*order samples,
    steady-state initial conditions scaled by the first value, both ways."""
    L = 3 * (max(len(a), len(b)) - 1)
    ext = np.concatenate([2 * x[0] - x[L:0:-1], x, 2 * x[-1] - x[-2:-L - 2:-1]])
    zi = signal.lfilter_zi(b, a)
    fwd, _ = signal.lfilter(b, a, ext, zi=zi * ext[0])
    rev = fwd[::-1]
    bwd, _ = signal.lfilter(b, a, rev, zi=zi * rev[0])
    return bwd[::-1][L:-L]


def test_matlab_filtfilt_against_written_out_algorithm():
    rng = np.random.default_rng(0)
    x = np.cumsum(rng.standard_normal(300))
    b, a = signal.butter(4, 0.2)
    y = matlab_filtfilt(b, a, x)
    np.testing.assert_allclose(y, naive_matlab_filtfilt(b, a, x), rtol=1e-12, atol=1e-12)
    # ...and it is not SciPy's default (padlen 3*max(len) instead of 3*order)
    assert np.max(np.abs(y - signal.filtfilt(b, a, x))) > 1e-6
    # columns are filtered independently
    X = np.column_stack([x, -2 * x])
    np.testing.assert_allclose(matlab_filtfilt(b, a, X), np.column_stack([y, -2 * y]), rtol=1e-12)


def test_matlab_decimate_grid_and_filter():
    # MATLAB keeps nbeg:r:N with nbeg = r - (r*ceil(N/r) - N): the grid ends at N
    N, r = 1003, 10
    t = np.arange(N)
    x = np.sin(2 * np.pi * t / 400.0)             # far below the 0.8/r cut-off
    y = matlab_decimate(x, r)
    nbeg = r - (r * int(np.ceil(N / r)) - N)       # = 3 (1-based)
    assert y.shape == (len(range(nbeg - 1, N, r)),) == (101,)
    # pass-band gain within twice (forward and backward) the 0.05 dB ripple,
    # i.e. 1.2 %, away from the last samples, where the odd reflection of a
    # sine differs from the sine itself
    np.testing.assert_allclose(y[:-3], x[nbeg - 1::r][:-3], rtol=0, atol=0.012)
    b, a = signal.cheby1(8, 0.05, 0.8 / r)
    np.testing.assert_allclose(y, naive_matlab_filtfilt(b, a, x)[nbeg - 1::r], rtol=1e-10, atol=1e-12)
    # a 2-D array is decimated column by column
    Y = matlab_decimate(np.column_stack([x, x**2]), r)
    np.testing.assert_allclose(Y[:, 1], matlab_decimate(x**2, r), rtol=1e-14)
    np.testing.assert_array_equal(matlab_decimate(x, 1), x)


def test_central_difference():
    rng = np.random.default_rng(2)
    y = rng.standard_normal(50)
    np.testing.assert_allclose(central_difference(y, 0.01), np.gradient(y, 0.01, edge_order=1),
                               rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(central_difference(3.0 * np.arange(10.0), 0.5), np.full(10, 6.0))


@pytest.mark.parametrize("call, exc, match", [
    (lambda: matlab_filtfilt([1.0], [0.0, 1.0], np.ones(10)), ValueError, r"a must be non-empty with a\[0\] != 0"),
    (lambda: matlab_filtfilt([1.0, 1.0], [1.0, 0.5], np.ones(3)), ValueError, "x must be longer than 3 samples"),
    (lambda: matlab_decimate(np.ones(100), 0), ValueError, "r must be an integer >= 1"),
    (lambda: matlab_decimate(np.ones(100), 2.5), TypeError, "r must be an integer"),
    (lambda: central_difference(np.ones(10), 0.0), ValueError, r"dt must be in \(0.0, inf\]"),
    (lambda: central_difference(np.ones(2), 1.0), ValueError, "y must be at least 3 samples long"),
])
def test_helper_argument_errors(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


# --------------------------------------------------------------------------
# Dryer ARX [2 2 3] (examples/dryer_arx.py)
# --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def dryer_example():
    return _load_example("dryer_arx")


def test_dryer_arx_coefficients(dryer_example):
    res = dryer_example.identify()
    # Provenance: shared/data/daisy/SOURCE.md, "Our plain LS", samples 1..300,
    # means removed, first max(na, nb+nk-1) = 4 rows discarded. Printed with 6
    # decimals (coefficients) and 4 decimals (std): half a unit of the last digit.
    np.testing.assert_allclose(res["theta"], [-1.273739, 0.393546, 0.066618, 0.044482], rtol=0, atol=5e-7)
    np.testing.assert_allclose(res["stderr"], [0.0209, 0.0191, 0.0021, 0.0033], rtol=0, atol=5e-5)
    # the model simulates the validation half well (no published number; a
    # second-order ARX of this plant fits its own validation data by > 80 %)
    assert res["fit_simulation_percent"] > 80.0


def test_dryer_arx_variants(dryer_example):
    d = load_daisy("dryer")

    def fit(u, y):
        Phi, target = dryer_example.arx_regression(u - u.mean(), y - y.mean())
        theta = np.linalg.lstsq(Phi, target, rcond=None)[0]
        r = target - Phi @ theta
        return theta, r @ r / r.size

    # SOURCE.md: samples 1..500 (Ljung's case study), printed to 4 decimals
    theta, loss = fit(d.u[:500], d.y[:500])
    np.testing.assert_allclose(theta, [-1.2765, 0.3967, 0.0652, 0.0452], rtol=0, atol=5e-5)
    assert loss == pytest.approx(1.6866e-3, abs=5e-8)
    # SOURCE.md: samples 1..300 with zero initial conditions instead of discarding
    u, y = d.u[:300] - d.u[:300].mean(), d.y[:300] - d.y[:300].mean()
    pad = np.zeros(4)
    Phi, target = dryer_example.arx_regression(np.r_[pad, u], np.r_[pad, y])
    theta = np.linalg.lstsq(Phi, target, rcond=None)[0]
    np.testing.assert_allclose(theta, [-1.274436, 0.394190, 0.066787, 0.044290], rtol=0, atol=5e-7)


def test_arx_regression_rows(dryer_example):
    u = np.arange(10.0)
    y = 100 + np.arange(10.0)
    Phi, target = dryer_example.arx_regression(u, y)
    # t = 4 (0-based): [-y(3), -y(2), u(1), u(0)]
    np.testing.assert_array_equal(Phi[0], [-103.0, -102.0, 1.0, 0.0])
    np.testing.assert_array_equal(target, y[4:])
    assert Phi.shape == (6, 4)
