"""Generated C of the QR-lattice FastRLS and the input delay nk (adaptid.codegen.to_c).

The oracle is FastRLS.run_fir continued from the exported state (itself tested
against RLS, the closed-form weighted least squares and SLICOT FD01AD's
published example in tests/estimators/), fed with the input delayed by nk
samples, v_k = u_(k-nk), where the C code is fed the raw u and keeps the
nk-sample buffer.

Tolerances. The kernel is compiled with fastmath "contract" (LLVM may fuse
a*b + c into one FMA), the C code with -ffp-contract=off rounds every product:
the same operations in the same order, but not bit for bit. The lattice is
rotations only (backward stable), so the difference stays at rounding level:
float64 errors and θ within 1e-10 relative to their scale over the record
(measured about 1e-14 for n = 5 ... 64). That the C code performs the kernel's
operations in the kernel's order, each rounded, is shown bit for bit against a
transcription of the kernel in NumPy scalars (float32 and float64), which in
turn is the kernel to 1e-12.
The ARM build (qemu-arm) and the host build, both without contraction and
both IEEE double, are bit for bit equal. float32 equals the float32 NumPy
transcription bit for bit and stays within 1e-4 of the float64 run (see the
test). The Cortex-M4F build is warning-free, with no double promotion in
float32.
"""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

import adaptid
from adaptid import codegen

CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-ffp-contract=off"]

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>
#include "@name@.h"

/* reads [int64 N | u (N) | y (N)] as doubles, writes per sample
 * [a-priori error | theta (n), if tracked] as doubles, then prints the
 * counters and the prediction for a next raw input 0.5 */
