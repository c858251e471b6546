"""C for the models (issue 33, point 8): ``to_c`` of ARX / AR and RecursiveARX / RecursiveAR.

The generated ``NAME_step(m, y, u)`` takes raw measurements, removes the
offsets, keeps the lag buffers, predicts ŷ before y is used and (streaming
objects) updates θ with the estimator's generated recursion. Oracles:

* streaming objects: the Python object's own ``step()`` on the measurements
  less the offsets (ŷ plus y₀), sample by sample; compiled with host gcc,
  ``-DNAME_USE_FMA -mfma`` (the fused products of adaptid's kernels): bit for
  bit (θ and ŷ), as tests/codegen/test_codegen.py holds the estimators;
  without contraction: rounding differences only (≤ 1e-12 relative);
* fixed models: the one-step predictor written out here in NumPy from the
  definition (the lag matrix with zeros before the first sample, ŷ = Σ φᵢθᵢ
  summed by NumPy) bit for bit, and ``model.predict`` (scipy's lfilter, whose
  dot products go through BLAS: CPU-dependent order) to 1e-12 relative;
* ARM Linux under qemu-arm against the host build, both without contraction:
  bit for bit; float32 against float64: bounded (see the tests).

A missing toolchain is a failure, not a skip (as in test_codegen.py).
"""

from __future__ import annotations

import re
import subprocess

import numpy as np
import pytest

import adaptid
from adaptid import codegen
from adaptid.models import AR, ARX, IDData, RecursiveAR, RecursiveARX

from .test_codegen import CFLAGS, _host_has_fma, _tool

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>
#include "@name@.h"

/* reads [int64 N, int64 m | y (N) | U (N x m)] as doubles, writes per sample
 * [yhat | theta (n)] as doubles; prints the final count */
