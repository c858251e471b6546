"""Generated C of a NARX predictor (adaptid.codegen.to_c of a NARX) against the model.

The oracles are ``NARX.predict(k=1)`` and ``NARX.simulate``, whose compiled sums
are themselves checked against plain Python loops in
tests/models/nonlinear/test_narx_kernels.py. The C code is written from
templates, compiled with the host gcc (a missing compiler is a failure, as in
test_codegen.py) and run on the same records:

* float64 with ``-ffp-contract=off``: the same operations in the same order
  (no FMA on either side), so the one-step predictions and the free run are
  bit for bit the model's; a NARMAX's noise terms are added after the process
  part (predict's own dot product), so they agree to rounding (≤ 1e-13);
* float32: the same code in single precision, relative to the double one
  within 1e-4 of the signal's range (measured ≈ 1e-6);
* arm-none-eabi-gcc for a Cortex-M4F: compiles warning-free.
"""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

from adaptid import IDData, codegen
from adaptid.models import NARX, RecursiveNARX

CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-ffp-contract=off"]
M4FLAGS = ["-mcpu=cortex-m4", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard", "-Os"]

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>
#include "@name@.h"

/* reads [int64 N, p, m, free, L0 | Y (N x p) | U (N x m)] as doubles; writes yhat (N x p).
 * free = 0: y(k) measured at every step; free = 1: measured for k < L0, NULL after. */
int main(int argc, char **argv)
{
    FILE *in, *out;
    int64_t hdr[5];
    double *Y, *U, row[@U@_P + 1];
    @real@ y[@U@_P + 1], u[@U@_M + 1], yh[@U@_P + 1];
    @name@_t s;
    long k, n;
    int i;
    if (argc != 3 || !(in = fopen(argv[1], "rb"))) return 2;
    if (fread(hdr, sizeof hdr, 1, in) != 1 || hdr[1] != @U@_P || hdr[2] != @U@_M) return 3;
    n = (long)hdr[0];
    Y = malloc(sizeof(double) * (size_t)(n * @U@_P));
    U = malloc(sizeof(double) * (size_t)(n * @U@_M + 1));
    if (!Y || !U) return 4;
    if (fread(Y, sizeof(double), (size_t)(n * @U@_P), in) != (size_t)(n * @U@_P)) return 5;
    if (fread(U, sizeof(double), (size_t)(n * @U@_M), in) != (size_t)(n * @U@_M)) return 5;
    fclose(in);
    if (!(out = fopen(argv[2], "wb"))) return 6;
    @name@_init(&s);
    for (k = 0; k < n; k++) {
        for (i = 0; i < @U@_P; i++) y[i] = (@real@)Y[k * @U@_P + i];
        for (i = 0; i < @U@_M; i++) u[i] = (@real@)U[k * @U@_M + i];
        @name@_step(&s, (hdr[3] && k >= hdr[4]) ? NULL : y, @U@_M ? u : NULL, yh);
        for (i = 0; i < @U@_P; i++) row[i] = (double)yh[i];
        if (fwrite(row, sizeof(double), @U@_P, out) != @U@_P) return 7;
    }
    fclose(out);
    free(Y);
    free(U);
    return 0;
}
"""


def _tool(name):
    path = shutil.which(name)
    if path is None:  # a failure, not a skip: .ci/run installs the toolchains
        pytest.fail(f"{name} not found: install gcc and gcc-arm-none-eabi (see .ci/run)")
    return path


def _build(model, folder, *, dtype="float64", name="plant"):
    folder.mkdir(parents=True, exist_ok=True)
    codegen.to_c(model, folder, name=name, dtype=dtype)
    real = "double" if dtype == "float64" else "float"
    drv = DRIVER.replace("@name@", name).replace("@U@", name.upper()).replace("@real@", real)
    (folder / "driver.c").write_text(drv)
    exe = folder / f"drv-{dtype}"
    res = subprocess.run([_tool("gcc"), *CFLAGS, "-I", str(folder), str(folder / "driver.c"),
                          str(folder / f"{name}.c"), "-o", str(exe), "-lm"],
                         capture_output=True, text=True)
    assert res.returncode == 0 and res.stderr == "", res.stderr  # warning-free
    return exe


def _run(exe, Y, U, free=False, L0=0):
    Y = np.reshape(Y, (Y.shape[0], -1))
    U = np.reshape(U, (Y.shape[0], -1))
    inp, out = exe.with_suffix(".in"), exe.with_suffix(".out")
    with open(inp, "wb") as fh:
        np.array([Y.shape[0], Y.shape[1], U.shape[1], int(free), L0], dtype=np.int64).tofile(fh)
        np.ascontiguousarray(Y, dtype=float).tofile(fh)
        np.ascontiguousarray(U, dtype=float).tofile(fh)
    res = subprocess.run([str(exe), str(inp), str(out)], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 0, res.stderr
    return np.fromfile(out).reshape(Y.shape)


def miso(N=3000, seed=0, noise=0.02):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (N, 2))
    y = np.zeros(N)
    y[:3] = 0.3
    for k in range(3, N):
        y[k] = (0.1 + 0.5 * y[k - 1] - 0.2 * y[k - 2] + 0.8 * u[k - 1, 0]
                - 0.3 * u[k - 2, 0] * y[k - 1] + 0.1 * u[k - 1, 1] ** 2 * y[k - 2]
                + 0.05 * u[k - 3, 1] ** 3 + noise * rng.standard_normal())
    return y, u


@pytest.fixture(scope="module")
def model():
    y, u = miso()
    return NARX(3, 3, 3, n_terms=10).fit(y, u), y, u


def test_one_step_and_free_run_bit_for_bit(model, tmp_path):
    m, y, u = model
    exe = _build(m, tmp_path)
    np.testing.assert_array_equal(_run(exe, y, u)[:, 0], m.predict(y, u))
    L = m.max_lag
    sim = _run(exe, y, u, free=True, L0=L)[:, 0]
    np.testing.assert_array_equal(sim, m.simulate(u, y0=y))
    assert np.std(sim[L:] - y[L:]) < 0.2  # a real simulation, not the record echoed
    # the free run from zeros: the C code with y = NULL from the first sample
    np.testing.assert_array_equal(_run(exe, y, u, free=True, L0=0)[:, 0], m.simulate(u))


def test_mimo_time_series_and_input_without_delay(tmp_path):
    rng = np.random.default_rng(4)
    N = 500
    u = rng.uniform(-1, 1, N)
    y = np.zeros((N, 2))
    for k in range(1, N):
        y[k, 0] = 0.5 * y[k - 1, 0] + u[k] + 0.2 * y[k - 1, 1] * u[k - 1]
        y[k, 1] = 0.3 * y[k - 1, 1] - 0.4 * y[k - 1, 0] ** 2 + 0.1
    d = IDData(y, u, y_names=["a", "b"], u_names="f")
    m = NARX(1, 2, 2, nk=0).fit(d)
    exe = _build(m, tmp_path / "mimo")
    np.testing.assert_array_equal(_run(exe, y, u), m.predict(d))
    np.testing.assert_array_equal(_run(exe, y, u, free=True, L0=m.max_lag), m.simulate(d))
    # a time series: no input at all (u = NULL)
    z = np.zeros(300)
    z[0] = 0.3
    for k in range(1, 300):
        z[k] = 3.7 * z[k - 1] * (1 - z[k - 1])
    ts = NARX(1, 0, 2).fit(z)
    exe = _build(ts, tmp_path / "ts", name="logistic")
    np.testing.assert_array_equal(_run(exe, z, np.zeros((300, 0)))[:, 0], ts.predict(z))
    np.testing.assert_array_equal(_run(exe, z, np.zeros((300, 0)), free=True, L0=1)[:, 0],
                                  ts.simulate(300, y0=z))


def test_narmax_noise_terms_to_rounding(tmp_path):
    rng = np.random.default_rng(5)
    N = 3000
    u = rng.uniform(-1, 1, N)
    e = 0.05 * rng.standard_normal(N)
    y = np.zeros(N)
    for k in range(1, N):
        y[k] = 0.5 * y[k - 1] + u[k - 1] - 0.3 * u[k - 1] * y[k - 1] + e[k] + 0.6 * e[k - 1]
    m = NARX(1, 1, 2, n_terms=3, noise_lags=2).fit(y, u)
    exe = _build(m, tmp_path)
    np.testing.assert_allclose(_run(exe, y, u)[:, 0], m.predict(y, u), rtol=0, atol=1e-13)
    np.testing.assert_array_equal(_run(exe, y, u, free=True, L0=1)[:, 0], m.simulate(u, y0=y))


def test_float32_close_to_float64(model, tmp_path):
    m, y, u = model
    e64 = _run(_build(m, tmp_path / "d"), y, u, free=True, L0=m.max_lag)[:, 0]
    e32 = _run(_build(m, tmp_path / "s", dtype="float32"), y, u, free=True,
               L0=m.max_lag)[:, 0]
    assert "float THETA" in (tmp_path / "s" / "plant.c").read_text()
    assert np.max(np.abs(e32 - e64)) < 1e-4 * np.ptp(e64)


def test_recursive_narx_exports_its_current_model(model, tmp_path):
    m, y, u = model
    obj = RecursiveNARX(m, forgetting=0.999)
    obj.run((y, u))
    exe = _build(obj, tmp_path)
    np.testing.assert_array_equal(_run(exe, y, u)[:, 0], obj.to_model().predict(y, u))


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_cortex_m4_compiles_warning_free(model, tmp_path, dtype):
    m = model[0]
    codegen.to_c(m, tmp_path, name="plant", dtype=dtype)
    res = subprocess.run([_tool("arm-none-eabi-gcc"), *CFLAGS[:-1], *M4FLAGS, "-c",
                          str(tmp_path / "plant.c"), "-o", str(tmp_path / "plant.o")],
                         capture_output=True, text=True)
    assert res.returncode == 0 and res.stderr == "", res.stderr


def test_refusals(model, tmp_path):
    m = model[0]
    with pytest.raises(ValueError, match="est must be a fitted NARX"):
        codegen.to_c(NARX(1, 1), tmp_path)
    with pytest.raises(ValueError, match="name"):
        codegen.to_c(m, tmp_path, name="math")
    with pytest.raises(ValueError, match="dtype"):
        codegen.to_c(m, tmp_path, name="plant", dtype="float16")
    assert not any(tmp_path.iterdir())  # nothing written on a refusal
    h, c = codegen.to_c(m, tmp_path, name="plant")
    assert (h.name, c.name) == ("plant.h", "plant.c")
    assert "void plant_step(plant_t *s, const double *y, const double *u, double *yhat);" \
        in h.read_text()


def test_cli_export_c_of_a_streaming_narx_state_file(model, tmp_path, capsys):
    """``adaptid export-c`` reads a RecursiveNARX state file and writes its current
    model's predictor (the same text as to_c of to_model)."""
    from adaptid.cli import main
    from adaptid.codegen._narx import generate_narx

    m, y, u = model
    obj = RecursiveNARX(m, forgetting=0.999)
    obj.run((y[:500], u[:500]))
    obj.save_state(tmp_path / "narx.npz")
    assert main(["export-c", str(tmp_path / "narx.npz"), "--out", str(tmp_path / "c"),
                 "--name", "plant"]) == 0
    assert (tmp_path / "c" / "plant.c").read_text() == generate_narx(obj, name="plant")[1]
    capsys.readouterr()
