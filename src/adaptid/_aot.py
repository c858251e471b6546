"""Kernels compiled when adaptid is installed (ahead of time), loaded on a cache miss.

numba compiles a kernel the first time a process calls it with new argument
types and keeps the machine code in its cache folder (:mod:`adaptid._config`).
On a fresh install that folder is empty, and the first ``RLS(n).run`` or
``adaptid demo`` spends most of its time in numba's compiler. So ``pip
install`` compiles the kernels that first calls need, once, at build time
(the build backend ``tools/pep517/aot_backend.py`` runs ``python -m
adaptid._aot build``), and ships numba's cache files of them in
``adaptid/_kernels/_aot`` with a ``MANIFEST.json``.

At run time a miss in the cache folder falls back to that folder
(:func:`load`, called by the cache of :func:`adaptid._config.njit`), when

* ``ADAPTID_AOT`` is not ``0`` (``ADAPTID_AOT_DIR`` names another folder);
* the folder is trusted as a cache folder is (owned by the user or root,
  not writable by group or others: numba's cache files are pickles);
* its manifest names this numba version and the kernels' source stamp
  (:data:`adaptid._kernels._cache.SOURCE_STAMP`): an edit to any kernel
  file, or another numba, makes every entry stale;
* and the entry's key matches, which numba builds from the signature, the
  target CPU (name and features) and the function's bytecode: code compiled
  on another kind of machine is never used.

Anything else is a miss, and numba compiles as it would without this
folder. What the folder holds is exactly what numba compiled from the same
source for the same signatures; nothing is changed on the way.

The kernels (:data:`TASKS`): the default form of :class:`adaptid.RLS` at
every size it is specialised for (n = 1..64: U-D up to 15, the square-root
form above) and the generic kernel above (``run`` and ``update`` share the
kernel), and what ``adaptid demo`` runs: the simulated
motor, the CLI's size-generic RLS, sliding window and Kalman kernels, and the
recursive residuals of its report.
"""

from __future__ import annotations

import json
import os
import pickle
import shutil
import subprocess
import sys
import tempfile
import time

__all__ = ["AOT_DIR", "TASKS", "build", "enabled", "folder", "load", "status"]

#: Where the installed kernels are (inside the package: as trusted as its code).
AOT_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_kernels", "_aot")
_MANIFEST = "MANIFEST.json"


def folder() -> str:
    """:data:`AOT_DIR`, or ``ADAPTID_AOT_DIR`` when set (read at each call)."""
    return os.environ.get("ADAPTID_AOT_DIR") or AOT_DIR


def enabled() -> bool:
    """False when ``ADAPTID_AOT=0`` (read at each call: tests switch it)."""
    return os.environ.get("ADAPTID_AOT", "1") != "0"


_READY = {}


