"""The fleet in a read-only install with an unwritable HOME (issue 32, point 9: the
stale line of docs/reliability.md said importing ``adaptid.fleet`` raised numba's
"no locator available" there).

The install is a copy of the package made read-only, with a file where every
``__pycache__`` folder would go, and HOME a file; the control (numba alone cannot
cache there) is ``tests/test_environment.py::test_read_only_install_with_unwritable_home_works``.
The oracle of the estimates is the same identify in this process.
"""

import os
import shutil
import stat
import textwrap

import numpy as np

from adaptid import fleet
from adaptid.datasets import fleet as make_fleet

from ..test_environment import SRC, _env, _run

PHI = ["i", "di_dt", "omega", "sign_i"]

RUN_FLEET = textwrap.dedent("""
    import warnings, numpy as np
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        from adaptid import fleet
        from adaptid.datasets import fleet as make_fleet
        df = make_fleet(n_devices=4, n_samples=150, seed=1)
        res = fleet.identify(df, group="device", time="time", y="v",
                             phi=["i", "di_dt", "omega", "sign_i"], npartitions=2)
    from adaptid import _config
    kinds = [type(w.message).__name__ for w in caught]
    print("THETA", res[["i", "di_dt", "omega", "sign_i"]].to_numpy().tobytes().hex())
    print("CACHE", _config.CACHE)
    print("WARNINGS", kinds.count("CompilationCacheWarning"))
""")


def test_fleet_in_a_read_only_install_with_unwritable_home(tmp_path):
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
        out, _ = _run(RUN_FLEET, env, tmp_path)
    finally:
        for p in [install, *install.rglob("*")]:
            os.chmod(p, stat.S_IMODE(p.stat().st_mode) | 0o200)
    assert out["CACHE"] == "False"
    assert int(out["WARNINGS"]) >= 1  # adaptid says it does not cache
    df = make_fleet(n_devices=4, n_samples=150, seed=1)
    ref = fleet.identify(df, group="device", time="time", y="v", phi=PHI, npartitions=2)
    got = np.frombuffer(bytes.fromhex(out["THETA"])).reshape(-1, len(PHI))
    np.testing.assert_array_equal(got, ref[PHI].to_numpy())
