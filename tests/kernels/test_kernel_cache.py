"""numba's cache of adaptid's kernels: a stamp per kernel module, safe folders.

A kernel inlines pieces of other files (the Bierman stages of _bierman.py in
the streams of _rls.py, ...): numba alone would keep serving a stale compiled
kernel after such a piece changed (it stamps each function with its own
file only). adaptid._kernels.toolchain._cache gives every kernel the hash of its
module, the kernel modules it imports (transitively) and _config.py, and refuses
cache folders another user could write.
"""

import os
import shutil

import numpy as np

from adaptid._kernels.toolchain import _cache


def test_kernels_use_the_adaptid_locator():
    import adaptid
    from adaptid._kernels.recursions import _rls

    adaptid.RLS(3).run(np.eye(3), np.ones(3))
    impl = _rls.rls_run._cache._impl
    assert isinstance(impl.locator, _cache._KernelsLocator)
    stamp = _cache.module_stamp(_rls.__file__)
    assert impl.locator.get_source_stamp() == ("adaptid-kernels", stamp)


def test_the_stamp_changes_with_any_kernel_file(tmp_path, monkeypatch):
    copy = tmp_path / "_kernels"
    shutil.copytree(_cache._DIR, copy, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(_cache._DIR.parent / "_config.py", tmp_path / "_config.py")
    monkeypatch.setattr(_cache, "_DIR", copy)
    before = _cache._source_stamp()
    assert before == _cache.SOURCE_STAMP  # the same files give the same stamp
    with open(copy / "recursions" / "_bierman.py", "a") as fh:  # an edit to an inlined piece only
        fh.write("\n# an edit\n")
    assert _cache._source_stamp() != before
    with open(tmp_path / "_config.py", "a") as fh:
        fh.write("\n")


def test_folders_others_can_write_are_refused(tmp_path):
    d = tmp_path / "cache"
    d.mkdir()
    os.chmod(d, 0o755)
    assert _cache._safe_folder(d)
    os.chmod(d, 0o775)
    assert not _cache._safe_folder(d)
    os.chmod(d, 0o757)
    assert not _cache._safe_folder(d)
    assert not _cache._safe_folder(tmp_path / "missing")


def test_a_kernel_stamp_covers_its_module_and_what_it_imports(tmp_path, monkeypatch):
    """An edit to an inlined piece restamps the kernels built from it, and only them."""
    copy = tmp_path / "_kernels"
    shutil.copytree(_cache._DIR, copy, ignore=shutil.ignore_patterns("__pycache__", "_aot"))
    shutil.copy(_cache._DIR.parent / "_config.py", tmp_path / "_config.py")
    monkeypatch.setattr(_cache, "_DIR", copy)
    _cache.module_stamp.cache_clear()
    rls, sim = str(copy / "recursions" / "_rls.py"), str(copy / "layers" / "_simulators.py")
    before = _cache.module_stamp(rls), _cache.module_stamp(sim)
    with open(copy / "recursions" / "_bierman.py", "a") as fh:
        fh.write("\n# an edit\n")
    _cache.module_stamp.cache_clear()
    assert _cache.module_stamp(rls) != before[0]  # _rls imports _bierman
    assert _cache.module_stamp(sim) == before[1]  # _simulators does not
    with open(tmp_path / "_config.py", "a") as fh:  # _config is in every stamp
        fh.write("\n")
    _cache.module_stamp.cache_clear()
    assert _cache.module_stamp(sim) != before[1]
    monkeypatch.undo()
    _cache.module_stamp.cache_clear()


_COMPILE_TWO = """
import json, numpy as np
from adaptid.datasets._dc_motor import MOTOR_PARAMETERS, _motor_states
from adaptid.diagnostics import recursive_residuals
from adaptid._kernels.layers import _residuals, _simulators
_motor_states(np.zeros(10), 1e-3, 5, MOTOR_PARAMETERS)
Phi = np.random.default_rng(0).standard_normal((12, 3))
recursive_residuals(Phi, Phi @ np.ones(3))
hits = lambda d: sum(d.stats.cache_hits.values())
print(json.dumps({"sim": hits(_simulators.simulate_dc_motor),
                  "res": hits(_residuals.recursive_residuals_kernel)}))
"""


def test_an_edit_recompiles_only_the_edited_kernel(tmp_path):
    """Issue 31: in a copy of the package, two kernels of two modules are compiled;
    after an edit of one module's docstring a fresh process loads the other from the
    cache and compiles the edited one again."""
    import json
    import subprocess
    import sys

    pkg = tmp_path / "src" / "adaptid"
    shutil.copytree(_cache._DIR.parent, pkg, ignore=shutil.ignore_patterns("__pycache__", "_aot"))
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    env = {**os.environ, "PYTHONPATH": str(tmp_path / "src"), "NUMBA_CACHE_DIR": str(cache),
           "ADAPTID_AOT": "0"}

    def run():
        out = subprocess.run([sys.executable, "-c", _COMPILE_TWO], env=env, cwd=tmp_path,
                             capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout.strip().splitlines()[-1])

    assert run() == {"sim": 0, "res": 0}  # both compiled
    assert run() == {"sim": 1, "res": 1}  # both from the cache
    sim = pkg / "_kernels" / "layers" / "_simulators.py"
    text = sim.read_text(encoding="utf-8")
    assert text.startswith('r"""')
    sim.write_text('r"""An edited docstring.\n\n' + text[4:], encoding="utf-8")
    assert run() == {"sim": 0, "res": 1}  # only the edited module's kernel compiles


def test_a_parallel_wrapper_is_stamped_with_the_run_it_wraps():
    """recursions/_parallel.py builds run_batched / run_segments for a run of another
    module: their stamp covers that module too, so an edit of it recompiles them."""
    from pathlib import Path

    import pytest

    from adaptid import _config
    from adaptid._kernels.recursions import _lms, _parallel

    if not _config.CACHE:
        pytest.skip("no cache folder: no locator")
    for wrapper in (_lms.lms_run_batched, _lms.nlms_run_segments):
        loc = wrapper._cache._impl.locator
        assert Path(loc._kernel_file) == Path(_parallel.__file__).resolve()
        assert loc._sources == (str(Path(_lms.__file__).resolve()),)
        assert loc.get_source_stamp()[1] not in (_cache.module_stamp(loc._kernel_file),
                                                 _cache.module_stamp(loc._sources[0]))
