"""The kernel cache swapped or planted after the import-time check (issue 32, point 1).

numba's cache files are pickles. adaptid checks the cache folder when it is
imported (:func:`adaptid._config.cache_decision`: the folder and every folder
above it) and again at every read of an index or code file
(:func:`adaptid._kernels.toolchain._cache.read_trusted`, on a held
descriptor). Another user is simulated, as root, by a forked child that
``setuid``'s to nobody (65534). Oracle: a planted pickle whose unpickling
creates a marker folder (the control in ``tests/test_environment.py`` shows
the same plant runs from a private folder), and the estimates of a clean run.
"""

import os
import pickle
import shutil
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numba
import pytest

import adaptid
from adaptid import _config
from adaptid._kernels.toolchain import _cache

SRC = Path(adaptid.__file__).resolve().parents[1]
NOBODY = 65534

pytestmark = pytest.mark.skipif(not hasattr(os, "getuid") or os.getuid() != 0,
                                reason="simulating another user needs root")

RUN = textwrap.dedent("""
    import os, sys, warnings, numpy as np
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        import adaptid
        from adaptid import _config
        if os.environ.get("SWAP"):
            exec(os.environ["SWAP"])
        est = adaptid.RLS(3)
        est.run(np.eye(3), [1.0, 2.0, 3.0])
    kinds = [type(w.message).__name__ for w in caught]
    print("THETA", list(est.theta))
    print("CACHE", _config.CACHE)
    print("WARNINGS", kinds.count("CompilationCacheWarning"), len(kinds))
""")


class _Plant:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (os.makedirs, (self.marker, 0o700, True))


def _plant_bytes(marker):
    return pickle.dumps(numba.__version__) + pickle.dumps(_Plant(str(marker)))


@pytest.fixture
def base():
    """A folder others can traverse (pytest's tmp_path is private to root)."""
    path = Path(tempfile.mkdtemp(prefix="adaptid-swap-"))
    os.chmod(path, 0o755)
    yield path
    shutil.rmtree(path, ignore_errors=True)


def _env(base, root, **extra):
    home = base / "home"
    home.mkdir(mode=0o700, exist_ok=True)
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "PYTHONPATH", "SWAP")}
    env.update(HOME=str(home), XDG_CACHE_HOME=str(home / ".cache"), PYTHONPATH=str(SRC),
               PYTHONDONTWRITEBYTECODE="1", ADAPTID_AOT="0", NUMBA_CACHE_DIR=str(root))
    env.update(extra)
    return env


