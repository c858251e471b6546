"""Time of one ``update`` call from Python, per algorithm (n = 4).

``update`` is a run of length 1 through the compiled ``run`` of each algorithm
(one signature for both), or for RLS's fast forms a step through the narrow entry
of ``adaptid._kernels.recursions._step`` when it is compiled (this script compiles it with
``compile_update()``; the "RLS(4) via run" row forces the run entry); what is timed here is that call with its Python
checks and, for the sliding window, the check of the pivots the window's run
makes once per run. Best of ``--rounds`` rounds of ``--calls`` calls each;
compile time excluded (100 calls first); the cases interleaved round by round.

    python benchmarks/bench_update.py [--rounds 7] [--calls 20000]

Run it with another tree's ``src`` first on PYTHONPATH for an A/B comparison.
"""

import argparse
import time

import numpy as np

import adaptid

def _via_run(est):
    """``est`` with its narrow step entry never looked up: every update a run of length 1."""
    est._find_step = lambda S: setattr(est._step, "step_S", S)
    return est


def _compiled(est):
    est.compile_update()
    return est


CASES = {
    "RLS(4, forgetting=0.99)": lambda: _compiled(adaptid.RLS(4, forgetting=0.99)),
    "RLS(4, forgetting=0.99) via run's entry": lambda: _via_run(adaptid.RLS(4, forgetting=0.99)),
    "RLS(4, form='covariance')": lambda: _compiled(adaptid.RLS(4, forgetting=0.99,
                                                               form="covariance")),
    "KalmanRLS(4)": lambda: adaptid.KalmanRLS(4, process_cov=1e-4),
    "SlidingWindowRLS(4, 50)": lambda: adaptid.SlidingWindowRLS(4, 50),
    "SlidingWindowRLS(4, 50, P0='diffuse')": lambda: adaptid.SlidingWindowRLS(4, 50, P0="diffuse"),
    "LMS(4)": lambda: adaptid.LMS(4, step=0.01),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--calls", type=int, default=20_000)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    X = rng.standard_normal((args.calls, 4))
    y = X @ [1.0, -0.5, 0.25, 2.0] + 0.1 * rng.standard_normal(args.calls)
    print(f"# adaptid {adaptid.__version__} from {adaptid.__file__}")
    ests = {name: make() for name, make in CASES.items()}
    for est in ests.values():
        for k in range(100):
            est.update(X[k], float(y[k]))
    best = dict.fromkeys(ests, np.inf)
    for _ in range(args.rounds):  # the cases interleaved, round by round
        for name, est in ests.items():
            upd = est.update
            t = time.perf_counter()
            for k in range(args.calls):
                upd(X[k], float(y[k]))
            best[name] = min(best[name], (time.perf_counter() - t) / args.calls)
    for name, est in ests.items():
        how = "step entry" if est._step.step_ep is not None else "run's entry"
        print(f"{name:42s} {best[name] * 1e6:6.2f} us per update  ({how})")

if __name__ == "__main__":
    main()
