"""The kernels compiled at install (adaptid.cli._aot builds, adaptid._kernels.toolchain._installed loads): a cold process loads instead of compiling.

Each check runs fresh Python processes on their own empty numba cache folder and an
AOT folder built here (``python -m adaptid.cli._aot build --tasks rls:3``), so it does
not depend on how this installation was built. numba's dispatcher statistics tell
whether a kernel was compiled (a miss) or loaded (a hit).
"""

import json
import os
import shutil
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import adaptid
from adaptid._kernels.toolchain import _installed
from adaptid.cli import _aot

SRC = Path(adaptid.__file__).resolve().parents[1]

CHILD = textwrap.dedent("""
    import json
    import numpy as np
    import adaptid
    from adaptid._kernels.toolchain import _installed
    from adaptid._kernels.recursions import _rls
    stats = lambda f: (sum(f.stats.cache_misses.values()), sum(f.stats.cache_hits.values()))
    rng = np.random.default_rng(7)
    Phi = rng.standard_normal((200, 3)); y = Phi @ np.array([1.0, -2.0, 0.5]) + 0.1 * rng.standard_normal(200)
    est = adaptid.RLS(3, forgetting=0.99)
    tr = est.run(Phi, y)
    e = est.update(Phi[0], y[0])
    print(json.dumps({"misses": stats(_rls.rls_run)[0], "hits": stats(_rls.rls_run)[1],
                      "step": [est._step.step_ep is not None, *stats(_rls.rls_step)],
                      "theta": [float(v).hex() for v in tr.theta.ravel()] + [float(e).hex()],
                      "status": _installed.status()}))
""")


def _env(tmp_path, cache, **extra):
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "ADAPTID_AOT", "ADAPTID_AOT_DIR", "PYTHONPATH",
                        "ADAPTID_MAX_SPECIALISED_N")}
    env.update(NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(SRC), PYTHONDONTWRITEBYTECODE="1")
    env.update({k: str(v) for k, v in extra.items()})
    return env


def _child(tmp_path, name, **extra):
    cache = tmp_path / f"cache-{name}"
    cache.mkdir(mode=0o700)
    proc = subprocess.run([sys.executable, "-c", CHILD], env=_env(tmp_path, cache, **extra),
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """An AOT folder holding RLS(3)'s kernel, built as pip's build step builds one."""
    tmp = tmp_path_factory.mktemp("aot")
    out = tmp / "aot"
    cache = tmp / "unused"
    cache.mkdir(mode=0o700)
    proc = subprocess.run([sys.executable, "-m", "adaptid.cli._aot", "build", str(out), "--jobs", "1",
                           "--tasks", "rls:3"], env=_env(tmp, cache), cwd=tmp,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return out


@pytest.fixture(scope="module")
def compiled(tmp_path_factory):
    """The control: the same process with the installed kernels switched off compiles."""
    return _child(tmp_path_factory.mktemp("jit"), "jit", ADAPTID_AOT="0")


def test_a_cold_process_loads_the_installed_kernel(built, compiled, tmp_path):
    man = json.loads((built / "MANIFEST.json").read_text())
    import numba
    assert man["numba"] == numba.__version__ and man["entries"] >= 1
    got = _child(tmp_path, "aot", ADAPTID_AOT_DIR=built)
    assert got["status"]["used"] is True
    assert got["misses"] == 0 and got["hits"] >= 1            # loaded, not compiled
    assert compiled["misses"] >= 1 and compiled["hits"] == 0  # the control compiled
    assert got["theta"] == compiled["theta"]                  # the same bits
    # update took its narrow step entry from the folder; the control (nothing installed
    # or cached) ran its update through run's entry, to the same bits (theta[-1])
    assert got["step"] == [True, 0, 1]
    assert compiled["step"] == [False, 0, 0]


def test_a_stale_manifest_is_not_used(built, tmp_path):
    stale = tmp_path / "stale"
    shutil.copytree(built, stale)
    man = json.loads((stale / "MANIFEST.json").read_text())
    man["stamp"] = "0" * 64  # built from other kernel sources
    (stale / "MANIFEST.json").write_text(json.dumps(man))
    got = _child(tmp_path, "stale", ADAPTID_AOT_DIR=stale)
    assert got["misses"] >= 1 and not got["status"]["used"]
    assert "other kernel sources" in got["status"]["why_not"]


def test_a_damaged_entry_is_a_miss(built, compiled, tmp_path):
    bad = tmp_path / "bad"
    shutil.copytree(built, bad)
    codes = sorted(bad.glob("_rls.rls_run-*.nbc"))
    assert codes
    for f in codes:
        f.write_bytes(f.read_bytes()[:100])  # truncated
    got = _child(tmp_path, "bad", ADAPTID_AOT_DIR=bad)
    assert got["misses"] >= 1
    assert got["theta"] == compiled["theta"]


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="POSIX permissions")
def test_a_folder_others_can_write_is_not_trusted(built, tmp_path, monkeypatch):
    open_ = tmp_path / "open"
    shutil.copytree(built, open_)
    os.chmod(open_, os.stat(open_).st_mode | stat.S_IWOTH)
    monkeypatch.setenv("ADAPTID_AOT_DIR", str(open_))
    monkeypatch.delenv("ADAPTID_AOT", raising=False)
    st = _installed.status()
    assert st["used"] is False and "writable by others" in st["why_not"]
    monkeypatch.setenv("ADAPTID_AOT_DIR", str(built))
    assert _installed.status()["used"] is True
    monkeypatch.setenv("ADAPTID_AOT", "0")
    assert _installed.status() == {**_installed.status(), "used": False, "why_not": "ADAPTID_AOT=0"}


def test_the_demo_helper_is_not_started_for_installed_kernels(built, tmp_path, monkeypatch):
    """adaptid demo compiles the window in a helper process unless its kernels are
    cached; kernels compiled at install count as cached."""
    from adaptid import _config
    from adaptid.cli import _prewarm

    monkeypatch.setattr(_config, "CACHE_DIR", str(tmp_path))  # an empty cache folder
    names = ("_rls.rls_run",)
    monkeypatch.setenv("ADAPTID_AOT_DIR", str(built))
    monkeypatch.delenv("ADAPTID_AOT", raising=False)
    assert _prewarm._cached("_rls.rls_run")
    assert not _prewarm._cached("_window.window_run")  # not in this folder
    monkeypatch.setenv("ADAPTID_AOT", "0")
    assert not any(_prewarm._cached(k) for k in names)


def test_tasks_are_split_longest_first():
    groups = _aot._split([("a", 5.0), ("b", 3.0), ("c", 3.0), ("d", 1.0)], 2)
    assert sorted(map(sorted, groups)) == [["a", "d"], ["b", "c"]]
    assert _aot._split([("a", 1.0)], 4) == [["a"]]
    names = [n for n, _ in _aot.TASKS]
    # every size of RLS's default form that has its own kernel, and one above
    assert {f"rls:{n}" for n in range(1, 66)} <= set(names)
    assert {"demo", "fit"} <= set(names)


def test_unknown_task_is_refused():
    with pytest.raises(ValueError, match="unknown"):
        _aot._run_task("nonsense")
