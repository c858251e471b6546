"""Generated C (adaptid.codegen.to_c) compiled and run against adaptid's own ``run``.

The oracle is the compiled Python estimator (``run``, numba kernels of
``adaptid._kernels``), which is tested elsewhere against batch solves;
here the C code, written independently from templates, is compiled with the
host gcc, the ARM Linux cross compiler (run under qemu-arm) and the
Cortex-M4F bare-metal compiler. A missing toolchain is a FAILURE, not a skip:
``.ci/run`` installs gcc, gcc-arm-linux-gnueabihf, libc6-dev-armhf-cross,
gcc-arm-none-eabi and qemu-user.

Tolerances:

* host, ``-ffp-contract=off``: the C code rounds every product, the kernel
  fuses ``a*b + c`` (numba ``fastmath={"contract"}``): the trajectories
  differ by rounding only, bounded by 1e-12 relative (measured ≤ 6e-14, the
  sliding window with λ = 1 being the largest);
* host, ``-DNAME_USE_FMA -mfma``: the same fused operations as the kernel,
  bit for bit equal for every estimator but ConstantTrace (its P = g P̄ + c₂I
  is formed in an order LLVM contracts differently after unrolling: about
  64 % of the samples are bit-equal, the rest within 1e-12);
* ARM (qemu) against the host, both without contraction: bit for bit;
* float32 against float64: see test_float32_error_bounded and docs/embedded.md.

LMS and NLMS (the test_gradient_* tests) are held to the same standard: bit for
bit with FMA (n = 4, 10, 13, 16, 18, i.e. sequential sums, the partial sums of
the specialised kernel and of the generic one), ≤ 1e-12 without.
"""

from __future__ import annotations

import platform
import re
import shutil
import subprocess
import warnings

import numpy as np
import pytest

import adaptid
import adaptid.forgetting as F
from adaptid import codegen
from adaptid._exceptions import CovarianceWindupWarning, DefinitenessLossWarning

