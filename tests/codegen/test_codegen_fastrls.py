"""Generated C of FastRLS (adaptid.codegen.to_c, issue 38) compiled and run.

The oracle is FastRLS.run_fir continued from the exported state (itself
tested against RLS and the closed-form weighted least squares in
tests/estimators/test_fastrls.py). The C code rounds every product where the
kernel fuses a*b + c (numba fastmath "contract"), so float64 agrees to
rounding: 1e-10 relative over the record (the FTF's error feedback keeps the
difference at the level of a few ulps amplified by the conditioning of the
coloured input). float32 is held to the closed-form bound of its own
precision against the float64 errors (see the test).
"""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

import adaptid

CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-ffp-contract=off"]

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>
#include "@name@.h"

/* reads [int64 N | u (N) | y (N)] as doubles, writes per sample
 * [a-priori error | theta (n)] as doubles, then prints the counters */
int main(int argc, char **argv)
{
    FILE *in, *out;
    int64_t N;
    double *u, *y, row[@N@ + 1];
    @real@ th[@N@];
    @name@_t s;
    long k;
    int i;
    if (argc != 3 || !(in = fopen(argv[1], "rb"))) return 2;
    if (fread(&N, sizeof N, 1, in) != 1) return 3;
    u = malloc(sizeof(double) * (size_t)N);
    y = malloc(sizeof(double) * (size_t)N);
    if (!u || !y) return 4;
    if (fread(u, sizeof(double), (size_t)N, in) != (size_t)N) return 5;
    if (fread(y, sizeof(double), (size_t)N, in) != (size_t)N) return 5;
    fclose(in);
    if (!(out = fopen(argv[2], "wb"))) return 6;
    @name@_init(&s);
    for (k = 0; k < N; k++) {
        row[0] = (double)@name@_update(&s, (@real@)u[k], (@real@)y[k]);
        @name@_theta(&s, th);
        for (i = 0; i < @N@; i++) row[i + 1] = (double)th[i];
        fwrite(row, sizeof(double), @N@ + 1, out);
    }
    fclose(out);
    printf("%llu %llu %llu %.17g\n", (unsigned long long)s.n_updates,
           (unsigned long long)s.n_skipped, (unsigned long long)s.n_rescues,
           (double)@name@_predict(&s, (@real@)0.5));
    return 0;
}
"""


def build_and_run(tmp_path, est, u, y, dtype="float64", name="fir"):
    h, c = est.to_c(tmp_path, name=name, dtype=dtype)
    n = est.n_taps
    real = "double" if dtype == "float64" else "float"
    drv = tmp_path / "driver.c"
    drv.write_text(DRIVER.replace("@name@", name).replace("@N@", str(n)).replace("@real@", real))
    exe = tmp_path / "run"
    subprocess.run([shutil.which("gcc"), *CFLAGS, "-I", str(tmp_path), str(c), str(drv), "-lm",
                    "-o", str(exe)], check=True, capture_output=True, text=True)
    data = tmp_path / "in.bin"
    with open(data, "wb") as fh:
        np.array([u.shape[0]], dtype=np.int64).tofile(fh)
        u.astype(np.float64).tofile(fh)
        y.astype(np.float64).tofile(fh)
    res = subprocess.run([str(exe), str(data), str(tmp_path / "out.bin")], check=True,
                         capture_output=True, text=True)
    out = np.fromfile(tmp_path / "out.bin").reshape(-1, n + 1)
    upd, skip, resc, pred = res.stdout.split()
    return out[:, 0], out[:, 1:], int(upd), int(skip), int(resc), float(pred)


def coloured(rng, N, n):
    w = rng.standard_normal(N)
    u = np.zeros(N)
    for k in range(N):  # AR(1), pole 0.8
        u[k] = w[k] + (0.8 * u[k - 1] if k else 0.0)
    return u, np.convolve(u, rng.standard_normal(n))[:N] + 0.05 * rng.standard_normal(N)


@pytest.mark.parametrize("n", [1, 5, 24])
def test_generated_ftf_continues_the_estimator(tmp_path, n):
    assert shutil.which("gcc"), "gcc is required (as for tests/codegen/test_codegen.py)"
    rng = np.random.default_rng(n)
    u, y = coloured(rng, 6000, n)
    u[3000], y[4000] = np.nan, np.inf  # skipped in C as in nan_policy="skip"
    est = adaptid.FastRLS(n, forgetting=0.995, delta=0.1, nan_policy="skip")
    est.run_fir(u[:1000], y[:1000])
    e_c, th_c, upd, skip, resc, pred = build_and_run(tmp_path, est, u[1000:], y[1000:])
    ref = est.run_fir(u[1000:], y[1000:])
    assert upd == est.n_updates and skip == est.n_skipped == 2 and resc == est.n_rescues == 0
    assert np.array_equal(np.isnan(e_c), ref.skipped)
    ok = ~ref.skipped
    assert np.max(np.abs(e_c[ok] - ref.error[ok])) <= 1e-10 * np.max(np.abs(ref.error[ok]))
    assert np.max(np.abs(th_c - ref.theta)) <= 1e-10 * np.max(np.abs(ref.theta))
    phi = np.concatenate([[0.5], est.delay_line[:-1]])
    assert abs(pred - est.predict(phi)) <= 1e-10 * (1 + abs(pred))


def test_generated_float32_stays_near_float64(tmp_path):
    rng = np.random.default_rng(3)
    n = 8
    u, y = coloured(rng, 20000, n)
    est = adaptid.FastRLS(n, forgetting=0.99, delta=1.0)  # 1 - 1/(2n) = 0.9375 <= λ
    e64 = est.copy().run_fir(u, y).error
    e32, th32, upd, _, resc, _ = build_and_run(tmp_path, est, u, y, dtype="float32")
    # float32 has 2^-24 ≈ 6e-8 relative rounding; the filter's error feedback keeps
    # the accumulated difference bounded. 1e-3 of the error scale over 20 000
    # samples is a loose bound (measured ≈ 1.5e-6); a drift or a divergence would
    # exceed it by orders of magnitude.
    assert upd == u.shape[0]
    assert np.max(np.abs(e32 - e64)) <= 1e-3 * np.max(np.abs(e64))
    assert np.all(np.isfinite(th32))


def test_refusals(tmp_path):
    est = adaptid.FastRLS(3)
    est.run_batched(np.zeros((2, 4, 3)), np.zeros((2, 4)))
    with pytest.raises(ValueError, match="single-stream"):
        adaptid.codegen.to_c(est, tmp_path)
    with pytest.raises(ValueError, match="dtype"):
        adaptid.FastRLS(3).to_c(tmp_path, dtype="float16")
    with pytest.raises(ValueError):
        adaptid.FastRLS(3).to_c(tmp_path, name="1bad")
