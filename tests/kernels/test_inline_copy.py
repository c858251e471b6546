"""adaptid._kernels.toolchain._inline: numba's inliner copies an inlined IR once, not once per block.

The patch changes compile time only: the kernels' machine code must be the
same with and without it, it must apply only to adaptid's own functions, and
``ADAPTID_FAST_INLINE=0`` must leave numba untouched.
"""

import json
import os
import subprocess
import sys
import textwrap
import types

import numba
import numpy as np
import pytest
from numba.core import inline_closurecall as icc

import adaptid  # noqa: F401 - importing adaptid installs the patch
from adaptid._kernels.toolchain import _inline

_ASM = textwrap.dedent("""
    import hashlib, json, sys
    import numpy as np
    from adaptid._kernels.toolchain import _inline
    from adaptid._kernels.recursions import _rls
    from adaptid._kernels.toolchain._dims import tags
    import adaptid
    rng = np.random.default_rng(0)
    X = rng.standard_normal((50, 3))
    est = adaptid.RLS(3)
    est.run(X, X @ np.ones(3))
    asm = {str(sig): hashlib.sha256(_rls.rls_run.inspect_asm(sig).encode()).hexdigest()
           for sig in _rls.rls_run.signatures}
    print(json.dumps({"installed": _inline.installed(), "asm": asm, "theta": est.theta.tolist()}))
""")


def _compile_in_fresh_process(tmp_path, fast):
    cache = tmp_path / f"cache{fast}"
    cache.mkdir(mode=0o700)
    env = dict(os.environ, ADAPTID_FAST_INLINE=fast, NUMBA_CACHE_DIR=str(cache))
    env.pop("ADAPTID_MAX_SPECIALISED_N", None)
    out = subprocess.run([sys.executable, "-c", _ASM], env=env, capture_output=True,
                         text=True, timeout=600, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_machine_code_is_the_same_with_and_without_the_patch(tmp_path):
    with_patch = _compile_in_fresh_process(tmp_path, "1")
    without = _compile_in_fresh_process(tmp_path, "0")
    assert with_patch["installed"] is True
    assert without["installed"] is False
    assert with_patch["asm"] and with_patch["asm"] == without["asm"]
    assert with_patch["theta"] == without["theta"]


def test_installed_by_default():
    assert _inline.installed()
    assert icc.copy is _inline._SharedMemoCopy
    assert icc.InlineWorker.inline_ir.__wrapped__ is not None


_PAIR = textwrap.dedent("""
    @numba.njit(inline="always")
    def callee(x):
        s = 0.0
        for i in range(x.shape[0]):
            if x[i] > 0:
                s += x[i]
            else:
                s -= 2.0 * x[i]
        return s

    @numba.njit
    def caller(x):
        return callee(x) + callee(x[::-1])
""")


def _inlining_pair(monkeypatch, name):
    """A caller with an inlined callee of several blocks, in a new module ``name``."""
    module = types.ModuleType(name)
    module.numba = numba
    monkeypatch.setitem(sys.modules, name, module)
    exec(_PAIR, module.__dict__)
    return module.caller


@pytest.mark.parametrize("module, shared", [("adaptid._fake_kernels", True),
                                            ("someone_else", False)])
def test_applies_to_adaptid_functions_only(monkeypatch, module, shared):
    seen = []
    real = _inline._SharedMemoCopy.deepcopy

    def spy(x, memo=None, _nil=[]):  # noqa: B006
        seen.append(getattr(_inline._state, "memos", None) is not None)
        return real(x, memo, _nil)

    monkeypatch.setattr(_inline._SharedMemoCopy, "deepcopy", staticmethod(spy))
    fn = _inlining_pair(monkeypatch, module)
    x = np.array([1.0, -2.0, 3.0, -0.5])
    expected = 2 * (1.0 + 4.0 + 3.0 + 1.0)
    assert fn(x) == expected
    assert seen, "numba's inliner did not copy the callee's blocks"
    assert set(seen) == {shared}


def test_switched_off_by_the_environment():
    env = dict(os.environ, ADAPTID_FAST_INLINE="0")
    code = ("import adaptid; from adaptid._kernels.toolchain import _inline; "
            "from numba.core import inline_closurecall as icc; import copy; "
            "print(_inline.installed(), icc.copy is copy)")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=120, check=True)
    assert out.stdout.split() == ["False", "True"]