N = 100_000
CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2"]
M4FLAGS = ["-mcpu=cortex-m4", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard", "-Os", "-fstack-usage"]

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>
#include "@name@.h"

/* reads [int64 N, int64 n | Phi (N x n) | y (N)] as doubles, writes per sample
 * [theta (n) | a-priori error] as doubles; prints n_updates n_skipped flags */
int main(int argc, char **argv)
{
    FILE *in, *out;
    int64_t hdr[2];
    double *phi, *y, row[@N@ + 1];
    @real@ p[@N@], th[@N@];
    @name@_t s;
    long k, n_rows;
    int i;
    if (argc != 3 || !(in = fopen(argv[1], "rb"))) return 2;
    if (fread(hdr, sizeof hdr, 1, in) != 1 || hdr[1] != @N@) return 3;
    n_rows = (long)hdr[0];
    phi = malloc(sizeof(double) * (size_t)(n_rows * @N@));
    y = malloc(sizeof(double) * (size_t)n_rows);
    if (!phi || !y) return 4;
    if (fread(phi, sizeof(double), (size_t)(n_rows * @N@), in) != (size_t)(n_rows * @N@)) return 5;
    if (fread(y, sizeof(double), (size_t)n_rows, in) != (size_t)n_rows) return 5;
    fclose(in);
    if (!(out = fopen(argv[2], "wb"))) return 6;
    @name@_init(&s);
    for (k = 0; k < n_rows; k++) {
        for (i = 0; i < @N@; i++) p[i] = (@real@)phi[k * @N@ + i];
        row[@N@] = (double)@name@_update(&s, p, (@real@)y[k]);
        @name@_theta(&s, th);
        for (i = 0; i < @N@; i++) row[i] = (double)th[i];
        if (fwrite(row, sizeof row, 1, out) != 1) return 7;
    }
    printf("%lu %lu %lu\n", (unsigned long)s.n_updates, (unsigned long)s.n_skipped,
           (unsigned long)s.flags);
    fclose(out);
    free(phi);
    free(y);
    return 0;
}
"""


def _tool(name):
    path = shutil.which(name)
    if path is None:  # a failure, not a skip: .ci/run installs the toolchains
        pytest.fail(f"{name} not found: install gcc, gcc-arm-linux-gnueabihf, "
                    "libc6-dev-armhf-cross, gcc-arm-none-eabi, qemu-user (see .ci/run)")
    return path


def _host_has_fma():
    if platform.machine() not in ("x86_64", "AMD64"):
        return platform.machine() in ("aarch64", "arm64")
    try:
        with open("/proc/cpuinfo") as fh:
            return " fma " in fh.read()
    except OSError:
        return False


def _build(est, folder, *, dtype="float64", cc="gcc", flags=(), name="est"):
    folder.mkdir(parents=True, exist_ok=True)
    codegen.to_c(est, folder, name=name, dtype=dtype)
    real = "double" if dtype == "float64" else "float"
    drv = DRIVER.replace("@name@", name).replace("@N@", f"{name.upper()}_N").replace("@real@", real)
    (folder / "driver.c").write_text(drv)
    exe = folder / f"drv-{cc}-{dtype}-{abs(hash(tuple(flags)))}"
    cmd = [_tool(cc), *CFLAGS, *flags, "-I", str(folder), str(folder / "driver.c"),
           str(folder / f"{name}.c"), "-o", str(exe), "-lm"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    assert res.returncode == 0 and res.stderr == "", res.stderr  # warning-free
    return exe


def _run(exe, Phi, y, runner=()):
    n_rows, n = Phi.shape
    inp, out = exe.with_suffix(".in"), exe.with_suffix(".out")
    with open(inp, "wb") as fh:
        np.array([n_rows, n], dtype=np.int64).tofile(fh)
        np.ascontiguousarray(Phi, dtype=float).tofile(fh)
        np.ascontiguousarray(y, dtype=float).tofile(fh)
    res = subprocess.run([*runner, str(exe), str(inp), str(out)], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    data = np.fromfile(out).reshape(n_rows, n + 1)
    counts = [int(v) for v in res.stdout.split()]
    return data[:, :n], data[:, n], counts


def _rel(a, b):
    """Largest per-sample ‖a_k − b_k‖∞ / ‖b_k‖∞."""
    return float(np.max(np.max(np.abs(a - b), axis=1) / np.max(np.abs(b), axis=1)))


# --------------------------------------------------------------------------
# data and estimators
# --------------------------------------------------------------------------
def _data(n=3, seed=18, nan_rows=(17, 5000, 77777)):
    rng = np.random.default_rng(seed)
    Phi = rng.standard_normal((N, n))
    theta = rng.standard_normal(n)
    theta2 = theta + 0.5  # an abrupt change half-way: forgetting and windows track it
    y = np.where(np.arange(N) < N // 2, Phi @ theta, Phi @ theta2) + 0.1 * rng.standard_normal(N)
    Phi[60_000:62_000, n - 1] = 0.0  # a stretch without excitation: P_max and Directional act
    for k in nan_rows:  # non-finite samples: skipped by C and by nan_policy="skip"
        Phi[k, k % n] = np.nan
    y[nan_rows[0] + 1] = np.inf
    return Phi, y


def _cases():
    n = 3  # the size of test_recursive's and test_kernels_scratch's kernels: compiled once
    kw = dict(nan_policy="skip")
    return {
        "rls": adaptid.RLS(n, forgetting=0.99, **kw),
        "rls_lam1": adaptid.RLS(n, **kw),
        "rls_pmax": adaptid.RLS(n, forgetting=0.98, P_max=0.5, **kw),
        "directional": adaptid.RLS(n, forgetting=F.Directional(0.98), **kw),
        "directional_pmax": adaptid.RLS(n, forgetting=F.Directional(0.98), P_max=0.05, **kw),
        "constant_trace": adaptid.RLS(n, forgetting=F.ConstantTrace(0.9, trace=4.0), **kw),
        "variable": adaptid.RLS(n, forgetting=F.Variable(0.95, 0.1, 100.0), **kw),
        "window": adaptid.SlidingWindowRLS(n, 50, **kw),
        "window_lam": adaptid.SlidingWindowRLS(n, 50, forgetting=0.995, **kw),
        "kalman": adaptid.KalmanRLS(n, process_cov=1e-4, noise_var=0.01, **kw),
    }


# The kernel and the C code both fuse every a*b + c: bit for bit, except
# ConstantTrace (see the module docstring).
NOT_BITWISE: set = set()


@pytest.fixture(scope="module")
def data():
    return _data()


@pytest.fixture(scope="module")
def exported(tmp_path_factory, data):
    """Each case: the estimator after 200 samples (the C code continues from its
    state), adaptid's run on the rest, and the host build without contraction."""
    Phi, y = data
    root = tmp_path_factory.mktemp("codegen")
    out = {}
    for key, est in _cases().items():
        est.run(Phi[:200] * 0.5, y[:200])  # identified "offline"
        ref = est.copy()
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            tr = ref.run(Phi, y)
        ref.warned = {w.category for w in rec}
        exe = _build(est, root / key, flags=["-ffp-contract=off"])
        out[key] = (est, tr, ref, exe, root / key)
    return out


@pytest.mark.parametrize("key", list(_cases()))
def test_host_matches_run(exported, data, key):
    Phi, y = data
    est, tr, ref, exe, folder = exported[key]
    th, err, (n_upd, n_skip, flags) = _run(exe, Phi, y)
    # the non-finite samples are skipped and counted like nan_policy="skip"
    np.testing.assert_array_equal(np.isnan(err), tr.skipped)
    assert n_skip == est.n_skipped + int(tr.skipped.sum()) == ref.n_skipped
    assert n_upd == ref.n_updates
    # the flags: a rebuild of the window as Python's n_rebuilds; windup (a pivot of P
    # outside (0, windup_threshold)) as Python's warning, where Python watches every
    # sample (the window's run looks at the final state only)
    assert bool(flags & 2) == (tr.n_rebuilds > 0)
    if not isinstance(est, adaptid.SlidingWindowRLS):
        assert bool(flags & 1) == (CovarianceWindupWarning in ref.warned)
    # without contraction: rounding differences only. Exception: the window with
    # lambda = 1 while a direction is not excited (rows 60000-61999): that
    # component of theta then rests on the downdates' cancellation (P0 = 1e4
    # against the data), which amplifies the rounding differences to 9e-7
    # (measured); 1e-13 again 50 samples (one window) after the stretch.
    ok = ~tr.skipped
    if key == "window":
        stretch = slice(60_000, 62_050)
        assert _rel(th[stretch], tr.theta[stretch]) <= 1e-5
        ok[stretch] = False
    assert _rel(th[ok], tr.theta[ok]) <= 1e-12
    assert np.max(np.abs(err[ok] - tr.error[ok])) <= 1e-12 * np.max(np.abs(tr.error[ok]))
    if not _host_has_fma():
        pytest.skip("the host CPU has no FMA: the bit-for-bit build cannot run here")
    fflags = ["-D" + "EST_USE_FMA"] + (["-mfma"] if platform.machine() == "x86_64" else [])
    exe2 = _build(est, folder, flags=fflags)
    th2, err2, _ = _run(exe2, Phi, y)
    frac = float(np.mean(th2 == tr.theta))
    print(f"{key}: bit-identical fraction with FMA {frac:.4f}, without {np.mean(th == tr.theta):.4f}")
    if key in NOT_BITWISE:
        assert _rel(th2, tr.theta) <= 1e-12 and frac > 0.3
    else:
        np.testing.assert_array_equal(th2, tr.theta)
        np.testing.assert_array_equal(err2, tr.error)


@pytest.mark.parametrize("key,strategy", [("rls_pmax", 0.98),
                                          ("directional_pmax", F.Directional(0.98))])
def test_pmax_cases_exercise_the_bound(exported, data, key, strategy):
    """The P_max cases above are not vacuous: without P_max the trajectory differs."""
    Phi, y = data
    est, tr, ref, exe, folder = exported[key]
    free = adaptid.RLS(est.n_params, forgetting=strategy, nan_policy="skip")
    free.run(Phi[:200] * 0.5, y[:200])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CovarianceWindupWarning)  # what P_max prevents
        free_theta = free.run(Phi, y).theta
    assert np.max(np.abs(free_theta - tr.theta)) > 1e-6


