"""numba's cache of adaptid's kernels: one stamp for all kernel files, safe folders.

A kernel inlines pieces of other files (the Bierman stages of _bierman.py in
the streams of _rls.py, ...): numba alone would keep serving a stale compiled
kernel after such a piece changed (it stamps each function with its own
file only). adaptid._kernels._cache gives every kernel the hash of all the
kernel files, and refuses cache folders another user could write.
"""

import os
import shutil

import numpy as np

from adaptid._kernels import _cache


def test_kernels_use_the_adaptid_locator():
    import adaptid
    from adaptid._kernels import _rls

    adaptid.RLS(3).run(np.eye(3), np.ones(3))
    impl = _rls.rls_run._cache._impl
    assert isinstance(impl.locator, _cache._KernelsLocator)
    assert impl.locator.get_source_stamp() == ("adaptid-kernels", _cache.SOURCE_STAMP)


def test_the_stamp_changes_with_any_kernel_file(tmp_path, monkeypatch):
    copy = tmp_path / "_kernels"
    shutil.copytree(_cache._DIR, copy, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(_cache._DIR.parent / "_config.py", tmp_path / "_config.py")
    monkeypatch.setattr(_cache, "_DIR", copy)
    before = _cache._source_stamp()
    assert before == _cache.SOURCE_STAMP  # the same files give the same stamp
    with open(copy / "_bierman.py", "a") as fh:  # an edit to an inlined piece only
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