int main(int argc, char **argv)
{
    FILE *in, *out;
    int64_t hdr[2];
    double *y, *U, row[@N@ + 1];
    @real@ th[@N@], uu[@M@ + 1];
    @name@_model_t s;
    long k, n_rows;
    int i;
    if (argc != 3 || !(in = fopen(argv[1], "rb"))) return 2;
    if (fread(hdr, sizeof hdr, 1, in) != 1 || hdr[1] != @M@) return 3;
    n_rows = (long)hdr[0];
    y = malloc(sizeof(double) * (size_t)n_rows);
    U = malloc(sizeof(double) * (size_t)(n_rows * @M@ + 1));
    if (!y || !U) return 4;
    if (fread(y, sizeof(double), (size_t)n_rows, in) != (size_t)n_rows) return 5;
    if (fread(U, sizeof(double), (size_t)(n_rows * @M@), in) != (size_t)(n_rows * @M@)) return 5;
    fclose(in);
    if (!(out = fopen(argv[2], "wb"))) return 6;
    @name@_model_init(&s);
    uu[0] = 0;
    (void)uu;
    for (k = 0; k < n_rows; k++) {
        for (i = 0; i < @M@; i++) uu[i] = (@real@)U[k * @M@ + i];
        row[0] = (double)@name@_step(&s, (@real@)y[k]@UARG@);
        @name@_model_theta(&s, th);
        for (i = 0; i < @N@; i++) row[i + 1] = (double)th[i];
        if (fwrite(row, sizeof row, 1, out) != 1) return 7;
    }
    printf("%lu\n", (unsigned long)s.count);
    fclose(out);
    free(y);
    free(U);
    return 0;
}
"""

FMA = ["-DMDL_USE_FMA", "-mfma"]


def _build(obj, folder, *, m, single=True, dtype="float64", cc="gcc", flags=(), name="mdl",
           offsets=None):
    folder.mkdir(parents=True, exist_ok=True)
    codegen.to_c(obj, folder, name=name, dtype=dtype, offsets=offsets)
    uarg = "" if m == 0 else ", uu[0]" if single else ", uu"
    drv = (DRIVER.replace("@name@", name).replace("@N@", f"{name.upper()}_N")
           .replace("@M@", str(m)).replace("@UARG@", uarg)
           .replace("@real@", "double" if dtype == "float64" else "float"))
    (folder / "driver.c").write_text(drv)
    exe = folder / f"drv-{cc}-{dtype}-{abs(hash(tuple(flags)))}"
    res = subprocess.run([_tool(cc), *CFLAGS, *flags, "-I", str(folder), str(folder / "driver.c"),
                          str(folder / f"{name}.c"), "-o", str(exe), "-lm"],
                         capture_output=True, text=True)
    assert res.returncode == 0 and res.stderr == "", res.stderr  # warning-free
    return exe


def _run(exe, y, U, runner=()):
    U = np.asarray(U, dtype=float).reshape(len(y), -1)
    inp, out = exe.with_suffix(".in"), exe.with_suffix(".out")
    with open(inp, "wb") as fh:
        np.array([len(y), U.shape[1]], dtype=np.int64).tofile(fh)
        np.ascontiguousarray(y, dtype=float).tofile(fh)
        np.ascontiguousarray(U, dtype=float).tofile(fh)
    res = subprocess.run([*runner, str(exe), str(inp), str(out)], capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    data = np.fromfile(out).reshape(len(y), -1)
    return data[:, 0], data[:, 1:], int(res.stdout)


def _fma_flags():
    return FMA if _host_has_fma() else None


# --------------------------------------------------------------------------- data
def _plant(N, m=1, seed=33):
    """A stable ARX plant (dryer-like) with offsets: y ≈ 20 + …, u ≈ 5 + … (raw)."""
    rng = np.random.default_rng(seed)
    U = 5.0 + rng.standard_normal((N, m))
    y = np.zeros(N)
    for k in range(N):
        acc = (1.2 * (y[k - 1] - 20.0 if k >= 1 else 0.0)
               - 0.45 * (y[k - 2] - 20.0 if k >= 2 else 0.0))
        for i in range(m):
            acc += (0.8 - 0.2 * i) * (U[k - 3, i] - 5.0 if k >= 3 else 0.0)
            acc += 0.3 * (U[k - 4, i] - 5.0 if k >= 4 else 0.0)
        y[k] = 20.0 + acc + 0.05 * rng.standard_normal()
    return y, U


def _stream_cases():
    return {
        # MATLAB's default recursiveARX (forgetting), the issue's [2 2 3]
        "arx223_rls": (lambda: RecursiveARX(2, 2, 3, forgetting=0.99), 1),
        # two inputs, n = 2 + 5 + 3 = 10: numpy's 8-way pairwise sum and its remainder,
        # the current input (nk = 0) in the regressor; Kalman
        "arx_two_inputs_kalman": (lambda: RecursiveARX(2, [5, 3], [0, 3], method="kalman",
                                                       noise_cov=1e-4, noise_var=0.01), 2),
        # n = 11: finite history (the sliding window)
        "arx_window_n11": (lambda: RecursiveARX(5, 6, 1, window=80), 1),
        "arx_ngradient": (lambda: RecursiveARX(2, 2, 3, method="ngradient", step=0.2), 1),
        "ar_rls": (lambda: RecursiveAR(3, forgetting=0.995), 0),
    }


@pytest.fixture(scope="module")
def streams(tmp_path_factory):
    """Each case: the object after 300 samples in Python (offsets removed), exported with
    the offsets; the reference steps through the next 2000 raw samples."""
    root = tmp_path_factory.mktemp("codegen_models")
    records = {m: _plant(2300, m=max(m, 1)) for m in (0, 1, 2)}
    out = {}
    for key, (make, m) in _stream_cases().items():
        obj = make()
        y, U = records[m]
        Ud = U[:, :m] - 5.0
        yd = y - 20.0
        args = (yd[:300],) if m == 0 else (yd[:300], Ud[:300, 0] if m == 1 else Ud[:300])
        obj.run(*args)
        offsets = 20.0 if m == 0 else (20.0, 5.0)
        ref = type(obj).from_state(obj.get_state())
        yhat, theta = [], []
        for k in range(300, 2300):
            uk = () if m == 0 else (Ud[k, 0],) if m == 1 else (Ud[k],)
            th, yh = ref.step(yd[k], *uk)
            yhat.append(yh + 20.0)   # the raw prediction: the offset added back
            theta.append(th)
        raw = (y[300:], U[300:, :m])
        out[key] = (obj, m, offsets, np.array(yhat), np.array(theta), raw, root / key)
    return out


@pytest.mark.parametrize("key", list(_stream_cases()))
def test_stream_host_matches_step(streams, key):
    obj, m, offsets, yhat, theta, (y, U), folder = streams[key]
    exe = _build(obj, folder, m=m, single=m == 1, offsets=offsets, flags=["-ffp-contract=off"])
    yh, th, count = _run(exe, y, U)
    assert count == 300 + 2000
    scale = np.max(np.abs(theta), axis=1)
    assert float(np.max(np.max(np.abs(th - theta), axis=1) / scale)) <= 1e-12
    assert float(np.max(np.abs(yh - yhat))) <= 1e-12 * float(np.max(np.abs(yhat)))
    flags = _fma_flags()
    if flags is None:
        pytest.skip("the host CPU has no FMA: the bit-for-bit build cannot run here")
    yh2, th2, _ = _run(_build(obj, folder / "fma", m=m, single=m == 1, offsets=offsets,
                              flags=flags), y, U)
    np.testing.assert_array_equal(th2, theta)
    np.testing.assert_array_equal(yh2, yhat)


def test_stream_tracks_the_plant(streams):
    """Not vacuous: the recursions the C code matches identify the plant (θ of _plant)."""
    obj, m, offsets, yhat, theta, raw, folder = streams["arx223_rls"]
    np.testing.assert_allclose(theta[-1], [-1.2, 0.45, 0.8, 0.3], atol=0.05)
    obj, m, offsets, yhat, theta, raw, folder = streams["arx_two_inputs_kalman"]
    # a1 a2 | u0: lags 0 … 4 (0.8 at lag 3, 0.3 at 4) | u1: lags 3, 4, 5 (0.6, 0.3, 0)
    np.testing.assert_allclose(theta[-1], [-1.2, 0.45, 0, 0, 0, 0.8, 0.3, 0.6, 0.3, 0],
                               atol=0.05)


@pytest.mark.parametrize("start", ["filled", "zero"])
def test_fresh_object_start_guard(tmp_path, start):
    """An object exported before any sample: with start="filled" the first
    max(na, nk + nb - 1) = 4 steps return NaN and leave θ at θ₀, as Python's step."""
    y, U = _plant(600)
    obj = RecursiveARX(2, 2, 3, forgetting=0.98, start=start)
    ref = RecursiveARX.from_state(obj.get_state())
    steps = [ref.step(y[k] - 20.0, U[k, 0] - 5.0) for k in range(600)]
    theta = np.array([s[0] for s in steps])
    yhat = np.array([s[1] for s in steps]) + 20.0
    assert np.isnan(yhat[:4]).all() == (start == "filled") and not np.isnan(yhat[4:]).any()
    flags = _fma_flags() or ["-ffp-contract=off"]
    yh, th, count = _run(_build(obj, tmp_path, m=1, offsets=(20.0, 5.0), flags=flags), y, U)
    assert count == 600
    np.testing.assert_array_equal(np.isnan(yh), np.isnan(yhat))
    if _fma_flags():
        np.testing.assert_array_equal(th, theta)
        np.testing.assert_array_equal(yh, yhat)
    else:
        np.testing.assert_allclose(th, theta, rtol=1e-12, atol=1e-12)