@pytest.mark.parametrize("forgetting", [0.99, F.ConstantTrace(0.9, trace=18.0)])
def test_generic_kernel_n18_bitwise(tmp_path, forgetting):
    """n = 18 > MAX_SPECIALISED_N: Python runs the generic (not unrolled) kernel,
    whose fused products differ in one place (see codegen._rls); still bit for bit."""
    rng = np.random.default_rng(18)
    Phi = rng.standard_normal((5_000, 18))
    y = Phi @ rng.standard_normal(18) + 0.1 * rng.standard_normal(5_000)
    est = adaptid.RLS(18, forgetting=forgetting, form="ud")  # the C code runs U-D
    tr = est.copy().run(Phi, y)
    fma = _host_has_fma()
    exe = _build(est, tmp_path, flags=(["-DEST_USE_FMA", "-mfma"] if fma else ["-ffp-contract=off"]))
    th = _run(exe, Phi, y)[0]
    assert _rel(th, tr.theta) <= 1e-12
    if fma:
        np.testing.assert_array_equal(th, tr.theta)


def test_window_rebuild_path(tmp_path):
    """A window of M = n = 3 with a diffuse prior: removals that would lose
    definiteness are replaced by the re-solve from the buffer, in C as in Python
    (nan_policy="skip": the kernels compiled for the cases above)."""
    rng = np.random.default_rng(3)
    Phi = rng.standard_normal((20_000, 3))
    y = Phi @ rng.standard_normal(3) + 0.01 * rng.standard_normal(20_000)
    est = adaptid.SlidingWindowRLS(3, 3, P0=1e12, nan_policy="skip")
    with pytest.warns(DefinitenessLossWarning):
        tr = est.copy().run(Phi, y)
    assert tr.n_rebuilds > 0
    exe = _build(est, tmp_path, flags=["-DEST_USE_FMA", "-mfma"] if _host_has_fma() else [])
    th, err, (_, _, flags) = _run(exe, Phi, y)
    assert flags & 2  # EST_FLAG_REBUILT
    if _host_has_fma():
        np.testing.assert_array_equal(th, tr.theta)
    assert _rel(th, tr.theta) <= 1e-12


@pytest.mark.parametrize("key", ["rls", "window_lam", "kalman", "directional", "constant_trace"])
def test_arm_linux_qemu_same_as_host(exported, data, key):
    """arm-linux-gnueabihf-gcc -static, run under qemu-arm: the host's trajectory bit for bit
    (both without contraction; IEEE double on both, same operation order)."""
    Phi, y = data
    est, tr, ref, exe, folder = exported[key]
    qemu = _tool("qemu-arm")
    arm = _build(est, folder / "arm", cc="arm-linux-gnueabihf-gcc",
                 flags=["-static", "-ffp-contract=off"])
    th_host, err_host, c_host = _run(exe, Phi, y)
    th_arm, err_arm, c_arm = _run(arm, Phi, y, runner=[qemu])
    np.testing.assert_array_equal(th_arm, th_host)
    np.testing.assert_array_equal(err_arm, err_host)
    assert c_arm == c_host


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize("key", ["rls", "constant_trace", "window_lam", "kalman"])
def test_cortex_m4_compiles_warning_free(tmp_path, key, dtype):
    est = _cases()[key]
    codegen.to_c(est, tmp_path, name="est", dtype=dtype)
    res = subprocess.run([_tool("arm-none-eabi-gcc"), *CFLAGS[:-1], *M4FLAGS, "-c",
                          str(tmp_path / "est.c"), "-o", str(tmp_path / "est.o")],
                         capture_output=True, text=True, cwd=tmp_path)
    assert res.returncode == 0 and res.stderr == "", res.stderr
    su = (tmp_path / "est.su").read_text()
    assert "est_update" in su and "static" in su  # bounded stack, no alloca/VLA ("dynamic")
    assert "dynamic" not in su


