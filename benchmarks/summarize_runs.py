#!/usr/bin/env python
"""Combine several ``bench_rls.py --json`` result files into Markdown tables.

Usage::

    python benchmarks/summarize_runs.py benchmarks/results/bench_rls_run*.json

Prints, for every contender, its median rate in each run and the median over
runs; for every target, the median same-round ratio in each run, the median
over runs and the verdict (met if the median over runs meets it).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np


def fmt_rate(r):
    for div, suf in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if r >= div:
            return f"{r / div:.3g} {suf}"
    return f"{r:.3g}"


def main(paths):
    runs = [json.loads(Path(p).read_text()) for p in paths]
    names = [Path(p).stem for p in paths]
    cases = runs[0]["cases"]
    print("| contender | group | N | " + " | ".join(names) + " | median of runs |")
    print("|---|---|---:|" + "---:|" * len(runs) + "---:|")
    for cid, c in cases.items():
        rates = [r["cases"][cid]["median_rate_per_s"] for r in runs if cid in r["cases"]]
        unit = "" if c["unit"] == "updates" else f" ({c['unit']}/s)"
        print(f"| {c['label']}{unit} | {c['group']} | {c['count']} | "
              + " | ".join(fmt_rate(x) for x in rates) + f" | **{fmt_rate(float(np.median(rates)))}** |")
    print()
    print("| ratio | target | " + " | ".join(names) + " | median of runs | verdict |")
    print("|---|---|" + "---:|" * len(runs) + "---:|---|")
    all_ratios = list(runs[0]["ratios"])
    for name in all_ratios:
        meds = [r["ratios"][name]["median"] for r in runs if name in r["ratios"]]
        m = float(np.median(meds))
        t = runs[0]["targets"].get(name)
        if t:
            op, thr = t["target"].split()
            ok = m >= float(thr) if op == ">=" else m < float(thr)
            verdict = "met" if ok else "**not met**"
            target = t["target"]
        else:
            verdict, target = "", ""
        print(f"| {name} | {target} | " + " | ".join(f"{x:.3g}" for x in meds)
              + f" | {m:.3g} | {verdict} |")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