# --------------------------------------------------------------------------- fixed models
def _lags(x, j):
    """x(k - j) with zeros before the first sample."""
    out = np.zeros_like(x)
    out[j:] = x[: len(x) - j] if j else x
    return out


def _one_step(yd, Ud, na, nb, nk, theta):
    """The one-step predictor written from its definition: φₖ = [−y(k−1) … −y(k−na),
    u(k−nk) … per input], zeros before the first sample; ŷ = Σ φᵢθᵢ (NumPy's sum)."""
    cols = [-_lags(yd, j) for j in range(1, na + 1)]
    for i, (b, k0) in enumerate(zip(nb, nk)):
        cols += [_lags(Ud[:, i], k0 + j) for j in range(b)]
    Phi = np.column_stack(cols)
    return (Phi * theta).sum(axis=1)


@pytest.mark.parametrize("orders,m", [((2, 2, 3), 1), ((3, [3, 6], [0, 2]), 2), ((4,), 0)])
def test_fixed_model_host(tmp_path, orders, m):
    """ARX / AR fitted on an IDData detrended with "constant": the offsets are the
    removed means (no offsets= given); C on the raw record = the one-step predictor
    on the detrended record plus the output mean, bit for bit; = predict to 1e-12."""
    y, U = _plant(3000, m=max(m, 1))
    data = IDData(y, U[:, :m] if m else None).detrend("constant")
    model = (ARX(*orders) if m else AR(*orders)).fit(data)
    y0 = float(np.mean(y))
    np.testing.assert_allclose(data.y_trend[0, 0], y0, rtol=1e-13)  # the removed mean
    yd, Ud = data.y, (data.u.reshape(len(y), -1) if m else np.zeros((len(y), 0)))
    na = orders[0]
    nb = () if m == 0 else [orders[1]] if m == 1 else orders[1]
    nk = () if m == 0 else [orders[2]] if m == 1 else orders[2]
    want = _one_step(yd, Ud, na, nb, nk, model.theta) + data.y_trend[0, 0]
    for flags in (["-ffp-contract=off"], _fma_flags()):
        if flags is None:
            continue
        exe = _build(model, tmp_path / str(len(flags)), m=m, single=m == 1, flags=flags)
        yh, th, count = _run(exe, y, U[:, :m])
        assert count == 3000
        np.testing.assert_array_equal(th, np.broadcast_to(model.theta, th.shape))
        np.testing.assert_array_equal(yh, want)
    pred = model.predict(yd) if m == 0 else model.predict(yd, Ud[:, 0] if m == 1 else Ud)
    np.testing.assert_allclose(yh, pred + data.y_trend[0, 0], rtol=1e-12)