def _run(env, cwd):
    proc = subprocess.run([sys.executable, "-c", RUN], env=env, cwd=cwd,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return dict(line.partition(" ")[::2] for line in proc.stdout.splitlines())


def _sub(root):
    return Path(root) / _config._subpath(str(Path(_config.__file__).parent / "_kernels"))


def _as_nobody(fn):
    """Run ``fn()`` in a forked child as user nobody; fail if it fails."""
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child
        code = 1
        try:
            os.setgroups([])
            os.setgid(NOBODY)
            os.setuid(NOBODY)
            fn()
            code = 0
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0


# ------------------------------------------------------------ import-time check
def test_every_ancestor_is_checked(base):
    top = base / "top"
    folder = top / "a" / "b" / "cache"
    folder.mkdir(parents=True, mode=0o700)
    for p in (top, top / "a", top / "a" / "b"):
        os.chmod(p, 0o755)
    assert _config._untrusted(folder) is None
    os.chmod(top, 0o777)                         # a grandparent others can write
    assert "others can write" in _config._untrusted(folder)
    os.chmod(top, 0o1777)                        # sticky and ours (like /tmp): safe
    assert _config._untrusted(folder) is None
    os.chown(top, NOBODY, NOBODY)                # sticky but another user's: not safe
    assert "another user" in _config._untrusted(folder)
    os.chown(top, 0, 0)
    os.chmod(top / "a", 0o775)                   # group-writable
    assert _config._untrusted(folder) is not None
    os.chmod(top / "a", 0o755)
    os.symlink(folder, base / "link")            # the folder itself a symlink
    assert "symbolic link" in _config._untrusted(base / "link")
    assert not _cache._safe_folder(base / "link")


@pytest.mark.parametrize("how", ["0777 grandparent", "1777 parent of another user"])
def test_unsafe_ancestors_are_refused_at_import(base, how):
    top = base / "top"
    root = top / "shared"
    root.mkdir(parents=True, mode=0o700)
    marker = base / "PLANT_RAN"
    sub = _sub(root)
    sub.mkdir(mode=0o700)
    warm = _run(_env(base, base / "warm"), base)      # the index names numba uses
    for index in _sub(base / "warm").glob("*.nbi"):
        (sub / index.name).write_bytes(_plant_bytes(marker))
    if how == "0777 grandparent":
        os.chmod(top, 0o777)
    else:
        os.chmod(root, 0o1777)
        os.chown(root, NOBODY, NOBODY)
    out = _run(_env(base, root), base)
    assert not marker.exists(), "a planted cache index was unpickled"
    assert out["CACHE"] == "False" and out["WARNINGS"] == "1 1"
    assert out["THETA"] == warm["THETA"]


# --------------------------------------------------------- swapped after import
@pytest.mark.parametrize("kernels_imported", [True, False])
def test_folder_swapped_after_import_is_not_unpickled(base, kernels_imported):
    """The folder passes the import-time check; then its parent becomes writable
    by others, and another user renames it away and puts a folder of planted
    indexes in its place before the first run: nothing planted is unpickled and
    the result is the clean one. With the kernel module already imported, its
    cache reads the swapped folder's files: refused at the read, one warning.
    Imported after the swap, the kernel's locator refuses the folder (numba then
    tries its next locator, the in-tree ``__pycache__``)."""
    root = base / "shared"
    root.mkdir(mode=0o700)
    marker = base / "PLANT_RAN"
    warm = _run(_env(base, root), base)               # a warm cache, then the swap
    assert warm["CACHE"] == "True" and any(_sub(root).glob("*.nbi"))
    plant = _plant_bytes(marker)
    swap = textwrap.dedent(f"""
        assert _config.CACHE
        if {kernels_imported!r}:
            import adaptid._kernels.recursions._rls
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_cache_swap import _as_nobody, _swap
        os.chmod({str(root)!r}, 0o777)
        _as_nobody(lambda: _swap({str(_sub(root))!r}, {plant!r}))
    """)
    out = _run(_env(base, root, SWAP=swap), base)
    assert not marker.exists(), "a planted cache index was unpickled"
    assert Path(str(_sub(root)) + ".old").is_dir()    # the swap did happen
    assert _sub(root).stat().st_uid == NOBODY
    assert out["CACHE"] == "True"
    assert out["WARNINGS"] == ("1 1" if kernels_imported else "0 0")
    assert out["THETA"] == warm["THETA"]


def _swap(sub, plant):  # pragma: no cover - runs in the attacker's child
    names = [n for n in os.listdir(sub) if n.endswith((".nbi", ".nbc"))]
    os.rename(sub, sub + ".old")
    os.mkdir(sub, 0o755)
    for name in names:
        with open(os.path.join(sub, name), "wb") as fh:
            fh.write(plant)
        os.chmod(os.path.join(sub, name), 0o644)


def test_symlinked_index_is_not_followed(base):
    """An index replaced by a symbolic link (to a file that would run code when
    unpickled) is refused, even though the file it points to is root's."""
    root = base / "shared"
    root.mkdir(mode=0o700)
    marker = base / "PLANT_RAN"
    warm = _run(_env(base, root), base)
    elsewhere = base / "elsewhere"
    elsewhere.mkdir(mode=0o700)
    (elsewhere / "plant").write_bytes(_plant_bytes(marker))
    for index in _sub(root).glob("*.nbi"):
        index.unlink()
        index.symlink_to(elsewhere / "plant")
    out = _run(_env(base, root), base)
    assert not marker.exists(), "a symlinked cache index was followed and unpickled"
    assert out["CACHE"] == "True" and out["WARNINGS"] == "1 1"
    assert out["THETA"] == warm["THETA"]


def test_read_trusted_refuses_files_of_others(base):
    folder = base / "c"
    folder.mkdir(mode=0o700)
    (folder / "x.nbi").write_bytes(b"data")
    assert _cache.read_trusted(str(folder), "x.nbi") == b"data"
    with pytest.raises(FileNotFoundError):
        _cache.read_trusted(str(folder), "missing.nbi")
    os.chmod(folder / "x.nbi", 0o666)                 # others can write the file
    with pytest.raises(_cache.UntrustedCacheError):
        _cache.read_trusted(str(folder), "x.nbi")
    os.chmod(folder / "x.nbi", 0o600)
    os.chown(folder / "x.nbi", NOBODY, NOBODY)        # another user's file
    with pytest.raises(_cache.UntrustedCacheError):
        _cache.read_trusted(str(folder), "x.nbi")
    os.chown(folder / "x.nbi", 0, 0)
    os.chown(folder, NOBODY, NOBODY)                  # another user's folder
    with pytest.raises(_cache.UntrustedCacheError):
        _cache.read_trusted(str(folder), "x.nbi")
    os.chown(folder, 0, 0)
    os.mkfifo(folder / "fifo.nbi", 0o600)             # not a regular file, never blocks
    with pytest.raises(_cache.UntrustedCacheError):
        _cache.read_trusted(str(folder), "fifo.nbi")
