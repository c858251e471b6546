"""Compile the kernels that first calls need, for ``pip install`` (ahead of time).

``python -m adaptid.cli._aot build [OUT]`` runs :data:`TASKS` in fresh processes,
each on its own empty numba cache folder, and merges numba's cache files of
adaptid's kernels into one folder (default: ``adaptid/_kernels/_aot``) with a
``MANIFEST.json``. The build backend ``tools/pep517/aot_backend.py`` runs it
when pip builds adaptid; :mod:`adaptid._kernels.toolchain._installed` loads the entries
on a cache miss, when they match.

The kernels: the default form of :class:`adaptid.RLS` at every size it is
specialised for (n = 1..64: U-D up to 15, the square-root form above) and the
generic kernel above (``run`` and ``update`` share the kernel), and what
``adaptid demo`` runs: the simulated motor, the CLI's size-generic RLS,
sliding window and Kalman kernels, and the recursive residuals of its report;
and the constancy tests of ``adaptid fit``'s report (CUSUM, F statistics, break
dating).
They are compiled by calling the public functions as a user does, so the
signatures are those of first calls. Needs numpy, scipy and numba only.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

from .._kernels.toolchain import _installed

__all__ = ["TASKS", "build", "main"]


def _rls(n):
    """RLS(n) with its default form, as a user starts it: ``run`` and ``update``, and for
    n <= :data:`STEP_MAX_N` the narrow step entry ``update`` then takes."""
    import numpy as np

    import adaptid

    Phi = np.random.default_rng(n).standard_normal((8, n))
    y = Phi @ np.ones(n)
    est = adaptid.RLS(n, forgetting=0.99)
    est.run(Phi, y)
    est.update(Phi[0], y[0])
    if n <= STEP_MAX_N:
        est.compile_update()  # update's narrow step entry


def _demo():
    """``adaptid demo``'s kernels, with the demo's array types (no pandas needed)."""
    import numpy as np

    from ._demo import DEMO_METHODS, compile_kernels
    from adaptid.datasets._dc_motor import MOTOR_PARAMETERS, _motor_states
    from adaptid.diagnostics import recursive_residuals

    _motor_states(np.zeros(10), 1e-3, 5, MOTOR_PARAMETERS)
    compile_kernels(DEMO_METHODS)
    Phi = np.random.default_rng(0).standard_normal((12, 3))
    recursive_residuals(Phi, Phi @ np.ones(3))


def _fit_report():
    """The constancy tests of ``adaptid fit``'s report (recursive residuals, CUSUM,
    F statistics, break dating), with the command's array types."""
    import numpy as np

    from ._engine import _cusum

    rng = np.random.default_rng(0)
    Phi = rng.standard_normal((80, 3))
    _cusum(Phi, Phi @ np.ones(3) + 0.1 * rng.standard_normal(80))


#: update's narrow step entry (``compile_update``) is built for n up to this: a second
#: compilation per n, so not for the square-root form's sizes 17..64 (those compile it
#: on demand with ``compile_update``)
STEP_MAX_N = 16

#: (name, relative cost): what the build compiles. The costs (seconds of compile,
#: roughly) only balance the work between the build's processes.
TASKS = ([("demo", 16.0), ("fit", 3.0)] + [(f"rls:{n}", 4.0) for n in range(1, 17)]
         + [(f"rls:{n}", 3.0) for n in range(17, 66)])


def _run_task(name):
    if name == "demo":
        _demo()
    elif name == "fit":
        _fit_report()
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


# sys.path as the parent has it (pip's build environment resets PYTHONPATH's effect)
_WORKER = "import sys; sys.path[:0] = {path!r}; from adaptid.cli._aot import main; sys.exit(main({args!r}))"


def build(out=None, *, jobs=None, tasks=None) -> dict:
    """Compile :data:`TASKS` in ``jobs`` fresh processes (each with its own empty
    numba cache folder) and store numba's cache files of them in ``out``.

    ``out`` is replaced as a whole: written beside it, then renamed. Returns the
    manifest. Raises ``RuntimeError`` if a process fails.
    """
    import numba

    from .._kernels.toolchain._cache import SOURCE_STAMP

    t0 = time.perf_counter()
    out = out or _installed.folder()
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
                                           env=env, stdin=subprocess.DEVNULL), names))
        failed = [names for p, names in procs if p.wait() != 0]
        if failed:
            raise RuntimeError(f"adaptid AOT build: the process compiling {failed[0]} failed")
        stage = tempfile.mkdtemp(prefix=".aot-", dir=parent)
        try:
            os.chmod(stage, 0o755)
            count = _installed.merge([os.path.join(tmp, f"cache{i}") for i in range(len(groups))], stage)
            man = {"numba": numba.__version__, "stamp": SOURCE_STAMP, "entries": count,
                   "python": list(sys.version_info[:2]),
                   "tasks": [n for g in groups for n in g],
                   "seconds": round(time.perf_counter() - t0, 1)}
            with open(os.path.join(stage, _installed.MANIFEST), "w", encoding="utf-8") as fh:
                json.dump(man, fh, indent=1)
            shutil.rmtree(out, ignore_errors=True)
            os.replace(stage, out)
        except BaseException:
            shutil.rmtree(stage, ignore_errors=True)  # no half-written folder left beside out
            raise
    _installed._READY.clear()
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

        ap = argparse.ArgumentParser(prog="python -m adaptid.cli._aot build")
        ap.add_argument("out", nargs="?", default=None)
        ap.add_argument("--jobs", type=int, default=None)
        ap.add_argument("--tasks", nargs="+", default=None, help="e.g. rls:3 demo")
        args = ap.parse_args(argv[1:])
        man = build(args.out, jobs=args.jobs, tasks=args.tasks)
        print(f"adaptid AOT: {man['entries']} compiled kernels in {args.out or _installed.folder()} "
              f"({man['seconds']} s)", flush=True)
        return 0
    print("usage: python -m adaptid.cli._aot build [OUT] [--jobs J] [--tasks T ...]", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