# --------------------------------------------------------------------------- ARM, float32
@pytest.mark.parametrize("key", ["arx223_rls", "arx_two_inputs_kalman", "ar_rls"])
def test_arm_linux_qemu_same_as_host(streams, key):
    obj, m, offsets, yhat, theta, (y, U), folder = streams[key]
    host = _build(obj, folder / "h", m=m, single=m == 1, offsets=offsets,
                  flags=["-ffp-contract=off"])
    arm = _build(obj, folder / "arm", m=m, single=m == 1, offsets=offsets,
                 cc="arm-linux-gnueabihf-gcc", flags=["-static", "-ffp-contract=off"])
    yh_h, th_h, c_h = _run(host, y, U)
    yh_a, th_a, c_a = _run(arm, y, U, runner=[_tool("qemu-arm")])
    np.testing.assert_array_equal(th_a, th_h)
    np.testing.assert_array_equal(yh_a, yh_h)
    assert c_a == c_h


def test_arm_linux_qemu_fixed_model(tmp_path):
    y, U = _plant(2000)
    model = ARX(2, 2, 3).fit(IDData(y, U[:, 0]).detrend("constant"))
    host = _build(model, tmp_path / "h", m=1, flags=["-ffp-contract=off"])
    arm = _build(model, tmp_path / "a", m=1, cc="arm-linux-gnueabihf-gcc",
                 flags=["-static", "-ffp-contract=off"])
    np.testing.assert_array_equal(_run(arm, y, U, runner=[_tool("qemu-arm")])[0],
                                  _run(host, y, U)[0])


@pytest.mark.parametrize("key", ["arx223_rls", "ar_rls"])
def test_float32_streaming_error_bounded(streams, key):
    """float32 against the float64 C on the same raw samples (the offsets 20 and 5 are
    removed in float32: ε₃₂·20 ≈ 1e-6 absolute on each measurement, ε₃₂ = 6e-8).
    The error of θ is about ε₃₂·κ, κ the condition number of the information in
    the estimator's memory (lagged outputs correlate: κ of order 10 here).
    Measured (seed 33): θ 5.8e-7 (ARX), 6.4e-7 (AR) relative; ŷ 1.5e-7, 2.1e-7
    relative. Bounds: θ ≤ 1e-5, ŷ ≤ 3e-6 (≈ 15 × the measured)."""
    obj, m, offsets, yhat, theta, (y, U), folder = streams[key]
    e64 = _build(obj, folder / "d64", m=m, offsets=offsets, flags=["-ffp-contract=off"])
    e32 = _build(obj, folder / "d32", m=m, offsets=offsets, dtype="float32",
                 flags=["-ffp-contract=off"])
    yh64, th64, _ = _run(e64, y, U)
    yh32, th32, _ = _run(e32, y, U)
    rt = float(np.max(np.max(np.abs(th32 - th64), axis=1) / np.max(np.abs(th64), axis=1)))
    ry = float(np.max(np.abs(yh32 - yh64)) / np.max(np.abs(yh64)))
    print(f"{key} float32 vs float64: theta {rt:.3g}, yhat {ry:.3g}")
    assert 0 < rt <= 1e-5
    assert 0 < ry <= 3e-6


