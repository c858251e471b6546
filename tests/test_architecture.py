"""The layer order of docs/architecture.md, enforced on the source.

Every import of an adaptid module (at module level or inside a function) is
read with ``ast``; a module may import only from its own layer or earlier
ones, the shared modules only from each other, and the import graph between
modules has no cycle. Calls of ``upward("...")`` (the documented hooks by
which results plot themselves and estimators export C) may name only the
modules in ``adaptid.estimators._hooks.ALLOWED``.
"""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "adaptid"

SHARED = {"_validation", "_exceptions", "_config", "_teststats", "_summary", "_lazy"}
LAYERS = {  # first path component below adaptid -> layer (docs/architecture.md)
    "_kernels": 1,
    "estimators": 2, "forgetting": 2,
    "_lstsq": 3, "constrained": 3,
    "continuous": 4,
    "models": 5, "datasets": 5,
    "diagnostics": 6,
    "io": 7, "plot": 7, "codegen": 7, "sklearn": 7,
    "fleet": 8,
    "cli": 9,
}
EXEMPT = {"__init__", "__main__"}  # the package's lazy index and `python -m adaptid`


def _modules():
    out = {}
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).with_suffix("")
        parts = rel.parts
        name = ".".join(("adaptid",) + parts)
        if parts[-1] == "__init__":
            name = ".".join(("adaptid",) + parts[:-1])
        out[name] = path
    return out


MODULES = _modules()


def _component(module):
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _layer(module):
    comp = _component(module)
    if comp in SHARED:
        return 0
    return LAYERS.get(comp)


def _resolve(module, path, node):
    """adaptid modules named by an Import/ImportFrom node of ``module``."""
    is_pkg = path.name == "__init__.py"
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name.split(".")[0] == "adaptid"]
    if node.level == 0:
        base = node.module or ""
        if base.split(".")[0] != "adaptid":
            return []
    else:
        pkg = module.split(".") if is_pkg else module.split(".")[:-1]
        pkg = pkg[: len(pkg) - (node.level - 1)]
        base = ".".join(pkg + ([node.module] if node.module else []))
    targets = []
    for alias in node.names:
        if base == "adaptid" and alias.name == "__version__":
            continue  # the version string is part of the index every layer may read
        sub = f"{base}.{alias.name}"
        targets.append(sub if sub in MODULES else base)
    return targets


def _imports():
    edges = {}
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        deps = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                deps.update(t for t in _resolve(module, path, node) if t != module)
        edges[module] = deps
    return edges


EDGES = _imports()


def test_every_module_has_a_layer():
    missing = sorted(m for m in MODULES if _component(m) not in EXEMPT and _layer(m) is None)
    assert not missing, f"modules outside the layer table of docs/architecture.md: {missing}"


def test_no_upward_import():
    bad = []
    for module, deps in EDGES.items():
        if _component(module) in EXEMPT:
            continue
        lay = _layer(module)
        for dep in deps:
            if dep == "adaptid" and lay != max(LAYERS.values()):
                bad.append(f"{module} imports the package index 'adaptid' (import the module)")
                continue
            dl = _layer(dep)
            if dl is None:
                continue
            if (lay == 0 and dl != 0) or dl > lay:
                bad.append(f"{module} (layer {lay}) imports {dep} (layer {dl})")
    assert not bad, "\n".join(sorted(bad))


def test_only_the_shell_imports_typer_or_rich():
    bad = []
    for module, path in MODULES.items():
        if _component(module) == "cli":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            bad += [f"{module} imports {n}" for n in names if n.split(".")[0] in ("typer", "rich")]
    assert not bad, bad


def test_no_import_cycle():
    state, stack, cycles = {}, [], []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for d in sorted(EDGES.get(m, ())):
            if d not in MODULES or _component(d) in EXEMPT:
                continue
            if state.get(d) == 1:
                cycles.append(stack[stack.index(d):] + [d])
            elif d not in state:
                visit(d)
        stack.pop()
        state[m] = 2

    for m in sorted(EDGES):
        if m not in state:
            visit(m)
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_upward_hooks_name_only_allowed_modules():
    from adaptid.estimators._hooks import ALLOWED
    found = []
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "upward":
                arg = node.args[0]
                name = arg.value if isinstance(arg, ast.Constant) else None
                found.append((module, name))
    assert found, "the hook is used (Trajectory.plot, est.to_c)"
    assert all(name in ALLOWED for _, name in found), found


@pytest.mark.parametrize("bad_import, layer_of", [
    ("from ..cli import main", "adaptid.estimators._engine"),
    ("from .. import fleet", "adaptid.models._arx"),
])
def test_the_checker_sees_an_upward_import(bad_import, layer_of):
    """The rule is not vacuous: a planted upward import is caught."""
    node = ast.parse(bad_import).body[0]
    deps = _resolve(layer_of, MODULES[layer_of], node)
    assert deps and all(_layer(d) > _layer(layer_of) for d in deps)


_COMPILERS = {"njit", "jit", "vectorize", "guvectorize", "cfunc", "stencil", "prange"}


def test_compiled_code_lives_only_under_kernels():
    """Issue 13, point 5: every numba-compiled function is in src/adaptid/_kernels/."""
    bad = []
    for module, path in MODULES.items():
        # _config defines the one decorator the kernels use (adaptid._config.njit)
        if _component(module) in ("_kernels", "_config"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            # a compiling decorator imported (from numba import njit) or used (@numba.njit)
            if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "numba":
                if any(a.name in _COMPILERS for a in node.names):
                    bad.append(module)
            if isinstance(node, ast.Attribute) and node.attr in _COMPILERS and \
                    getattr(node.value, "id", None) == "numba":
                bad.append(module)
    assert not bad, f"modules outside _kernels/ that use numba: {sorted(set(bad))}"


def test_no_kernel_file_over_400_lines():
    long = {p.name: n for p in (SRC / "_kernels").rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 400}
    assert not long, long


def test_kernels_take_njit_from_config():
    """Every compiled kernel goes through adaptid._config.njit (the cache decision
    of issue 14: no cache in a folder others can write, damaged caches recompile)."""
    bad = []
    for path in sorted((SRC / "_kernels").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "") == "numba" and \
                    any(a.name in ("njit", "jit") for a in node.names):
                bad.append(path.name)
            if isinstance(node, ast.keyword) and node.arg == "cache" and \
                    isinstance(node.value, ast.Constant):
                bad.append(f"{path.name}: literal cache=")
    assert not bad, bad
