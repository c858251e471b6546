"""``adaptid demo`` compiles the window's kernels in a helper process meanwhile.

The helper must compile exactly the signatures the demo then calls (else the
demo compiles them again and nothing is gained), and must never change a
result. Oracle for "exactly": numba's own per-dispatcher counters of cache
misses and hits, in a fresh process on a fresh cache folder.
"""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import adaptid
from adaptid.cli import _prewarm

SRC = Path(adaptid.__file__).resolve().parents[1]

DEMO_WINDOW_FIT = textwrap.dedent("""
    import json, numpy as np
    from adaptid.cli._demo import N_CHUNKS, demo_spec
    from adaptid.cli._engine import fit_equation
    from adaptid.datasets import dc_motor
    from adaptid.estimators import size_generic_kernels
    from adaptid.models import dc_motor_regressors
    from adaptid._kernels.recursions import _window
    data, _ = dc_motor(seed=0)
    regs = dc_motor_regressors(data.time.to_numpy(), data.voltage.to_numpy(),
                               data.current.to_numpy(), data.speed.to_numpy(),
                               speed_kind="interval_mean")
    reg = regs.mechanical
    with size_generic_kernels():
        fit = fit_equation("mechanical", list(reg.names), reg.Phi, np.asarray(reg.y, float),
                           np.asarray(reg.index), demo_spec("window"), n_chunks=N_CHUNKS)
    print(json.dumps({"misses": sum(_window.window_run.stats.cache_misses.values()),
                      "hits": sum(_window.window_run.stats.cache_hits.values()),
                      "theta": list(fit.theta)}))
""")


def _python(code, cache, tmp_path, **env):
    # ADAPTID_AOT=0: the helper's work is to fill numba's cache folder; the kernels
    # compiled at install (tests/kernels/test_aot.py) would serve the command without it
    full = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(SRC), ADAPTID_AOT="0",
                **env)
    proc = subprocess.run([sys.executable, "-c", code], env=full, cwd=tmp_path,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


def test_helper_compiles_the_signatures_the_demo_calls(tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    _python("from adaptid.cli._demo import compile_kernels; compile_kernels(('window',))", cache,
            tmp_path)
    out = json.loads(_python(DEMO_WINDOW_FIT, cache, tmp_path).splitlines()[-1])
    assert out["misses"] == 0 and out["hits"] >= 1     # loaded, not compiled again
    # control: on an empty cache folder the same fit compiles (a miss)
    empty = tmp_path / "empty"
    empty.mkdir(mode=0o700)
    control = json.loads(_python(DEMO_WINDOW_FIT, empty, tmp_path).splitlines()[-1])
    assert control["misses"] >= 1
    assert control["theta"] == out["theta"]            # same numbers either way


def test_no_helper_where_it_cannot_help(monkeypatch):
    from adaptid import _config

    monkeypatch.setenv("ADAPTID_PREWARM", "0")
    assert _prewarm.start("adaptid.cli._demo", "compile_kernels", ("window",)) is None
    monkeypatch.delenv("ADAPTID_PREWARM")
    monkeypatch.setattr(_config, "CACHE", False)   # nothing cached: a helper cannot hand over
    assert _prewarm.start("adaptid.cli._demo", "compile_kernels", ("window",)) is None
    _prewarm.wait(None)                            # waiting for no helper is a no-op


def test_no_helper_when_the_kernels_are_cached(monkeypatch, tmp_path):
    """A warm install: the helper would only make the command wait for it."""
    from adaptid import _config

    monkeypatch.delenv("ADAPTID_PREWARM", raising=False)
    monkeypatch.setenv("ADAPTID_AOT", "0")  # the cache folder alone (test_aot.py: with both)
    monkeypatch.setattr(_config, "CACHE", True)
    monkeypatch.setattr(_config, "CACHE_DIR", str(tmp_path))
    names = ("_window._window_core", "_window.window_run")
    (tmp_path / "_window._window_core-90.py311.nbi").write_bytes(b"")
    assert not _prewarm._cached("_window.window_run")
    proc = _prewarm.start("time", "sleep", 0, unless_cached=names)   # one missing: a helper
    assert proc is not None
    _prewarm.wait(proc)
    (tmp_path / "_window.window_run-210.py311.nbi").write_bytes(b"")
    assert _prewarm.start("time", "sleep", 0, unless_cached=names) is None


def test_a_stuck_helper_is_killed():
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    _prewarm.wait(proc, timeout=0.5)
    assert proc.returncode is not None


def test_demo_results_do_not_depend_on_the_helper(monkeypatch):
    from typer.testing import CliRunner

    from adaptid.cli._app import app

    from adaptid import _config

    started = []
    start = _prewarm.start

    def recording_start(*args, **kwargs):
        proc = start(*args, **kwargs)
        started.append(proc is not None)
        return proc

    # the suite's cache may already hold the window's kernels (or be off): start the
    # helper anyway
    monkeypatch.setattr(_config, "CACHE", True)
    monkeypatch.setattr(_prewarm, "_cached", lambda kernel: False)
    monkeypatch.setattr(_prewarm, "start", recording_start)
    outs = []
    for flag in ("0", "1"):
        monkeypatch.setenv("ADAPTID_PREWARM", flag)
        res = CliRunner().invoke(app, ["demo", "--json", "--no-report"])
        assert res.exit_code == 0, res.output
        out = json.loads(res.output)
        out.pop("elapsed_s")                     # wall-clock time, the one field that differs
        outs.append(out)
    assert started == [False, True]              # without, then with the helper
    assert outs[0] == outs[1]
