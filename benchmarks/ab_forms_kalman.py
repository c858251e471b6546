"""Same-run A/B of the Kalman filter and of RLS's square-root / U-D forms at larger n.

Run it in this tree and with ``PYTHONPATH=<old checkout>/src``, alternating
(one JSON line per run: million updates per second, best of 5, ``store=False``)::

    for i in 1 2; do python benchmarks/ab_forms_kalman.py; \
        PYTHONPATH=/path/to/old/src python benchmarks/ab_forms_kalman.py; done

Keys: ``kalman<n>``; ``<form><n>`` for ``RLS(n, forgetting=0.99, form=<form>)``
(``auto<n>`` is what the default form runs at that n).
"""
import json
import time

import numpy as np

import adaptid


def rate(make, n, N):
    rng = np.random.default_rng(0)
    Phi = rng.standard_normal((N, n))
    y = Phi @ np.ones(n) + 0.1 * rng.standard_normal(N)
    make().run(Phi[:10], y[:10])  # compile / load outside the timing
    best = np.inf
    for _ in range(5):
        est = make()
        t = time.perf_counter()
        est.run(Phi, y, store=False)
        best = min(best, time.perf_counter() - t)
    return N / best / 1e6


out = {}
for n in (2, 4, 8, 16):
    out[f"kalman{n}"] = rate(lambda: adaptid.KalmanRLS(n, process_cov=1e-4, noise_var=0.1), n,
                             400_000 // max(1, n // 4))
for n, forms in ((24, ("sqrt",)), (32, ("sqrt",)), (64, ("sqrt",)), (65, ("sqrt", "ud", "auto")),
                 (100, ("sqrt", "ud", "auto"))):
    for form in forms:
        out[f"{form}{n}"] = rate(lambda: adaptid.RLS(n, forgetting=0.99, form=form), n,
                                 max(5_000, 2_000_000 // (n * n)))
print(json.dumps({k: round(v, 3) for k, v in out.items()}))
