"""The environment at the edges (issue 14): where compiled kernels are cached.

Every case runs adaptid in a subprocess with HOME, XDG_CACHE_HOME and
NUMBA_CACHE_DIR pointed at temporary folders, so the developer's caches are
never touched. Oracles: numba's own locator code (where numba would cache,
``numba.core.caching``), marker side effects of planted pickles (did anything
unpickle them?), and plain ``numba.njit(cache=True)`` as the control that the
damage and the plant are real (numba itself fails or runs the plant).

The tests run as any user: an "unwritable" folder is made by a regular file
standing where the folder would be (nobody, root included, can create a folder
there), and additionally by ``chmod a-w`` (which binds users other than root).
"""

import os
import pickle
import shutil
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import pytest

import adaptid
from adaptid import _config

SRC = Path(adaptid.__file__).resolve().parents[1]

RUN_RLS = textwrap.dedent("""
    import warnings, numpy as np
    warnings.simplefilter("always")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        import adaptid
        est = adaptid.RLS(3)
        est.run(np.eye(3), [1.0, 2.0, 3.0])
    from adaptid import _config
    kinds = [type(w.message).__name__ for w in caught]
    print("THETA", list(est.theta))
    print("CACHE", _config.CACHE, _config.CACHE_DIR)
    print("WARNINGS", kinds.count("CompilationCacheWarning"), len(kinds))
""")


def _env(tmp_path, **extra):
    home = tmp_path / "home"
    home.mkdir(mode=0o700, exist_ok=True)
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "PYTHONPATH")}
    # ADAPTID_AOT=0: these tests are about numba's cache folder, not the kernels
    # compiled at install (tests/kernels/test_aot.py), which would serve its misses
    env.update(HOME=str(home), XDG_CACHE_HOME=str(home / ".cache"),
               PYTHONPATH=str(SRC), PYTHONDONTWRITEBYTECODE="1", ADAPTID_AOT="0")
    env.update({k: str(v) for k, v in extra.items()})
    return env