@pytest.mark.parametrize("conditioning,bound,median_bound", [("well", 1e-4, 1e-5),
                                                           ("ill", 0.05, 2.4e-3)])
def test_float32_error_bounded(tmp_path, conditioning, bound, median_bound):
    """float32 against float64, both generated C, RLS (λ = 0.99), window (M = 100), Kalman.

    The error of θ is about ε₃₂·κ (ε₃₂ = 6e-8, κ the condition number of the
    information in the estimator's memory, which for a 100-sample window is a
    few times κ(ΦᵀΦ) of the whole record). Measured (seeds 7, 8, 9): well
    (κ ≈ 1): max 2e-5; ill (κ(ΦᵀΦ) ≈ 4e4, so ε₃₂·κ ≈ 2.4e-3): max 0.015, median
    ≤ 3.7e-4 (at κ ≈ 4e6 the max reaches 0.37: float32 is then useless).
    Bounds: max ≤ 1e-4 / 0.05 (≈ 20 ε₃₂·κ), median ≤ 1e-5 / ε₃₂·κ.
    """
    rng = np.random.default_rng(7)
    n_rows = 20_000
    X = rng.standard_normal((n_rows, 2))
    Phi = X if conditioning == "well" else np.column_stack([X[:, 0], X[:, 0] + 1e-2 * X[:, 1]])
    y = Phi @ [1.0, -0.5] + 0.1 * rng.standard_normal(n_rows)
    kappa = np.linalg.cond(Phi.T @ Phi)
    assert (kappa < 2) if conditioning == "well" else (3e4 < kappa < 5e4)
    worst, medians = 0.0, []
    for i, est in enumerate([adaptid.RLS(2, forgetting=0.99), adaptid.SlidingWindowRLS(2, 100),
                             adaptid.KalmanRLS(2, process_cov=1e-6, noise_var=0.01)]):
        e64 = _build(est, tmp_path / f"d{i}", flags=["-ffp-contract=off"])
        e32 = _build(est, tmp_path / f"s{i}", dtype="float32", flags=["-ffp-contract=off"])
        th64 = _run(e64, Phi, y)[0][100:]  # after the first 100 samples (the diffuse start)
        th32 = _run(e32, Phi, y)[0][100:]
        r = np.max(np.abs(th32 - th64), axis=1) / np.max(np.abs(th64), axis=1)
        worst = max(worst, float(r.max()))
        medians.append(float(np.median(r)))
    print(f"float32 vs float64, {conditioning} (kappa {kappa:.3g}): max relative error "
          f"{worst:.3g}, medians {', '.join(f'{m:.2g}' for m in medians)}")
    assert 0 < worst <= bound
    assert max(medians) <= median_bound


# --------------------------------------------------------------------------
# the generator's own contract
# --------------------------------------------------------------------------
def test_files_and_symbols(tmp_path):
    est = adaptid.RLS(3)
    h, c = codegen.to_c(est, tmp_path / "new", name="motor", dtype="float32")
    assert h.name == "motor.h" and c.name == "motor.c"
    text = h.read_text()
    for decl in ("} motor_t;", "void motor_init(motor_t *s);",
                 "float motor_update(motor_t *s, const float phi[MOTOR_N], float y);",
                 "float motor_predict(const motor_t *s, const float phi[MOTOR_N]);",
                 "void motor_theta(const motor_t *s, float theta[MOTOR_N]);"):
        assert decl in text
    src = c.read_text()
    assert "double" not in src.split("*/", 1)[1].replace("/* ", "")  # float32 all through
    assert "malloc" not in src and "Bierman 1977" in src
    inc = sorted(line for line in (src + text).splitlines() if line.startswith("#include <"))
    assert set(inc) <= {"#include <math.h>", "#include <stdint.h>", "#include <string.h>"}
    w = codegen.to_c(adaptid.SlidingWindowRLS(2, 5), tmp_path, name="w")[1].read_text()
    assert "Yamamoto (1991), eqs. 62-65" in w
    k = codegen.to_c(adaptid.KalmanRLS(2, process_cov=1e-3), tmp_path, name="k")[1].read_text()
    assert "eq. 2.114" in k


@pytest.mark.parametrize("est,kw,match", [
    (adaptid.RLS(2), dict(name="1abc"), "name must be a C identifier"),
    (adaptid.RLS(2), dict(name="int"), "name must be a C identifier"),
    (adaptid.RLS(2), dict(dtype="float16"), "dtype must be"),
    (adaptid.RLS(2, forgetting=F.EFRA(), P0=1.0), {}, "est must be RLS with exponential"),
    (adaptid.RLS(2, n_outputs=2), {}, "est must be a single-output"),
])
def test_refuses(tmp_path, est, kw, match):
    with pytest.raises(ValueError, match=match):
        codegen.to_c(est, tmp_path, **kw)


def test_refuses_batched_and_foreign(tmp_path):
    state = adaptid.RLS(2).get_state()
    state["batch"] = 2  # the state of an estimator after run_batched
    with pytest.raises(ValueError, match="single stream"):
        codegen.generate_c(state)
    with pytest.raises(TypeError, match="est must be"):
        codegen.to_c(object(), tmp_path)


