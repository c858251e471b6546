"""The basement's rooms (issue 31): numba's internals only in ``_kernels/toolchain``,
a docstring for every kernel subpackage, entry points in tables, every patch switchable.

Read with ``ast`` (the source, not what happens to be imported), except the
patch tests, which start a fresh process with ``ADAPTID_NUMBA_PATCHES=0``.
"""

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / "src" / "adaptid"
KERNELS = SRC / "_kernels"
TOOLCHAIN = KERNELS / "toolchain"
#: numba's internals (its public API is numba, numba.njit, numba.prange, numba.types, ...)
INTERNAL = ("numba.core", "numba.extending", "numba.np", "numba.cpython", "numba.misc",
            "numba.typed.typedobjectutils", "llvmlite")
SUBPACKAGES = ("toolchain", "recursions", "lanes", "layers")


def _imported(tree):
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module
            yield from (f"{node.module}.{a.name}" for a in node.names)


def _internal(name):
    return any(name == p or name.startswith(p + ".") for p in INTERNAL)


def test_numba_internals_only_in_the_toolchain():
    bad = []
    for path in sorted(SRC.rglob("*.py")):
        if TOOLCHAIN in path.parents:
            continue
        names = {n for n in _imported(ast.parse(path.read_text(encoding="utf-8"))) if _internal(n)}
        bad.extend(f"{path.relative_to(SRC)}: {n}" for n in sorted(names))
    assert not bad, "numba internals outside _kernels/toolchain:\n" + "\n".join(bad)


def test_the_check_is_not_vacuous():
    """The toolchain does use numba's internals, and the checker sees them."""
    seen = set()
    for path in TOOLCHAIN.glob("*.py"):
        seen |= {n for n in _imported(ast.parse(path.read_text(encoding="utf-8"))) if _internal(n)}
    assert {"numba.core.caching", "numba.extending", "llvmlite.ir"} <= seen
    assert _internal("numba.np.arrayobj") and not _internal("numba.types")


def test_every_kernel_subpackage_has_a_docstring():
    for sub in SUBPACKAGES:
        init = (KERNELS / sub / "__init__.py").read_text(encoding="utf-8")
        doc = ast.get_docstring(ast.parse(init))
        assert doc and len(doc.split()) >= 10, sub
    flat = sorted(p.name for p in KERNELS.glob("*.py") if p.name != "__init__.py")
    assert not flat, f"kernel modules outside the subpackages: {flat}"


def test_module_names_are_unique_across_rooms():
    """All kernels share numba's cache folder of ``_kernels``, whose file names are
    built from a module's own name: two modules of one name would collide."""
    names = [p.stem for p in KERNELS.rglob("_*.py") if p.name != "__init__.py"]
    assert len(names) == len(set(names)), sorted(n for n in names if names.count(n) > 1)


def test_entry_points_are_declared_in_tables():
    """No entry point is found from a built string: every public name maps to a
    module and a key of its ENTRIES table, and each table is a literal dict."""
    from adaptid import _kernels

    tree = ast.parse((KERNELS / "__init__.py").read_text(encoding="utf-8"))
    assert not any(isinstance(n, ast.Call) and getattr(n.func, "id", "") == "getattr"
                   for n in ast.walk(tree))
    for name, (module, key) in _kernels.ENTRY_TABLE.items():
        mod = ast.parse((KERNELS / "recursions" / f"{module}.py").read_text(encoding="utf-8"))
        tables = [n.value for n in mod.body if isinstance(n, ast.Assign)
                  and [getattr(t, "id", None) for t in n.targets] == ["ENTRIES"]]
        assert len(tables) == 1 and isinstance(tables[0], ast.Dict), module
        assert key in [k.value for k in tables[0].keys], (name, module)
        entries = getattr(_kernels, name)
        assert isinstance(entries, _kernels.Entries) and entries.run is not None


def _fresh(code, **env):
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600,
                         env={**os.environ, "PYTHONPATH": str(SRC.parent), **env})
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


_PROBE = """
import json
from numba.core import caching
import adaptid
from adaptid import _kernels
from adaptid._kernels.toolchain import _dispatch, _inline, _installed, _patches, _scratch, _vecir
mine = [c for c in caching.CacheImpl._locator_classes if c.__module__.startswith("adaptid.")]
print(json.dumps({"locators": len(mine), "inline": _inline.installed(),
                  "aot": _installed.enabled(), "vector_ir": _vecir.VECTOR_IR,
                  "stack": _scratch.STACK,
                  "step": _dispatch.entry_point(_kernels.RLS.run, ()) is None,
                  "status": {p["name"]: p["on"] for p in _patches.status()}}))
"""


def test_every_patch_off_with_the_master_switch(tmp_path):
    """ADAPTID_NUMBA_PATCHES=0: numba's locator list and inliner untouched, no installed
    kernels, no vector IR or stack arrays, no step look-up (``.ci/run`` runs the core
    tests so)."""
    got = _fresh(_PROBE, ADAPTID_NUMBA_PATCHES="0", NUMBA_CACHE_DIR=str(tmp_path))
    assert got["locators"] == 0 and got["inline"] is False and got["aot"] is False
    assert got["vector_ir"] is False and got["stack"] is False and got["step"] is True
    assert not any(got["status"].values()), got["status"]


def test_patches_on_by_default(tmp_path):
    env = {k: "1" for k in ("ADAPTID_NUMBA_PATCHES", "ADAPTID_FAST_INLINE", "ADAPTID_AOT")}
    got = _fresh(_PROBE, NUMBA_CACHE_DIR=str(tmp_path), **env)
    assert got["locators"] == 3 and got["inline"] is True and got["aot"] is True
    assert got["vector_ir"] is True and got["stack"] is True
    assert all(got["status"].values()), got["status"]


def test_one_switch_turns_one_patch_off(tmp_path):
    got = _fresh(_PROBE, NUMBA_CACHE_DIR=str(tmp_path), ADAPTID_NUMBA_PATCHES="1",
                 ADAPTID_CACHE_LOCATORS="0")
    assert got["locators"] == 0 and got["inline"] is True
    assert [k for k, on in got["status"].items() if not on] == ["cache-locators"]