def _run(code, env, cwd):
    proc = subprocess.run([sys.executable, "-c", code], env=env, cwd=cwd,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = {}
    for line in proc.stdout.splitlines():
        key, _, rest = line.partition(" ")
        out[key] = rest
    return out, proc.stderr


def _private(path):
    path.mkdir(mode=0o700, parents=True, exist_ok=True)
    os.chmod(path, 0o700)
    return path


# ---------------------------------------------------------------- where it caches
def test_cache_folder_is_where_numba_puts_it():
    """Oracle: numba's own locator code for a file in adaptid/_kernels."""
    from numba.core.caching import _CacheLocator
    from numba.misc.appdirs import AppDirs
    kernels = str(Path(_config.__file__).parent / "_kernels")
    assert _config._subpath(kernels) == _CacheLocator.get_suitable_cache_subpath(
        os.path.join(kernels, "_rls.py"))
    assert _config._user_cache_root() == AppDirs(appname="numba", appauthor=False).user_cache_dir


def test_private_cache_dir_is_used(tmp_path):
    cache = _private(tmp_path / "cache")
    out, _ = _run(RUN_RLS, _env(tmp_path, NUMBA_CACHE_DIR=cache), tmp_path)
    assert out["CACHE"].startswith("True " + str(cache))
    assert out["WARNINGS"] == "0 0"
    folder = Path(out["CACHE"].split(" ", 1)[1])
    assert any(folder.glob("_rls.rls_run-*.nbi"))   # numba wrote its index there


def _planted_root(tmp_path):
    """A cache root whose adaptid folder holds planted indexes; the plant's marker."""
    root = _private(tmp_path / "shared")
    sub = root / _config._subpath(str(Path(_config.__file__).parent / "_kernels"))
    marker = tmp_path / "PLANT_RAN"
    _plant(sub, marker)
    return root, sub, marker


def test_planted_index_in_a_private_folder_is_unpickled(tmp_path):
    """Control for the test below: in private folders numba loads the planted
    index (the plant runs, and adaptid survives it: a cache miss)."""
    root, _, marker = _planted_root(tmp_path)
    out, _ = _run(RUN_RLS, _env(tmp_path, NUMBA_CACHE_DIR=root), tmp_path)
    assert marker.exists() and out["CACHE"].startswith("True")


@pytest.mark.parametrize("how", ["group-writable", "world-writable parent",
                                 "other owner"])
def test_cache_folder_others_can_write_is_not_used(tmp_path, how):
    """A planted index (a pickle that creates a folder when loaded) is never
    unpickled from a folder others can write (the control above shows the same
    plant runs from a private folder)."""
    root, sub, marker = _planted_root(tmp_path)
    if how == "group-writable":
        os.chmod(sub, 0o770)
    elif how == "world-writable parent":
        os.chmod(root, 0o777)             # no sticky bit: anyone may swap the folder
    else:
        if os.getuid() != 0:
            pytest.skip("changing a folder's owner needs root")
        os.chown(sub, 65534, 65534)
    out, err = _run(RUN_RLS, _env(tmp_path, NUMBA_CACHE_DIR=root), tmp_path)
    assert not marker.exists(), "a planted cache index was unpickled"
    assert out["CACHE"].startswith("False")
    assert out["WARNINGS"] == "1 1"
    assert out["THETA"] != ""


def _plant(folder, marker):
    """An index for every entry point of _rls.py whose unpickling creates `marker`."""
    folder.mkdir(parents=True, exist_ok=True)
    os.chmod(folder, 0o700)
    rls = Path(_config.__file__).parent / "_kernels" / "recursions" / "_rls.py"
    source = rls.read_text().splitlines()
    for lineno, line in enumerate(source, 1):
        if line.startswith("def rls_"):
            # numba's index name: <module>.<qualname>-<first line>.py<ver>.nbi, where the
            # first line is the decorator's (co_firstlineno)
            name = f"_rls.{line[4:line.index('(')]}-{lineno - 1}.py{sys.version_info[0]}" \
                   f"{sys.version_info[1]}.nbi"
            with open(folder / name, "wb") as fh:
                pickle.dump(numba.__version__, fh)
                fh.write(pickle.dumps(_Plant(str(marker))))


class _Plant:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (os.makedirs, (self.marker, 0o700, True))


def test_sticky_shared_root_with_own_subfolder_is_used(tmp_path):
    """/tmp-like: world-writable with the sticky bit, our own private sub-folder."""
    root = tmp_path / "tmp-like"
    root.mkdir()
    os.chmod(root, 0o1777)
    out, _ = _run(RUN_RLS, _env(tmp_path, NUMBA_CACHE_DIR=root), tmp_path)
    assert out["CACHE"].startswith("True") and out["WARNINGS"] == "0 0"


# ------------------------------------------------------- read-only install, no HOME
def test_read_only_install_with_unwritable_home_works(tmp_path):
    install = tmp_path / "site"
    shutil.copytree(SRC / "adaptid", install / "adaptid",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for folder in [install / "adaptid", *[p for p in (install / "adaptid").rglob("*")
                                          if p.is_dir()]]:
        (folder / "__pycache__").write_text("a file: no cache folder can be made here")
    home = tmp_path / "home-file"
    home.write_text("HOME is a file: nothing can be created under it")
    for p in [install, *install.rglob("*")]:
        os.chmod(p, stat.S_IMODE(p.stat().st_mode) & ~0o222)
    try:
        env = _env(tmp_path)
        env.update(HOME=str(home), XDG_CACHE_HOME=str(home / ".cache"), PYTHONPATH=str(install))
        control = textwrap.dedent("""
            import numba
            from numba.core.caching import FunctionCache
            import adaptid._kernels.recursions._rls as k
            try:
                FunctionCache(k.rls_run.py_func)
            except RuntimeError as err:
                print("NUMBA", "no locator" in str(err))
        """)
        out, _ = _run(control, env, tmp_path)
        assert out["NUMBA"] == "True"      # numba itself could not cache here
        out, err = _run(RUN_RLS, env, tmp_path)
        assert out["CACHE"] == "False None"
        assert out["WARNINGS"] == "1 1"    # one warning, of adaptid's class
        assert out["THETA"].startswith("[np.float64(0.99") or out["THETA"].startswith("[0.99")
    finally:
        for p in [install, *install.rglob("*")]:
            os.chmod(p, stat.S_IMODE(p.stat().st_mode) | 0o200)


# -------------------------------------------------------------------- damaged cache
DAMAGES = {
    "garbage index": lambda folder: [p.write_bytes(os.urandom(64)) for p in folder.glob("*.nbi")],
    "truncated code": lambda folder: [os.truncate(p, 100) for p in folder.glob("*.nbc")],
    "empty files": lambda folder: [os.truncate(p, 0) for p in folder.glob("*.nb?")],
    "index of another pickle": lambda folder: [
        p.write_bytes(pickle.dumps(numba.__version__) + pickle.dumps(("x", [1, 2])))
        for p in folder.glob("*.nbi")],
}


@pytest.fixture(scope="module")
def filled_cache(tmp_path_factory):
    """A cache folder filled by one RUN_RLS, and that run's output (copied per test)."""
    root = tmp_path_factory.mktemp("filled")
    cache = _private(root / "cache")
    out, _ = _run(RUN_RLS, _env(root, NUMBA_CACHE_DIR=cache), root)
    return cache, out


@pytest.mark.parametrize("damage", sorted(DAMAGES))
def test_damaged_cache_recompiles(tmp_path, damage, filled_cache):
    template, first = filled_cache
    cache = tmp_path / "cache"
    shutil.copytree(template, cache)
    env = _env(tmp_path, NUMBA_CACHE_DIR=cache)
    folder = cache / Path(first["CACHE"].split(" ", 1)[1]).relative_to(template)
    assert any(folder.glob("*.nbc"))
    DAMAGES[damage](folder)
    second, _ = _run(RUN_RLS, env, tmp_path)           # recompiles, same result
    assert second["THETA"] == first["THETA"] and second["WARNINGS"] == "0 0"
    third, _ = _run(RUN_RLS, env, tmp_path)            # and the cache was repaired
    assert third["THETA"] == first["THETA"]
    index = next(folder.glob("_rls.rls_run-*.nbi")).read_bytes()
    with open(next(folder.glob("_rls.rls_run-*.nbi")), "rb") as fh:
        assert pickle.load(fh) == numba.__version__   # a valid index again
    assert len(index) > 40


def test_control_plain_numba_fails_on_the_same_damage(tmp_path):
    """Without adaptid's tolerant cache, numba raises on a truncated code file."""
    mod = tmp_path / "plainmod.py"
    mod.write_text("import numba\n\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1\n")
    env = _env(tmp_path, NUMBA_CACHE_DIR=_private(tmp_path / "cache"))
    env["PYTHONPATH"] = str(tmp_path)
    _run("import plainmod; print('R', plainmod.f(1))", env, tmp_path)
    for p in (tmp_path / "cache").rglob("*.nbc"):
        os.truncate(p, 100)
    proc = subprocess.run([sys.executable, "-c", "import plainmod; plainmod.f(1)"], env=env,
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode != 0
    assert "Error" in proc.stderr


# ------------------------------------------------------------- loading, not compiling
WARM_THEN_COMPILE = textwrap.dedent("""
    import sys, numpy as np, numba
    import adaptid
    from adaptid._kernels.recursions import _rls
    est = adaptid.RLS(3)
    est.run(np.eye(3), [1.0, 2.0, 3.0])
    print("THETA", list(est.theta))
    print("HITS", sum(_rls.rls_run.stats.cache_hits.values()),
          sum(_rls.rls_run.stats.cache_misses.values()))
    print("LINALG", "scipy.linalg" in sys.modules)
    # a compilation after the load: numba loads its registries (BLAS included) itself
    gram = numba.njit(lambda A: A.T @ A)
    rng = np.random.default_rng(1)
    A = rng.standard_normal((40, 5))
    print("GRAM", np.allclose(gram(A), A.T @ A, rtol=1e-13, atol=0.0))
    big = adaptid.RLS(5, P0=1e4)
    Phi = rng.standard_normal((30, 5)); y = Phi @ np.arange(1.0, 6.0)
    big.run(Phi, y)
    ridge = np.linalg.lstsq(np.vstack([Phi, np.eye(5) / np.sqrt(1e4)]),
                            np.concatenate([y, np.zeros(5)]), rcond=None)[0]
    print("BIG", np.allclose(big.theta, ridge, rtol=1e-10, atol=0.0))
""")


def test_cached_kernels_load_without_the_compiler_registries(tmp_path, filled_cache):
    """A process whose kernels all come from the cache does not pay for numba's
    compile-time registries (scipy.linalg, cffi, ...: about 0.2 s), gives the same
    numbers, and can still compile afterwards (numba's compiler refreshes itself)."""
    template, first = filled_cache
    cache = tmp_path / "cache"
    shutil.copytree(template, cache)
    out, _ = _run(WARM_THEN_COMPILE, _env(tmp_path, NUMBA_CACHE_DIR=cache), tmp_path)
    assert out["THETA"] == first["THETA"]
    assert out["HITS"] == "1 0"              # loaded, not compiled
    assert out["LINALG"] == "False"          # numba's full refresh did not run
    assert out["GRAM"] == "True" and out["BIG"] == "True"