def test_cli_export_c(tmp_path, capsys):
    from adaptid.cli import main
    est = adaptid.RLS(2, forgetting=0.98)
    est.run(np.eye(2), [1.0, 2.0])
    est.save_state(tmp_path / "state.npz")
    assert main(["export-c", str(tmp_path / "state.npz"), "--out", str(tmp_path / "c"),
                 "--name", "drive", "--float32"]) == 0
    assert "float drive_update(" in (tmp_path / "c" / "drive.h").read_text()
    want = codegen.generate_c(est.get_state(), name="drive", dtype="float32")[1]
    assert (tmp_path / "c" / "drive.c").read_text() == want
    capsys.readouterr()
    assert main(["export-c", str(tmp_path / "missing.npz"), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("adaptid: error: ")
    assert main(["export-c", str(tmp_path / "state.npz"), "--out", str(tmp_path),
                 "--name", "9x"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "name must be a C identifier" in err[0]


def test_docs_example_runs(tmp_path, monkeypatch):
    """docs/embedded.md: its Python block exports, its C block compiles (host gcc,
    the strict flags) and tracks the plant's change from a = 0.9 to 0.8 (b = 0.5,
    the simulated plant's true values) and counts the lost sample."""
    import re
    from pathlib import Path
    page = (Path(__file__).resolve().parents[2] / "docs" / "embedded.md").read_text()
    py = re.findall(r"^```python\n(.*?)^```", page, re.S | re.M)
    c = re.findall(r"^```c\n(.*?)^```", page, re.S | re.M)
    monkeypatch.chdir(tmp_path)
    exec(compile(py[0], "embedded.md", "exec"), {"__name__": "docs_embedded"})
    (tmp_path / "main.c").write_text(c[0])
    exe = tmp_path / "main"
    res = subprocess.run([_tool("gcc"), *CFLAGS, "-Ifirmware", "main.c", "firmware/plant.c",
                          "-o", str(exe), "-lm"], capture_output=True, text=True)
    assert res.returncode == 0 and res.stderr == "", res.stderr
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    m = re.match(r"a = (\S+), b = (\S+), skipped (\d+)", out)
    assert m and abs(float(m[1]) - 0.8) < 1e-3 and abs(float(m[2]) - 0.5) < 1e-3 and m[3] == "1"
    assert "It prints `" + out.strip().split(",")[0] in page.replace("\n", " ")


@pytest.mark.parametrize("script,args", [("bench_codegen.py", ["--quick", "--ns", "2", "--rounds", "1"]),
                                         ("embedded_sizes.py", [])])
def test_benchmark_scripts_run(script, args):
    """The scripts behind docs/embedded.md's table and the BENCHMARKS figures run
    (bench_codegen checks the FMA build against adaptid bit for bit before timing;
    embedded_sizes that every stack frame is static). Speed is not asserted."""
    import os
    import sys
    from pathlib import Path
    root = Path(__file__).resolve().parents[2]
    for tool in ("gcc", "arm-none-eabi-gcc", "arm-none-eabi-size", "arm-none-eabi-nm"):
        _tool(tool)
    env = dict(os.environ, PYTHONPATH=str(root / "src"))
    res = subprocess.run([sys.executable, str(root / "benchmarks" / script), *args],
                         capture_output=True, text=True, env=env, timeout=300)
    assert res.returncode == 0, res.stderr
    table = [line for line in res.stdout.splitlines() if line.startswith("| ")]
    assert len(table) == (2 if script == "bench_codegen.py" else 25)


# --------------------------------------------------------------------------
# LMS and NLMS (stochastic gradient, no covariance)
# --------------------------------------------------------------------------
# n = 4: the kernel's dot products are sequential; n = 10: four partial sums
# plus a remainder of two (adaptid/_kernels/recursions/_lms.py, _dot), which the C code
# must reproduce. Steps: LMS μ = 0.01 < 2/λmax(E φφᵀ) = 2 for standard-normal
# regressors (mean convergence, Widrow & Stearns 1985, ch. 6); NLMS μ = 0.5 in
# (0, 2) (Haykin 2002, sec. 6.1); NLMS at n = 10 with padasip's ε = 1e-3.
def _gradient_cases():
    kw = dict(nan_policy="skip")
    return {
        "lms4": adaptid.LMS(4, step=0.01, **kw),
        "nlms4": adaptid.NLMS(4, step=0.5, **kw),
        "lms10": adaptid.LMS(10, step=0.01, **kw),
        "nlms10": adaptid.NLMS(10, step=0.5, eps=1e-3, **kw),
    }


@pytest.fixture(scope="module")
def gradient_exported(tmp_path_factory):
    """As ``exported``: 200 samples in Python, then adaptid's run and the host
    build (unfused) on 10⁵ samples with non-finite ones."""
    root = tmp_path_factory.mktemp("codegen_lms")
    out = {}
    for key, est in _gradient_cases().items():
        Phi, y = _data(n=est.n_params)
        est.run(Phi[:200] * 0.5, y[:200])
        ref = est.copy()
        tr = ref.run(Phi, y)  # a DivergenceWarning would be an error here (pyproject)
        exe = _build(est, root / key, flags=["-ffp-contract=off"])
        out[key] = (est, tr, ref, exe, root / key, Phi, y)
    return out


@pytest.mark.parametrize("key", list(_gradient_cases()))
def test_gradient_host_matches_run(gradient_exported, key):
    est, tr, ref, exe, folder, Phi, y = gradient_exported[key]
    th, err, (n_upd, n_skip, flags) = _run(exe, Phi, y)
    np.testing.assert_array_equal(np.isnan(err), tr.skipped)
    assert tr.skipped.sum() == 4  # the three NaN regressors and the inf output
    assert n_skip == ref.n_skipped and n_upd == ref.n_updates
    assert flags == 0  # no divergence, as Python (no DivergenceWarning)
    ok = ~tr.skipped
    # unfused: the products rounded before the sums, rounding differences only
    # (the recursion is contractive for these steps: they do not grow)
    assert _rel(th[ok], tr.theta[ok]) <= 1e-12
    assert np.max(np.abs(err[ok] - tr.error[ok])) <= 1e-12 * np.max(np.abs(tr.error[ok]))
    if not _host_has_fma():
        pytest.skip("the host CPU has no FMA: the bit-for-bit build cannot run here")
    fflags = ["-DEST_USE_FMA"] + (["-mfma"] if platform.machine() == "x86_64" else [])
    th2, err2, _ = _run(_build(est, folder, flags=fflags), Phi, y)
    print(f"{key}: bit-identical fraction without FMA {np.mean(th == tr.theta):.4f}")
    np.testing.assert_array_equal(th2, tr.theta)
    np.testing.assert_array_equal(err2, tr.error)


def test_gradient_estimates_converge(gradient_exported):
    """Not a vacuous trajectory: the final θ of adaptid's run (which the C runs
    above equal) is near the true θ₂ that _data draws (seed 18): the LMS / NLMS
    misadjustment with noise 0.1 is small."""
    for key, (est, tr, ref, exe, folder, Phi, y) in gradient_exported.items():
        n = est.n_params
        rng = np.random.default_rng(18)
        rng.standard_normal((N, n))
        theta2 = rng.standard_normal(n) + 0.5  # as _data draws it
        assert np.max(np.abs(tr.theta[-1] - theta2)) < 0.1, key


@pytest.mark.parametrize("kind", ["LMS", "NLMS"])
def test_gradient_generic_kernel_n18_bitwise(tmp_path, kind):
    """n = 18 > MAX_SPECIALISED_N: Python runs the generic (looped) kernel, whose
    φᵀφ is fused as the plain partial sums (see codegen/_lms.py); bit for bit."""
    rng = np.random.default_rng(18)
    Phi = rng.standard_normal((5_000, 18))
    y = Phi @ rng.standard_normal(18) + 0.1 * rng.standard_normal(5_000)
    est = adaptid.LMS(18, step=0.01) if kind == "LMS" else adaptid.NLMS(18, step=0.5)
    tr = est.copy().run(Phi, y)
    fma = _host_has_fma()
    flags = ["-DEST_USE_FMA", "-mfma"] if fma else ["-ffp-contract=off"]
    th = _run(_build(est, tmp_path, flags=flags), Phi, y)[0]
    assert _rel(th, tr.theta) <= 1e-12
    if fma:
        np.testing.assert_array_equal(th, tr.theta)


@pytest.mark.parametrize("n", [8, 13, 16])
def test_gradient_nlms_sumsq_and_zero_regressor(tmp_path, n):
    """NLMS with ε₀ = 0 and rows φ = 0 (q = 0: no step, as the kernel), at the n
    where the specialised kernel's fused φᵀφ (sumsq, see codegen/_lms.py) has
    no remainder (8, 16) and a remainder of one (13): bit for bit with FMA."""
    rng = np.random.default_rng(n)
    Phi = rng.standard_normal((5_000, n))
    Phi[100:110] = 0.0
    y = Phi @ rng.standard_normal(n) + 0.1 * rng.standard_normal(5_000)
    est = adaptid.NLMS(n, step=0.5, eps=0.0)
    tr = est.copy().run(Phi, y)
    assert np.array_equal(tr.theta[100], tr.theta[109])  # the zero rows: no step
    fma = _host_has_fma()
    flags = ["-DEST_USE_FMA", "-mfma"] if fma else ["-ffp-contract=off"]
    th = _run(_build(est, tmp_path, flags=flags), Phi, y)[0]
    assert np.all(np.isfinite(th))
    assert _rel(th, tr.theta) <= 1e-12
    if fma:
        np.testing.assert_array_equal(th, tr.theta)


@pytest.mark.parametrize("kind", ["LMS", "NLMS"])
def test_gradient_divergence_flag(tmp_path, kind):
    """A step far too large: Python warns (DivergenceWarning) and the C code sets
    EST_FLAG_DIVERGED; the trajectories agree up to the overflow (with FMA: bit
    for bit, NaN where Python has NaN)."""
    from adaptid._exceptions import DivergenceWarning
    rng = np.random.default_rng(5)
    Phi = 10.0 * rng.standard_normal((3_000, 4))
    y = Phi @ [1.0, 2.0, -1.0, 0.5]
    # LMS: μ = 1 ≫ 2/λmax = 0.02; NLMS: μ = 4 > 2, the error along φ grows by |1 - μ| = 3
    est = adaptid.LMS(4, step=1.0) if kind == "LMS" else adaptid.NLMS(4, step=4.0)
    with pytest.warns(DivergenceWarning):
        tr = est.copy().run(Phi, y)
    fma = _host_has_fma()
    exe = _build(est, tmp_path, flags=["-DEST_USE_FMA", "-mfma"] if fma else [])
    th, err, (_, _, flags) = _run(exe, Phi, y)
    assert flags == 4  # EST_FLAG_DIVERGED only
    assert not np.all(np.isfinite(tr.theta[-1]))
    if fma:
        np.testing.assert_array_equal(th, tr.theta)  # NaN at the same places


@pytest.mark.parametrize("key", ["lms4", "nlms10"])
def test_gradient_arm_linux_qemu_same_as_host(gradient_exported, key):
    est, tr, ref, exe, folder, Phi, y = gradient_exported[key]
    arm = _build(est, folder / "arm", cc="arm-linux-gnueabihf-gcc",
                 flags=["-static", "-ffp-contract=off"])
    th_host, err_host, c_host = _run(exe, Phi, y)
    th_arm, err_arm, c_arm = _run(arm, Phi, y, runner=[_tool("qemu-arm")])
    np.testing.assert_array_equal(th_arm, th_host)
    np.testing.assert_array_equal(err_arm, err_host)
    assert c_arm == c_host


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize("key", ["lms4", "nlms10"])
def test_gradient_cortex_m4_compiles_warning_free(tmp_path, key, dtype):
    codegen.to_c(_gradient_cases()[key], tmp_path, name="est", dtype=dtype)
    res = subprocess.run([_tool("arm-none-eabi-gcc"), *CFLAGS[:-1], *M4FLAGS, "-c",
                          str(tmp_path / "est.c"), "-o", str(tmp_path / "est.o")],
                         capture_output=True, text=True, cwd=tmp_path)
    assert res.returncode == 0 and res.stderr == "", res.stderr
    su = (tmp_path / "est.su").read_text()
    assert "est_update" in su and "dynamic" not in su


@pytest.mark.parametrize("key", ["lms4", "nlms10"])
def test_gradient_float32_error_bounded(gradient_exported, tmp_path, key):
    """float32 against the float64 build on the same 10⁵ samples.

    LMS / NLMS forget their past geometrically: the error of θ is a filtered
    sum of the per-step rounding (about ε₃₂·‖θ‖ per step, ε₃₂ = 6e-8) that does
    not accumulate. Measured (independent regressors, the data of _data):
    lms4 max 7.2e-7, median 1.3e-7; nlms10 max 4.3e-7, median 6.4e-8, i.e.
    ≈ 10 ε₃₂. Bounds: max ≤ 1e-5, median ≤ 1e-6 (≈ 15 × the measured)."""
    est, tr, ref, exe, folder, Phi, y = gradient_exported[key]
    e32 = _build(est, tmp_path, dtype="float32", flags=["-ffp-contract=off"])
    th64, err64, c64 = _run(exe, Phi, y)
    th32, err32, c32 = _run(e32, Phi, y)
    assert c32 == c64
    ok = ~tr.skipped
    r = np.max(np.abs(th32[ok] - th64[ok]), axis=1) / np.max(np.abs(th64[ok]), axis=1)
    print(f"{key} float32 vs float64: max {r.max():.3g}, median {np.median(r):.3g}")
    assert 0 < r.max() <= 1e-5
    assert np.median(r) <= 1e-6


def test_gradient_header_and_refusals(tmp_path):
    h, c = codegen.to_c(adaptid.NLMS(3, step=0.2, eps=1e-3), tmp_path, name="g")
    head, src = h.read_text(), c.read_text()
    for decl in ("} g_t;", "void g_init(g_t *s);",
                 "double g_update(g_t *s, const double phi[G_N], double y);",
                 "double g_predict(const g_t *s, const double phi[G_N]);",
                 "void g_theta(const g_t *s, double theta[G_N]);", "#define G_FLAG_DIVERGED 4u"):
        assert decl in head
    assert "U[" not in head and "D[" not in head  # no covariance
    assert "NormalizedGradient" in src and "Haykin 2002" in src and "#define EPS0 0.001" in src
    lms = codegen.to_c(adaptid.LMS(3, step=0.2), tmp_path, name="l")[1].read_text()
    assert '"Gradient"' in lms and "Widrow & Stearns 1985" in lms and "EPS0" not in lms
    f32 = codegen.to_c(adaptid.NLMS(9, step=0.2), tmp_path, name="f", dtype="float32")[1]
    code = re.sub(r"/\*.*?\*/", "", f32.read_text(), flags=re.S)
    assert "double" not in code and "fmaf(" in code and "sumsq" in code  # float32 all through
    with pytest.raises(ValueError, match="est must be a single-output"):
        codegen.to_c(adaptid.LMS(2, step=0.1, n_outputs=2), tmp_path)
    # est.to_c goes through the same generator (the CLI's export-c reads a state
    # file, which load_state cannot read for LMS/NLMS yet: not tested here)
    est = adaptid.LMS(2, step=0.1)
    est.run(np.eye(2), [1.0, 2.0])
    want = codegen.generate_c(est.get_state(), name="lm")[1]
    assert "0.1, 0.2" in want  # θ after the two samples: μ φ y = (0.1, 0.2)
    est.to_c(tmp_path / "m", name="lm")
    assert (tmp_path / "m" / "lm.c").read_text() == want


def test_cli_fit_nlms_export_c(tmp_path, capsys):
    """adaptid fit --method nlms --export-c: the C code of the fitted NLMS, which
    continues from the fit's final θ (y = 1·a + 2·b exactly: θ = (1, 2))."""
    from adaptid.cli import main
    rng = np.random.default_rng(0)
    X = rng.standard_normal((500, 2))
    np.savetxt(tmp_path / "d.csv", np.column_stack([X, X @ [1.0, 2.0]]), delimiter=",",
               header="a,b,y", comments="")
    assert main(["fit", str(tmp_path / "d.csv"), "--y", "y", "--phi", "a,b", "--method", "nlms",
                 "--step", "0.5", "--export-c", str(tmp_path / "c"), "--c-name", "fitn",
                 "-q"]) == 0
    capsys.readouterr()
    head = (tmp_path / "c" / "fitn.h").read_text()
    src = (tmp_path / "c" / "fitn.c").read_text()
    assert "normalised least mean squares" in head and "FITN_FLAG_DIVERGED" in head
    assert "#define STEP 0.5" in src
    init = src.split("THETA_INIT[FITN_N] = {", 1)[1].split("}", 1)[0]
    np.testing.assert_allclose([float(v) for v in init.split(",")], [1.0, 2.0], rtol=1e-9)


def test_export_c_reads_a_gradient_state_file(tmp_path):
    """adaptid export-c on the state file of an NLMS (no P: the state is θ alone)."""
    import subprocess
    import sys

    import adaptid
    rng = np.random.default_rng(0)
    X = rng.standard_normal((500, 3))
    est = adaptid.NLMS(3, step=0.5)
    est.run(X, X @ [1.0, 2.0, 3.0])
    est.save_state(tmp_path / "s.npz")
    r = subprocess.run([sys.executable, "-m", "adaptid", "export-c", str(tmp_path / "s.npz"),
                        "--out", str(tmp_path / "c"), "--name", "nl"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "c" / "nl.c").read_text() == \
        adaptid.codegen.generate_c(est.get_state(), name="nl")[1]


# ------------------------------------------------- issue 32, point 7: names, values, pairs
@pytest.mark.parametrize("name", ["plant\n", "rls\n", "real", "uint32", "int32", "size", "main",
                                  "uint64_t", "size_t", "int8_t", "_Atomic", "_Generic",
                                  "math", "string", "stdint", "stdio", "stdlib", "float",
                                  "limits", "Math", "fma", "NAN"])
def test_reserved_and_header_names_refused(tmp_path, name):
    with pytest.raises(ValueError, match="name"):
        codegen.to_c(adaptid.RLS(2), tmp_path, name=name)
    assert list(tmp_path.iterdir()) == []


def test_float32_values_beyond_range_refused(tmp_path):
    with pytest.raises(ValueError, match="D within float32's range"):
        codegen.to_c(adaptid.RLS(2, P0=1e40), tmp_path, name="big", dtype="float32")
    assert list(tmp_path.iterdir()) == []
    # the same in float64 is fine, and no literal is `inf`
    h, c = codegen.to_c(adaptid.RLS(2, P0=1e40), tmp_path, name="big")
    assert "1e+40" in c.read_text()


@pytest.mark.parametrize("label", ["theta", "D"])
def test_non_finite_state_refused(tmp_path, label):
    est = adaptid.RLS(2)
    state = est.get_state()
    S = np.array(state["state"], dtype=float)
    S[0 if label == "theta" else 2 + 4] = np.nan if label == "theta" else np.inf
    state["state"] = S
    with pytest.raises(ValueError, match=f"finite {label}"):
        codegen.generate_c(state, name="bad")


def test_files_written_as_a_pair_or_not_at_all(tmp_path):
    old = codegen.to_c(adaptid.RLS(2), tmp_path, name="pair")
    before = old[0].read_text()
    (tmp_path / "pair.c").unlink()
    (tmp_path / "pair.c").mkdir()               # the .c cannot be replaced
    with pytest.raises(OSError):
        codegen.to_c(adaptid.RLS(3), tmp_path, name="pair")
    assert old[0].read_text() == before          # the old header is untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pair.c", "pair.h"]  # no temps
    (tmp_path / "pair.c").rmdir()
    h, c = codegen.to_c(adaptid.RLS(3), tmp_path, name="pair")
    assert "PAIR_N 3" in h.read_text() and c.is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pair.c", "pair.h"]


def test_fast_math_caveat_in_the_header(tmp_path):
    h, _ = codegen.to_c(adaptid.RLS(2), tmp_path, name="fm")
    assert "-ffast-math" in h.read_text()


@pytest.mark.parametrize("name", ["int", "real", "math", "uint32"])
def test_cli_reserved_c_names_are_one_line_exit_2(tmp_path, capsys, name):
    from adaptid.cli import main
    est = adaptid.RLS(2)
    est.run(np.eye(2), [1.0, 2.0])
    est.save_state(tmp_path / "state.npz")
    capsys.readouterr()
    assert main(["export-c", str(tmp_path / "state.npz"), "--out", str(tmp_path / "c"),
                 "--name", name]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("adaptid: error: ") and "name" in err[0]
    assert not (tmp_path / "c").exists() or list((tmp_path / "c").iterdir()) == []
    data = tmp_path / "d.csv"
    data.write_text("y,x0,x1\n" + "".join(f"{i},{i % 3},{i % 5}\n" for i in range(20)))
    assert main(["fit", str(data), "--y", "y", "--phi", "x0,x1", "--export-c",
                 str(tmp_path / "c2"), "--c-name", name]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--c-name" in err[0]
    assert not (tmp_path / "c2").exists()
