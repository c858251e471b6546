"""Write the format-2 state files of this folder with the adaptid of commit f66d1cc.

Run (from the repository root)::

    git archive f66d1cc src | tar -x -C /tmp/f66
    PYTHONPATH=/tmp/f66/src python tests/data/state_format2/make_fixtures.py

The data are seeded and re-created by tests/estimators/test_state_files_hostile.py, which
checks that the current code loads these files and that the loaded estimators
continue exactly like estimators run by the current code on the same data.
"""

from pathlib import Path

import numpy as np

import adaptid
from adaptid.constrained import ConstrainedRLS

HERE = Path(__file__).resolve().parent


def data(seed, N, n):
    rng = np.random.default_rng(seed)
    Phi = rng.standard_normal((N, n))
    y = Phi @ np.arange(1.0, n + 1) + 0.1 * rng.standard_normal(N)
    return Phi, y


def main():
    print("adaptid", adaptid.__file__)
    Phi, y = data(1, 40, 3)
    est = adaptid.RLS(3, forgetting=0.98, P0=100.0)
    est.run(Phi, y)
    est.save_state(HERE / "rls.npz")
    est = adaptid.SlidingWindowRLS(3, 9, forgetting=0.995)
    est.run(Phi, y)
    est.save_state(HERE / "window.npz")
    est = adaptid.KalmanRLS(3, process_cov=np.diag([1e-3, 2e-3, 3e-4]), noise_var=0.3)
    est.run(Phi, y)
    est.save_state(HERE / "kalman.npz")
    Phi4, y4 = data(2, 30, 4)
    est = ConstrainedRLS(4, C=[[1.0, 1.0, 0.0, 0.0]], d=[3.0], forgetting=0.99)
    est.run(Phi4, y4)
    est.save_state(HERE / "constrained.npz")


if __name__ == "__main__":
    main()