def test_float32_fixed_model_error_bounded(tmp_path):
    """Fixed ARX: ŷ in float32 against float64: the offsets, θ and each product and sum
    rounded to float32 (ε₃₂ = 6e-8 relative to terms of the size of ŷ ≈ 20):
    measured 1.1e-7 relative; bound 2e-6 (≈ 15 ×)."""
    y, U = _plant(2000)
    model = ARX(2, 2, 3).fit(IDData(y, U[:, 0]).detrend("constant"))
    yh64 = _run(_build(model, tmp_path / "d", m=1, flags=["-ffp-contract=off"]), y, U)[0]
    yh32 = _run(_build(model, tmp_path / "s", m=1, dtype="float32",
                       flags=["-ffp-contract=off"]), y, U)[0]
    r = float(np.max(np.abs(yh32 - yh64)) / np.max(np.abs(yh64)))
    print(f"fixed ARX float32 vs float64: yhat {r:.3g}")
    assert 0 < r <= 2e-6


def test_cortex_m4_compiles_warning_free(tmp_path):
    obj = RecursiveARX(2, [2, 1], [3, 0])
    for dtype in ("float32", "float64"):
        codegen.to_c(obj, tmp_path, name="mdl", dtype=dtype, offsets=(1.0, [2.0, 3.0]))
        res = subprocess.run([_tool("arm-none-eabi-gcc"), *CFLAGS[:-1], "-mcpu=cortex-m4",
                              "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard", "-Os", "-c",
                              str(tmp_path / "mdl.c"), "-o", str(tmp_path / "mdl.o")],
                             capture_output=True, text=True)
        assert res.returncode == 0 and res.stderr == "", res.stderr


# --------------------------------------------------------------------------- the header
def test_header_documents_the_regressor(tmp_path):
    """The issue's example: ARX [2 2 3] detrended: phi = [-y(k-1), -y(k-2), u(k-3), u(k-4)]
    less the offsets, in a comment and in named constants that a C program can use."""
    y, U = _plant(1000)
    data = IDData(y, U[:, 0]).detrend("constant")
    model = ARX(2, 2, 3).fit(data)
    h, c = codegen.to_c(model, tmp_path, name="dryer")
    head = h.read_text()
    rows = re.findall(r"phi\[(\d)\] = ([-+])\((\w)\(k-(\d)\) - (DRYER_\w+)\)\s+(\w+)", head)
    assert rows == [("0", "-", "y", "1", "DRYER_Y0", "a1"), ("1", "-", "y", "2", "DRYER_Y0", "a2"),
                    ("2", "+", "u", "3", "DRYER_U0_0", "b0"),
                    ("3", "+", "u", "4", "DRYER_U0_0", "b1")]
    assert "theta = [a1, a2, b0, b1]" in head
    prog = tmp_path / "consts.c"
    prog.write_text('#include <stdio.h>\n#include "dryer.h"\nint main(void)\n{\n'
                    '    printf("%d %d %d %d %d %.17g %.17g\\n", DRYER_N, DRYER_NA, DRYER_NB_0, '
                    'DRYER_NK_0, DRYER_PHI_U_0, DRYER_Y0, DRYER_U0_0);\n    return 0;\n}\n')
    exe = tmp_path / "consts"
    res = subprocess.run([_tool("gcc"), *CFLAGS, "-I", str(tmp_path), str(prog), str(c), "-o",
                          str(exe), "-lm"], capture_output=True, text=True)
    assert res.returncode == 0 and res.stderr == "", res.stderr
    vals = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    assert [int(v) for v in vals[:5]] == [4, 2, 2, 3, 2]
    assert float(vals[5]) == data.y_trend[0, 0] and float(vals[6]) == data.u_trend[0, 0]
    np.testing.assert_allclose([float(vals[5]), float(vals[6])], [np.mean(y), np.mean(U)],
                               rtol=1e-13)


def test_streaming_file_keeps_the_estimator_entry(tmp_path):
    """A streaming object's files hold the estimator's own API too (NAME_update …)."""
    h, c = codegen.to_c(RecursiveARX(1, 1, 1), tmp_path, name="s")
    head = h.read_text()
    for decl in ("void s_init(s_t *s);",
                 "double s_update(s_t *s, const double phi[S_N], double y);",
                 "void s_model_init(s_model_t *m);",
                 "double s_step(s_model_t *m, double y, double u);",
                 "s_t est;", "#define S_NK_0 1"):
        assert decl in head
    h2 = codegen.to_c(RecursiveAR(2), tmp_path, name="a")[0].read_text()
    assert "double a_step(a_model_t *m, double y);" in h2 and "A_NU" not in h2
    h3 = codegen.to_c(RecursiveARX(1, [1, 1], [1, 1]), tmp_path, name="t")[0].read_text()
    assert "double t_step(t_model_t *m, double y, const double u[T_NU]);" in h3