def _manifest(where=None):
    try:
        with open(os.path.join(where or folder(), _MANIFEST), encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None


def _ready():
    """The manifest if the folder can be used by this process, else None (memoised)."""
    where = folder()
    if where in _READY:
        return _READY[where]
    import numba

    from ._config import _untrusted
    from ._kernels._cache import SOURCE_STAMP

    man = _manifest(where)
    ok = (man is not None and _untrusted(where) is None
          and man.get("numba") == numba.__version__ and man.get("stamp") == SOURCE_STAMP)
    _READY[where] = man if ok else None
    return _READY[where]


def load(cache, sig, target_context):
    """The installed compile result of ``cache``'s function for ``sig``, or None.

    ``cache`` is numba's ``FunctionCache`` of a kernel (its locator one of
    :mod:`adaptid._kernels._cache`'s); the entry is read as numba reads its own
    cache (``IndexDataCacheFile``) and rebuilt by the cache's own ``rebuild``.
    """
    if not enabled() or _ready() is None:
        return None
    from numba.core.caching import IndexDataCacheFile

    from ._kernels._cache import _KernelsLocator

    impl = cache._impl
    if not isinstance(impl.locator, _KernelsLocator):
        return None
    store = IndexDataCacheFile(cache_path=folder(), filename_base=impl.filename_base,
                               source_stamp=impl.locator.get_source_stamp())
    data = store.load(cache._index_key(sig, target_context.codegen()))
    return None if data is None else impl.rebuild(target_context, data)


def status() -> dict:
    """What ``adaptid info`` shows: the folder, whether it is used, and why not."""
    import numba

    from ._kernels._cache import SOURCE_STAMP

    man = _manifest()
    out = {"folder": folder(), "enabled": enabled(), "kernels": 0, "used": False}
    if man is None:
        out["why_not"] = "not built (pip install builds it; ADAPTID_AOT_BUILD=0 skips it)"
        return out
    out["kernels"] = int(man.get("entries", 0))
    out["seconds_to_build"] = man.get("seconds")
    if man.get("numba") != numba.__version__:
        out["why_not"] = f"built with numba {man.get('numba')}, this is numba {numba.__version__}"
    elif man.get("stamp") != SOURCE_STAMP:
        out["why_not"] = "built from other kernel sources (edited since the install)"
    elif not out["enabled"]:
        out["why_not"] = "ADAPTID_AOT=0"
    elif _ready() is None:
        out["why_not"] = "the folder is writable by others or belongs to another user"
    else:
        out["used"] = True
    return out


# ---------------------------------------------------------------------- build

def _rls(n):
    """RLS(n) with its default form, as a user starts it: ``run``, then ``update``."""
    import numpy as np

    import adaptid

    Phi = np.random.default_rng(n).standard_normal((8, n))
    y = Phi @ np.ones(n)
    est = adaptid.RLS(n, forgetting=0.99)
    est.run(Phi, y)
    est.update(Phi[0], y[0])


def _demo():
    """``adaptid demo``'s kernels, with the demo's array types (no pandas needed)."""
    import numpy as np

    from adaptid.cli._demo import DEMO_METHODS, compile_kernels
    from adaptid.datasets._dc_motor import MOTOR_PARAMETERS, _motor_states
    from adaptid.diagnostics import recursive_residuals

    _motor_states(np.zeros(10), 1e-3, 5, MOTOR_PARAMETERS)
    compile_kernels(DEMO_METHODS)
    Phi = np.random.default_rng(0).standard_normal((12, 3))
    recursive_residuals(Phi, Phi @ np.ones(3))


#: (name, relative cost): what the build compiles. The costs (seconds of compile,
#: roughly) only balance the work between the build's processes.
TASKS = ([("demo", 16.0)] + [(f"rls:{n}", 2.0) for n in range(1, 17)]
         + [(f"rls:{n}", 3.0) for n in range(17, 66)])


def _run_task(name):
    if name == "demo":
        _demo()
    elif name.startswith("rls:"):
        _rls(int(name[4:]))
    else:
        raise ValueError(f"task: unknown {name!r}")


def _split(tasks, jobs):
    """Longest first onto the least loaded of ``jobs`` lists."""
    loads = [[0.0, []] for _ in range(jobs)]
    for name, cost in sorted(tasks, key=lambda t: -t[1]):
        slot = min(loads, key=lambda s: s[0])
        slot[0] += cost
        slot[1].append(name)
    return [names for _, names in loads if names]


def _merge(folders, out):
    """Copy every adaptid kernel's entries of numba's cache ``folders`` into ``out``,
    renumbering the data files, with numba's own index format. Returns the count."""
    import numba
    from numba.core.caching import IndexDataCacheFile

    from ._kernels._cache import SOURCE_STAMP

    stamp = ("adaptid-kernels", SOURCE_STAMP)
    merged = {}  # filename base -> {key: data bytes}
    for folder in folders:
        for root, _, files in os.walk(folder):
            for fn in files:
                if not fn.endswith(".nbi"):
                    continue
                with open(os.path.join(root, fn), "rb") as fh:
                    version = pickle.load(fh)
                    if version != numba.__version__:
                        continue
                    got, overloads = pickle.loads(fh.read())
                if got != stamp:  # not one of the kernels (or another source)
                    continue
                entries = merged.setdefault(fn[:-4], {})
                for key, data_name in overloads.items():
                    with open(os.path.join(root, data_name), "rb") as fh:
                        entries[key] = fh.read()
    count = 0
    for base, entries in merged.items():
        store = IndexDataCacheFile(cache_path=out, filename_base=base, source_stamp=stamp)
        index = {}
        for i, (key, blob) in enumerate(entries.items(), 1):
            name = f"{base}.{i}.nbc"
            with open(os.path.join(out, name), "wb") as fh:
                fh.write(blob)
            index[key] = name
            count += 1
        store._save_index(index)
    return count


# sys.path as the parent has it (pip's build environment resets PYTHONPATH's effect)
_WORKER = "import sys; sys.path[:0] = {path!r}; from adaptid._aot import main; sys.exit(main({args!r}))"


def build(out=None, *, jobs=None, tasks=None, quiet=False) -> dict:
    """Compile :data:`TASKS` in ``jobs`` fresh processes (each with its own empty
    numba cache folder) and store numba's cache files of them in ``out``.

    ``out`` is replaced as a whole: written beside it, then renamed. Returns the
    manifest. Raises ``RuntimeError`` if a process fails.
    """
    import numba

    from ._kernels._cache import SOURCE_STAMP

    t0 = time.perf_counter()
    out = out or folder()
    jobs = max(1, int(jobs or min(os.cpu_count() or 1, 4)))
    groups = _split(TASKS if tasks is None else [(t, 1.0) for t in tasks], jobs)
    parent = os.path.dirname(os.path.abspath(out))
    os.makedirs(parent, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="adaptid-aot-") as tmp:
        procs = []
        for i, names in enumerate(groups):
            cache = os.path.join(tmp, f"cache{i}")
            os.mkdir(cache, 0o700)
            env = dict(os.environ, NUMBA_CACHE_DIR=cache, ADAPTID_AOT="0", ADAPTID_PREWARM="0")
            env.pop("ADAPTID_MAX_SPECIALISED_N", None)
            procs.append((subprocess.Popen([sys.executable, "-c", _WORKER.format(
                                               path=[p for p in sys.path if p],
                                               args=["worker", *names])],
                                           env=env, stdin=subprocess.DEVNULL,
                                           stdout=subprocess.DEVNULL if quiet else None), names))
        failed = [names for p, names in procs if p.wait() != 0]
        if failed:
            raise RuntimeError(f"adaptid AOT build: the process compiling {failed[0]} failed")
        stage = tempfile.mkdtemp(prefix=".aot-", dir=parent)
        os.chmod(stage, 0o755)
        count = _merge([os.path.join(tmp, f"cache{i}") for i in range(len(groups))], stage)
        man = {"numba": numba.__version__, "stamp": SOURCE_STAMP, "entries": count,
               "python": list(sys.version_info[:2]), "tasks": [n for g in groups for n in g],
               "seconds": round(time.perf_counter() - t0, 1)}
        with open(os.path.join(stage, _MANIFEST), "w", encoding="utf-8") as fh:
            json.dump(man, fh, indent=1)
        shutil.rmtree(out, ignore_errors=True)
        os.replace(stage, out)
    _READY.clear()
    return man


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["worker"]:
        for name in argv[1:]:
            t = time.perf_counter()
            _run_task(name)
            print(f"adaptid AOT: {name} {time.perf_counter() - t:.1f} s", flush=True)
        return 0
    if argv[:1] == ["build"]:
        import argparse

        ap = argparse.ArgumentParser(prog="python -m adaptid._aot build")
        ap.add_argument("out", nargs="?", default=None)
        ap.add_argument("--jobs", type=int, default=None)
        ap.add_argument("--tasks", nargs="+", default=None, help="e.g. rls:3 demo")
        args = ap.parse_args(argv[1:])
        man = build(args.out, jobs=args.jobs, tasks=args.tasks)
        print(f"adaptid AOT: {man['entries']} compiled kernels in {args.out or folder()} "
              f"({man['seconds']} s)", flush=True)
        return 0
    print("usage: python -m adaptid._aot build [OUT] [--jobs J] [--tasks T ...]", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
