"""``adaptid fit --fir NB,NK --method fastrls --export-c DIR`` for the lattice and nk > 0.

The C files the command writes are compiled with gcc and fed the raw rows of
the rest of the CSV; the oracles, none of them the CLI's code: FastRLS.run_fir
in Python on the input delayed here by nk (v_k = u_(k-nk), zero before the
record), run over the first part and continued over the rest. Tolerances as in
tests/codegen/test_codegen_fastlattice.py: the kernel may fuse a*b + c, the C
code (-ffp-contract=off) rounds every product, so float64 agrees to 1e-10 of
the error scale; float32 to 1e-4 (its own precision, measured about 1e-6).
"""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import adaptid
from adaptid.cli._app import app

N = 2000
CUT = 1500

DRIVER = r"""
#include <stdio.h>
#include "fir.h"
/* prints theta at export (if tracked), then per line "u y" of stdin the a-priori error */
int main(void)
{
    fir_t s;
    double u, y;
    int i;
    fir_init(&s);
#if FIR_TRACK
    {
        @real@ th[FIR_N];
        fir_theta(&s, th);
        for (i = 0; i < FIR_N; i++) printf("%.17g\n", (double)th[i]);
    }
#endif
    (void)i;
    while (scanf("%lf %lf", &u, &y) == 2)
        printf("%.17g\n", (double)fir_update(&s, (@real@)u, (@real@)y));
    return 0;
}
"""


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    rng = np.random.default_rng(381)
    w = rng.standard_normal(N)
    u = np.zeros(N)
    for k in range(N):  # coloured input: AR(1), pole 0.7
        u[k] = w[k] + (0.7 * u[k - 1] if k else 0.0)
    h = np.array([0.0, 0.0, 0.8, -0.5, 0.3, 0.1])   # two samples of dead time
    y = np.convolve(u, h)[:N] + 0.05 * rng.standard_normal(N)
    u[700], y[1700] = np.nan, np.nan   # --nan skip: left out before the delay, in C as well
    path = tmp_path_factory.mktemp("fastrls_export") / "first.csv"
    pd.DataFrame({"u": u[:CUT], "y": y[:CUT]}).to_csv(path, index=False, float_format="%.17g")
    return path, u, y


def delayed(u, y, nk):
    """The complete rows, the input delayed by nk over them: v_k = u_(k-nk), zero before
    the record (the prewindowed delay; a row with a gap enters neither)."""
    ok = np.isfinite(u) & np.isfinite(y)
    return np.concatenate([np.zeros(nk), u[ok][: ok.sum() - nk]]), y[ok], ok


@pytest.mark.parametrize("method,nk,dtype", [("lattice", 0, "float64"), ("lattice", 2, "float64"),
                                             ("ftf", 2, "float64"), ("lattice", 3, "float32")])
def test_export_c_continues_the_fit(record, tmp_path, method, nk, dtype):
    assert shutil.which("gcc"), "gcc is required (tools/system-deps.sh)"
    path, u, y = record
    nb, lam = 6, 0.995
    cdir = tmp_path / "c"
    res = CliRunner().invoke(app, [str(a) for a in (
        "fit", path, "--u", "u", "--y", "y", "--fir", f"{nb},{nk}", "--method", "fastrls",
        "--fastrls-method", method, "--forgetting", lam, "--nan", "skip", "--export-c", cdir,
        "--c-name", "fir", "--save-state", tmp_path / "s.npz",
        *(["--float32"] if dtype == "float32" else []), "--json")])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert sorted(out["export_c"]) == sorted([str(cdir / "fir.c"), str(cdir / "fir.h")])
    v, yy, ok = delayed(u, y, nk)
    first = int(ok[:CUT].sum())
    py = adaptid.FastRLS(nb, forgetting=lam, method=method)   # the fit, in Python
    py.run_fir(v[:first], yy[:first])
    assert np.allclose(out["theta"], py.theta, rtol=0, atol=1e-12)
    real = "double" if dtype == "float64" else "float"
    (tmp_path / "drv.c").write_text(DRIVER.replace("@real@", real))
    exe = tmp_path / "run"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2",
                    "-ffp-contract=off", "-I", str(cdir), str(cdir / "fir.c"),
                    str(tmp_path / "drv.c"), "-lm", "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    feed = "\n".join(f"{float(a)!r} {float(b)!r}" for a, b in zip(u[CUT:], y[CUT:]))
    got = np.array(subprocess.run([str(exe)], input=feed, check=True, capture_output=True,
                                  text=True).stdout.split(), dtype=float)
    th_c, e_c = got[:nb], got[nb:]          # the FTF and the tracked lattice both give θ
    ref = py.run_fir(v[first:], yy[first:]).error  # the C code is fed the raw u: it delays it
    tol = 1e-10 if dtype == "float64" else 1e-4
    assert np.array_equal(np.isfinite(e_c), ok[CUT:])   # the gap: NaN, skipped
    assert np.max(np.abs(e_c[ok[CUT:]] - ref)) <= tol * np.max(np.abs(ref))
    assert np.max(np.abs(th_c - out["theta"])) <= tol * np.max(np.abs(out["theta"]))

    # adaptid export-c of the state file the fit saved: the same files (the delay and the
    # pending inputs come from the file's labels)
    res = CliRunner().invoke(app, ["export-c", str(tmp_path / "s.npz"), "--out",
                                   str(tmp_path / "c2"), "--name", "fir",
                                   *(["--float32"] if dtype == "float32" else [])])
    assert res.exit_code == 0, res.output
    for f in ("fir.h", "fir.c"):
        assert (tmp_path / "c2" / f).read_text() == (cdir / f).read_text()