# --------------------------------------------------------------------------- refusals
def test_refusals(tmp_path):
    y, U = _plant(400)
    with pytest.raises(ValueError, match="offsets must be given .* non-constant trend"):
        codegen.to_c(ARX(2, 2, 3).fit(IDData(y, U[:, 0]).detrend("linear")), tmp_path)
    # explicit offsets override the recorded trend
    codegen.to_c(ARX(2, 2, 3).fit(IDData(y, U[:, 0]).detrend("linear")), tmp_path,
                 offsets=(20.0, 5.0))
    from adaptid.models import NotFittedError
    with pytest.raises(NotFittedError, match="not fitted"):
        codegen.to_c(ARX(2, 2, 3), tmp_path)
    with pytest.raises(ValueError, match="offsets"):
        codegen.to_c(RecursiveARX(2, [1, 1], [1, 1]), tmp_path, offsets=(0.0, [1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match=r"offsets must be a number y0 \(the model has no"):
        codegen.to_c(RecursiveAR(2), tmp_path, offsets=(0.0, 1.0))
    with pytest.raises(ValueError, match="offsets must be finite"):
        codegen.to_c(RecursiveAR(2), tmp_path, offsets=np.nan)
    with pytest.raises(ValueError, match="offsets must be None for an estimator"):
        codegen.to_c(adaptid.RLS(2), tmp_path, offsets=1.0)
    with pytest.raises(ValueError, match="finite P0"):
        codegen.to_c(RecursiveARX(1, 1, 1, P0="diffuse"), tmp_path)
    with pytest.raises(ValueError, match="single-output ARX"):
        Y = np.column_stack([y, np.roll(y, 1)])
        codegen.to_c(ARX(np.eye(2, dtype=int), np.ones((2, 1), int), np.ones((2, 1), int))
                     .fit(Y, U[:, 0]), tmp_path)
    from adaptid.models import ARMAX
    with pytest.raises(TypeError, match="est must be"):
        codegen.to_c(ARMAX(1, 1, 1, 1).fit(y, U[:, 0]), tmp_path)


# --------------------------------------------------------------------------- the CLI
def test_cli_fit_arx_export_c_model(tmp_path, capsys):
    """adaptid fit --arx 2,2,3 --detrend constant --export-c: the files hold NAME_step with
    the removed means as offsets, continuing the fit's estimator with empty lag buffers
    (start="filled"). Oracle: the Python fit of the same detrended record (ARX's
    fit_recursive with adaptid.RLS(4), as the CLI's default) continued by a
    RecursiveARX(start="filled") holding that estimator: θ at export as the CLI's
    JSON; the C steps on new raw data as Python's step() (bit for bit with FMA)."""
    from adaptid.cli import main
    y, U = _plant(1500)
    np.savetxt(tmp_path / "d.csv", np.column_stack([U[:1000, 0], y[:1000]]), delimiter=",",
               header="pump,temp", comments="", fmt="%.17g")
    flags = _fma_flags() or ["-ffp-contract=off"]
    assert main(["fit", str(tmp_path / "d.csv"), "--y", "temp", "--u", "pump", "--arx", "2,2,3",
                 "--detrend", "constant", "--export-c", str(tmp_path / "c"), "--c-name", "mdl",
                 "-q"]) == 0
    capsys.readouterr()
    head = (tmp_path / "c" / "mdl.h").read_text()
    assert "phi[2] = +(u(k-3) - MDL_U0_0)" in head and "#define MDL_START 4" in head
    data = IDData(y[:1000], U[:1000, 0]).detrend("constant")
    fitted = ARX(2, 2, 3)
    fitted.fit_recursive(data, estimator=adaptid.RLS(4))
    obj = RecursiveARX(2, 2, 3, start="filled")
    state = obj.get_state()
    state["inner"] = fitted.estimator.get_state()
    ref = RecursiveARX.from_state(state)
    y0, u0 = data.y_trend[0, 0], data.u_trend[0, 0]
    np.testing.assert_allclose([y0, u0], [np.mean(y[:1000]), np.mean(U[:1000])], rtol=1e-13)
    steps = [ref.step(y[k] - y0, U[k, 0] - u0) for k in range(1000, 1500)]
    theta = np.array([s[0] for s in steps])
    yhat = np.array([s[1] for s in steps]) + y0
    exe = subprocess.run([_tool("gcc"), *CFLAGS, *flags, "-I", str(tmp_path / "c"), "-x", "c",
                          "-", str(tmp_path / "c" / "mdl.c"), "-o", str(tmp_path / "drv"),
                          "-lm"], input=DRIVER.replace("@name@", "mdl").replace("@N@", "MDL_N")
                         .replace("@M@", "1").replace("@UARG@", ", uu[0]")
                         .replace("@real@", "double"), capture_output=True, text=True)
    assert exe.returncode == 0 and exe.stderr == "", exe.stderr
    yh, th, count = _run(tmp_path / "drv", y[1000:], U[1000:])
    assert count == 500 and np.isnan(yh[:4]).all() and np.isnan(yhat[:4]).all()
    if flags[0] == "-DMDL_USE_FMA":
        np.testing.assert_array_equal(th, theta)
        np.testing.assert_array_equal(yh, yhat)
    np.testing.assert_allclose(th, theta, rtol=1e-12)
    np.testing.assert_allclose(th[-1], [-1.2, 0.45, 0.8, 0.3], atol=0.05)


def test_cli_export_c_refuses_linear_detrend(tmp_path, capsys):
    from adaptid.cli import main
    y, U = _plant(300)
    np.savetxt(tmp_path / "d.csv", np.column_stack([U[:, 0], y]), delimiter=",",
               header="pump,temp", comments="")
    assert main(["fit", str(tmp_path / "d.csv"), "--y", "temp", "--u", "pump", "--arx", "2,2,3",
                 "--detrend", "linear", "--export-c", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--detrend linear" in err[0]
    assert not (tmp_path / "c").exists()


def test_docs_section_runs(tmp_path, monkeypatch):
    """docs/embedded.md, "C for a model": the Python block exports, the header excerpt
    is the generated header's text line for line, the C block compiles warning-free."""
    from pathlib import Path
    page = (Path(__file__).resolve().parents[2] / "docs" / "embedded.md").read_text()
    sec = page[page.index("## C for a model"):]
    sec = sec[: sec.index("\n## ", 1)]
    py = re.findall(r"^```python\n(.*?)^```", sec, re.S | re.M)
    text = re.findall(r"^```text\n(.*?)^```", sec, re.S | re.M)
    c = re.findall(r"^```c\n(.*?)^```", sec, re.S | re.M)
    monkeypatch.chdir(tmp_path)
    exec(compile(py[0], "embedded.md", "exec"), {"__name__": "docs_embedded_models"})
    head = (tmp_path / "firmware" / "dryer.h").read_text().splitlines()
    for line in text[0].splitlines():
        assert line == " ..." or line in head, line
    (tmp_path / "control.c").write_text(c[0])
    res = subprocess.run([_tool("gcc"), *CFLAGS, "-Ifirmware", "-c", "control.c", "-o",
                          "control.o"], capture_output=True, text=True)
    assert res.returncode == 0 and res.stderr == "", res.stderr


@pytest.mark.parametrize("structure,m", [(["--ar", "3"], 0), (["--fir", "3,2", "--u", "pump"], 1),
                                         (["--arx", "2,2,3", "--u", "pump,fan"], 2)])
def test_cli_export_c_other_structures(tmp_path, capsys, structure, m):
    """--ar, --fir and two inputs: the model entry continues the fit's estimator; C steps
    on new raw data = Python's step() of the streaming object holding the estimator of
    the same fit in Python (ARX(0, nb, nk) for FIR), bit for bit with FMA."""
    from adaptid.cli import main
    y, U = _plant(1300, m=2)
    cols = {"pump": U[:, 0], "fan": U[:, 1], "temp": y}
    np.savetxt(tmp_path / "d.csv", np.column_stack(list(cols.values()))[:1000], delimiter=",",
               header=",".join(cols), comments="", fmt="%.17g")
    assert main(["fit", str(tmp_path / "d.csv"), "--y", "temp", *structure, "--detrend",
                 "constant", "--forgetting", "0.995", "--export-c", str(tmp_path / "c"),
                 "--c-name", "mdl", "-q"]) == 0
    capsys.readouterr()
    data = IDData(y[:1000], U[:1000, :m] if m else None).detrend("constant")
    if m == 0:
        fitted, obj = AR(3), RecursiveAR(3, start="filled")
    elif m == 1:
        fitted, obj = ARX(0, 3, 2), RecursiveARX(0, 3, 2, start="filled")
    else:
        fitted, obj = ARX(2, [2, 2], [3, 3]), RecursiveARX(2, [2, 2], [3, 3], start="filled")
    fitted.fit_recursive(data, estimator=adaptid.RLS(obj.n_params, forgetting=0.995))
    state = obj.get_state()
    state["inner"] = fitted.estimator.get_state()
    ref = type(obj).from_state(state)
    y0, u0 = data.y_trend[0, 0], data.u_trend[0, :m]
    steps = [ref.step(y[k] - y0, *((U[k, 0] - u0[0],) if m == 1 else (U[k, :m] - u0,) if m
                                   else ())) for k in range(1000, 1300)]
    theta = np.array([s[0] for s in steps])
    yhat = np.array([s[1] for s in steps]) + y0
    flags = _fma_flags() or ["-ffp-contract=off"]
    drv = (DRIVER.replace("@name@", "mdl").replace("@N@", "MDL_N").replace("@M@", str(m))
           .replace("@UARG@", "" if m == 0 else ", uu[0]" if m == 1 else ", uu")
           .replace("@real@", "double"))
    res = subprocess.run([_tool("gcc"), *CFLAGS, *flags, "-I", str(tmp_path / "c"), "-x", "c",
                          "-", str(tmp_path / "c" / "mdl.c"), "-o", str(tmp_path / "drv"),
                          "-lm"], input=drv, capture_output=True, text=True)
    assert res.returncode == 0 and res.stderr == "", res.stderr
    yh, th, count = _run(tmp_path / "drv", y[1000:], U[1000:, :m])
    assert count == 300 and np.isnan(yh).sum() == np.isnan(yhat).sum() > 0
    np.testing.assert_allclose(th, theta, rtol=1e-12)
    if flags[0] == "-DMDL_USE_FMA":
        np.testing.assert_array_equal(th, theta)
        np.testing.assert_array_equal(yh, yhat)


def test_cli_export_c_intercept_writes_the_estimator_only(tmp_path, capsys):
    from adaptid.cli import main
    y, U = _plant(300)
    np.savetxt(tmp_path / "d.csv", np.column_stack([U[:, 0], y]), delimiter=",",
               header="pump,temp", comments="")
    assert main(["fit", str(tmp_path / "d.csv"), "--y", "temp", "--u", "pump", "--arx", "1,1,1",
                 "--intercept", "--export-c", str(tmp_path / "c"), "-q"]) == 0
    capsys.readouterr()
    head = (tmp_path / "c" / "rls.h").read_text()
    assert "rls_update(" in head and "rls_step" not in head


def test_nan_measurement_in_c(tmp_path):
    """The documented C behaviour (Python's step refuses NaN): a NaN y(k) is skipped by the
    estimator, sits in the buffer for na samples (ŷ NaN, θ unchanged, each skipped), then
    the model continues from the same θ."""
    y, U = _plant(400)
    y[200] = np.nan
    obj = RecursiveARX(2, 2, 3, forgetting=0.99)
    yh, th, count = _run(_build(obj, tmp_path, m=1, offsets=(20.0, 5.0),
                                flags=["-ffp-contract=off"]), y, U)
    assert np.isfinite(yh[200]) and np.isnan(yh[201:203]).all() and np.isfinite(yh[203:]).all()
    np.testing.assert_array_equal(th[200], th[199])
    np.testing.assert_array_equal(th[202], th[199])
    assert not np.array_equal(th[203], th[202]) and np.all(np.isfinite(th))


def test_export_c_command_reads_a_stream_state_file(tmp_path):
    """adaptid export-c on a RecursiveARX state file writes the model entry (no offsets:
    a state file does not record them), the same text as to_c of the object."""
    import sys
    y, U = _plant(500)
    obj = RecursiveARX(2, 2, 3, forgetting=0.99)
    obj.run(y - 20.0, U[:, 0] - 5.0)
    obj.save_state(tmp_path / "s.npz")
    r = subprocess.run([sys.executable, "-m", "adaptid", "export-c", str(tmp_path / "s.npz"),
                        "--out", str(tmp_path / "c"), "--name", "dry"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    want = codegen.to_c(obj, tmp_path / "py", name="dry")
    assert (tmp_path / "c" / "dry.h").read_text() == want[0].read_text()
    assert (tmp_path / "c" / "dry.c").read_text() == want[1].read_text()
    assert "#define DRY_Y0 0.0" in want[0].read_text()