int main(int argc, char **argv)
{
    FILE *in, *out;
    int64_t N;
    double *u, *y, row[@N@ + 1];
    @name@_t s;
    long k;
    int i, w = @TRACK@ ? @N@ + 1 : 1;
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
#if @TRACK@
        {
            @real@ th[@N@];
            @name@_theta(&s, th);
            for (i = 0; i < @N@; i++) row[i + 1] = (double)th[i];
        }
#endif
        fwrite(row, sizeof(double), (size_t)w, out);
    }
    (void)i;
    fclose(out);
    printf("%llu %llu %llu %.17g\n", (unsigned long long)s.n_updates,
           (unsigned long long)s.n_skipped, (unsigned long long)s.n_rescues,
           (double)@name@_predict(&s, (@real@)0.5));
    return 0;
}
"""


def _tool(name):
    path = shutil.which(name)
    if path is None:  # a failure, not a skip, as in tests/codegen/test_codegen.py
        pytest.fail(f"{name} not found: run tools/system-deps.sh")
    return path


def build(folder, est, *, dtype="float64", nk=0, pending=None, cc="gcc", flags=(),
          name="lat"):
    folder.mkdir(parents=True, exist_ok=True)
    codegen.to_c(est, folder, name=name, dtype=dtype, nk=nk, pending=pending)
    real = "double" if dtype == "float64" else "float"
    track = int(est.track_theta)
    drv = folder / "driver.c"
    drv.write_text(DRIVER.replace("@name@", name).replace("@N@", str(est.n_taps))
                   .replace("@real@", real).replace("@TRACK@", str(track)))
    exe = folder / f"run-{cc}"
    res = subprocess.run([_tool(cc), *CFLAGS, *flags, "-I", str(folder), str(folder / f"{name}.c"),
                          str(drv), "-lm", "-o", str(exe)], capture_output=True, text=True)
    assert res.returncode == 0 and res.stderr == "", res.stderr  # warning-free
    return exe, track


def run(exe, track, n, u, y, runner=()):
    data = exe.with_suffix(".in")
    with open(data, "wb") as fh:
        np.array([u.shape[0]], dtype=np.int64).tofile(fh)
        u.astype(np.float64).tofile(fh)
        y.astype(np.float64).tofile(fh)
    res = subprocess.run([*runner, str(exe), str(data), str(exe.with_suffix(".out"))],
                         check=True, capture_output=True, text=True)
    out = np.fromfile(exe.with_suffix(".out")).reshape(-1, n + 1 if track else 1)
    upd, skip, resc, pred = res.stdout.split()
    return out[:, 0], out[:, 1:], (int(upd), int(skip), int(resc)), float(pred)


def coloured(rng, N, n):
    w = rng.standard_normal(N)
    u = np.zeros(N)
    for k in range(N):  # AR(1), pole 0.8
        u[k] = w[k] + (0.8 * u[k - 1] if k else 0.0)
    return u, np.convolve(u, rng.standard_normal(n))[:N] + 0.05 * rng.standard_normal(N)


def delayed(u, y, nk, pending):
    """The oracle's record: complete rows only (a skipped sample enters neither the
    buffer nor the line), the input delayed by nk behind the pending inputs; and the
    inputs still pending at the end."""
    ok = np.isfinite(u) & np.isfinite(y)
    seq = np.concatenate([pending, u[ok]])
    return seq[: ok.sum()], y[ok], ok, seq[seq.shape[0] - nk:]


def predicted(est, v_next):
    """ŷ of the next sample from the Python filter: y − e of an update with any y."""
    phi = np.concatenate([[v_next], est.delay_line[:-1]])
    return 1.0 - est.copy().update(phi, 1.0)


def _rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.mark.parametrize("n,track,nk", [(1, True, 0), (5, True, 0), (24, True, 0),
                                        (5, False, 0), (24, False, 0), (6, True, 3),
                                        (6, False, 1)])
def test_generated_lattice_continues_the_estimator(tmp_path, n, track, nk):
    rng = np.random.default_rng(n + 10 * nk)
    u, y = coloured(rng, 6000, n)
    u[3000], y[4000] = np.nan, np.inf  # skipped in C as with nan_policy="skip"
    theta0 = rng.standard_normal(n) if n == 5 else None  # the prior mean enters the joint process
    est = adaptid.FastRLS(n, forgetting=0.995, delta=0.1, method="lattice", nan_policy="skip",
                          theta0=theta0, track_theta=track)
    v, yy, _, pending = delayed(u[:1000], y[:1000], nk, np.zeros(nk))
    est.run_fir(v, yy)
    exe, _ = build(tmp_path, est, nk=nk, pending=pending)
    e_c, th_c, counts, pred = run(exe, track, n, u[1000:], y[1000:])
    v, yy, ok, pending = delayed(u[1000:], y[1000:], nk, pending)
    ref = est.run_fir(v, yy, store_theta=track)
    assert counts == (est.n_updates, 2, 0)  # the oracle got the complete rows only
    assert np.array_equal(np.isfinite(e_c), ok)
    assert _rel(e_c[ok], ref.error) <= 1e-10
    if track:
        assert _rel(th_c[ok], ref.theta) <= 1e-10
        assert np.array_equal(th_c[3000 - 1000], th_c[3000 - 1001])  # skipped: θ unchanged
        assert _rel(th_c[-1], est.theta) <= 1e-10
    v_next = pending[0] if nk else 0.5
    assert abs(pred - predicted(est, v_next)) <= 1e-10 * (1 + abs(pred))
    if track:
        phi = np.concatenate([[v_next], est.delay_line[:-1]])
        assert abs(pred - est.predict(phi)) <= 1e-10 * (1 + abs(pred))


@pytest.mark.parametrize("nk", [1, 4])
def test_generated_ftf_with_input_delay(tmp_path, nk):
    """The FTF export with the nk buffer: as FastRLS.run_fir on the delayed input."""
    n = 5
    rng = np.random.default_rng(nk)
    u, y = coloured(rng, 5000, n)
    u[2500] = np.nan
    est = adaptid.FastRLS(n, forgetting=0.995, delta=0.1, nan_policy="skip")
    v, yy, _, pending = delayed(u[:1000], y[:1000], nk, np.zeros(nk))
    est.run_fir(v, yy)
    exe, _ = build(tmp_path, est, nk=nk, pending=pending, name="fir")
    h = (tmp_path / "fir.h").read_text()
    assert f"#define FIR_NK {nk}" in h and "u_(k-NK)" in h and "double ubuf[FIR_NK]" in h
    e_c, th_c, counts, pred = run(exe, True, n, u[1000:], y[1000:])
    v, yy, ok, pending = delayed(u[1000:], y[1000:], nk, pending)
    ref = est.run_fir(v, yy)
    assert counts == (est.n_updates, 1, 0)
    assert np.array_equal(np.isfinite(e_c), ok)
    assert _rel(e_c[ok], ref.error) <= 1e-10 and _rel(th_c[ok], ref.theta) <= 1e-10
    phi = np.concatenate([[pending[0]], est.delay_line[:-1]])
    assert abs(pred - est.predict(phi)) <= 1e-10 * (1 + abs(pred))


def test_generated_lattice_float32_stays_near_float64(tmp_path):
    rng = np.random.default_rng(3)
    n = 8
    u, y = coloured(rng, 20000, n)
    est = adaptid.FastRLS(n, forgetting=0.99, delta=1.0, method="lattice")
    ref = est.copy().run_fir(u, y)
    exe, track = build(tmp_path, est, dtype="float32")
    e32, th32, counts, _ = run(exe, track, n, u, y)
    # float32 rounds to 2^-24 ≈ 6e-8 relative; the lattice is rotations only
    # (backward stable), so the float32 run is the exact solution of a problem
    # perturbed at that level: 1e-4 of the scale over 20 000 samples is a loose
    # bound (measured 5e-6 for the errors, 3e-6 for θ); a drift or a loss of
    # stability would exceed it by orders of magnitude.
    assert counts[0] == u.shape[0]
    assert np.max(np.abs(e32 - ref.error)) <= 1e-4 * np.max(np.abs(ref.error))
    assert np.max(np.abs(th32 - ref.theta)) <= 1e-4 * np.max(np.abs(ref.theta))


@pytest.mark.parametrize("method,track", [("lattice", True), ("lattice", False), ("ftf", True)])
def test_arm_linux_qemu_same_as_host(tmp_path, method, track):
    """arm-linux-gnueabihf-gcc -static under qemu-arm: the host's errors and θ bit for bit
    (both without contraction; IEEE double on both, the same operation order)."""
    n, nk = 6, 2
    rng = np.random.default_rng(7)
    u, y = coloured(rng, 3000, n)
    est = adaptid.FastRLS(n, forgetting=0.99, delta=0.1, method=method, track_theta=track)
    est.run_fir(u[:500], y[:500])
    host, _ = build(tmp_path / "host", est, nk=nk)
    arm, _ = build(tmp_path / "arm", est, nk=nk, cc="arm-linux-gnueabihf-gcc", flags=["-static"])
    a = run(host, track, n, u[500:], y[500:])
    b = run(arm, track, n, u[500:], y[500:], runner=[_tool("qemu-arm")])
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert a[2:] == b[2:]


def test_header_documents_the_lattice(tmp_path):
    est = adaptid.FastRLS(4, method="lattice")
    h, c = codegen.to_c(est, tmp_path, name="echo", nk=2, pending=[0.5, -1.0])
    text = h.read_text()
    for needle in ("#define ECHO_N 4", "#define ECHO_NK 2", "#define ECHO_TRACK 1",
                   "phi_k = [v_k, v_(k-1), ..., v_(k-n+1)]", "v_k = u_(k-NK)",
                   "echo_update(s, u, y)", "echo_predict(s, u)", "R theta = z",
                   "double ubuf[ECHO_NK]",
                   "void echo_theta(const echo_t *s, double theta[ECHO_N]);"):
        assert needle in text, needle
    assert "0.5, -1.0" in c.read_text()
    h, _ = codegen.to_c(adaptid.FastRLS(4, method="lattice", track_theta=False), tmp_path,
                        name="echo2", dtype="float32")
    text = h.read_text()
    assert "#define ECHO2_TRACK 0" in text and "echo2_theta(" not in text.split("*/")[-1]
    assert "ubuf" not in text.split("*/")[-1]


def test_delay_refusals(tmp_path):
    est = adaptid.FastRLS(3, method="lattice")
    with pytest.raises(ValueError, match="nk"):
        codegen.to_c(est, tmp_path, nk=-1)
    with pytest.raises(ValueError, match="pending"):
        codegen.to_c(est, tmp_path, nk=2, pending=[1.0])
    with pytest.raises(ValueError, match="pending"):
        codegen.to_c(est, tmp_path, nk=1, pending=[np.nan])
    with pytest.raises(ValueError, match="FastRLS"):
        codegen.to_c(adaptid.RLS(2), tmp_path, nk=1)
    with pytest.raises(ValueError, match="float32"):
        codegen.to_c(adaptid.FastRLS(2, method="lattice", theta0=[1e39, 0.0]), tmp_path,
                     dtype="float32")
    with pytest.raises(ValueError, match="pending"):
        codegen.to_c(adaptid.FastRLS(2), tmp_path, nk=1, pending=[1e39], dtype="float32")
    with pytest.raises(ValueError, match="single-stream"):
        est.run_batched(np.zeros((2, 4, 3)), np.zeros((2, 4)))
        codegen.to_c(est, tmp_path)
    assert not list(tmp_path.iterdir())


# ---------------------------------------------------------------------------
# A float32 (and float64) oracle: the kernel's lattice_run transcribed with NumPy
# scalars, every operation rounded to the dtype (no fused multiply-add), written
# from src/adaptid/_kernels/recursions/_fastrls.py, not from the C templates.
# ---------------------------------------------------------------------------
def _givens(a, b):
    h = np.sqrt(a * a + b * b)
    if h == 0:
        return a * 0 + 1, a * 0, a * 0
    return a / h, b / h, h


def _rotation(rp, r, b):
    """cos, sin of a stage from r = sqrt(running sum of squares), by one reciprocal."""
    if r == 0:
        return r * 0 + 1, r * 0
    inv = 1 / r
    return rp * inv, b * inv


def _lattice_oracle_step(L, uk, yr, ls):
    xf, ep, c, s, yq = L["xf"], L["ep"], L["c"], L["s"], L["yq"]
    n = len(xf)
    f = uk
    for i in range(n):
        t = xf[i] * ls
        xf[i] = s[i] * f + c[i] * t
        f = c[i] * f - s[i] * t
    efor = L["efor"] * ls
    t = np.sqrt(f * f + efor * efor)
    f = f * ep[n] / t if t > 0 else f * 0
    L["efor"] = t
    q, rp, u = t * t, t, t * 0
    w = np.zeros(n + 1, dtype=xf.dtype)  # w[i] = sum of ep[j]^2, i <= j < n
    for i in range(n - 1, -1, -1):
        q = xf[i] * xf[i] + q
        r = np.sqrt(q)
        cc, ss = _rotation(rp, r, xf[i])
        e = ep[i]
        ep[i + 1] = cc * e - ss * f
        f = cc * f + ss * e
        if i < n - 1:
            u = ep[i + 1] * ep[i + 1] + u
            w[i + 1] = u
        rp = r
    ep[0] = f
    w[0] = f * f + u
    t = 1 - w[0]
    t = t if t > 0 else t * 0
    rr = np.sqrt(t + w)
    for i in range(n):
        c[i], s[i] = _rotation(rr[i + 1], rr[i], ep[i])
    ep[n] = rr[n]
    f = yr
    for i in range(n):
        t = yq[i] * ls
        yq[i] = s[i] * f + c[i] * t
        f = c[i] * f - s[i] * t
    return f / ep[n]


def _track_oracle(R, z, x, yk, ls):
    n = len(x)
    R *= ls
    z *= ls
    row, w = x.copy(), yk
    for i in range(n):
        cc, ss, r = _givens(R[i, i], row[i])
        R[i, i] = r
        for j in range(i + 1, n):
            a = R[i, j]
            R[i, j] = cc * a + ss * row[j]
            row[j] = cc * row[j] - ss * a
        a = z[i]
        z[i] = cc * a + ss * w
        w = cc * w - ss * a
    th = np.zeros(n, dtype=x.dtype)
    for i in range(n - 1, -1, -1):
        v = z[i]
        for j in range(i + 1, n):
            v = v - R[i, j] * th[j]
        th[i] = v / R[i, i]
    return th


def lattice_oracle(est, u, y, dtype):
    """(errors, θ after every sample) of the lattice from est's state, in ``dtype``."""
    f = np.dtype(dtype).type
    n, S = est.n_taps, est.get_state()["state"]
    L = {"xf": S[n:2 * n].astype(dtype), "ep": S[2 * n:3 * n + 1].astype(dtype),
         "c": S[3 * n + 1:4 * n + 1].astype(dtype), "s": S[4 * n + 1:5 * n + 1].astype(dtype),
         "yq": S[5 * n + 1:6 * n + 1].astype(dtype), "efor": f(S[7 * n + 1])}
    x = S[6 * n + 1:7 * n + 1].astype(dtype)
    R = S[7 * n + 2:7 * n + 2 + n * n].reshape(n, n).astype(dtype)
    z = S[7 * n + 2 + n * n:7 * n + 2 + n * n + n].astype(dtype)
    ls, th0 = f(np.sqrt(est.forgetting)), est.theta0.astype(dtype)
    E, TH = np.empty(len(u)), np.empty((len(u), n))
    for k in range(len(u)):
        uk, yk = f(u[k]), f(y[k])
        x[1:] = x[:-1].copy()
        x[0] = uk
        yr = yk
        for i in range(n):
            yr = yr - th0[i] * x[i]
        E[k] = _lattice_oracle_step(L, uk, yr, ls)
        TH[k] = _track_oracle(R, z, x, yk, ls)
    return E, TH


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_generated_lattice_equals_a_numpy_oracle_bit_for_bit(tmp_path, dtype):
    """Without contraction the C code rounds every operation as NumPy scalars do: the
    same errors and θ bit for bit, in float32 and float64 (and the float64 oracle
    is the kernel up to its fused multiply-adds)."""
    n = 5
    rng = np.random.default_rng(11)
    u, y = coloured(rng, 1200, n)
    est = adaptid.FastRLS(n, forgetting=0.98, delta=0.5, method="lattice",
                          theta0=0.1 * rng.standard_normal(n))
    est.run_fir(u[:200], y[:200])
    exe, _ = build(tmp_path, est, dtype=dtype)
    e_c, th_c, _, _ = run(exe, True, n, u[200:], y[200:])
    e_o, th_o = lattice_oracle(est, u[200:], y[200:], dtype)
    np.testing.assert_array_equal(e_c, e_o)
    np.testing.assert_array_equal(th_c, th_o)
    if dtype == "float64":
        ref = est.run_fir(u[200:], y[200:])
        assert _rel(e_o, ref.error) <= 1e-12 and _rel(th_o, ref.theta) <= 1e-12


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize("method,track,nk", [("lattice", True, 2), ("lattice", False, 0),
                                             ("ftf", True, 3)])
def test_cortex_m4_compiles_warning_free(tmp_path, method, track, nk, dtype):
    """arm-none-eabi-gcc for a Cortex-M4F: no warning, a bounded stack; in float32 no
    operation promoted to double (-Wdouble-promotion), which the M4F would emulate."""
    est = adaptid.FastRLS(8, method=method, track_theta=track)
    codegen.to_c(est, tmp_path, name="fir", dtype=dtype, nk=nk)
    extra = ["-Wdouble-promotion"] if dtype == "float32" else []
    res = subprocess.run([_tool("arm-none-eabi-gcc"), *CFLAGS[:-2], *extra, "-mcpu=cortex-m4",
                          "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard", "-Os", "-fstack-usage", "-c",
                          str(tmp_path / "fir.c"), "-o", str(tmp_path / "fir.o")],
                         capture_output=True, text=True, cwd=tmp_path)
    assert res.returncode == 0 and res.stderr == "", res.stderr
    su = (tmp_path / "fir.su").read_text()
    assert "fir_update" in su and "dynamic" not in su
