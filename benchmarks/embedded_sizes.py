#!/usr/bin/env python
r"""Object size and stack of the generated C on a Cortex-M4F (docs/embedded.md's table).

For RLS (λ = 0.99), SlidingWindowRLS (M = 50) and KalmanRLS, n = 2, 4, 8, 16,
float32 and float64: ``adaptid.codegen.to_c`` from a fresh estimator, compiled
with

    arm-none-eabi-gcc -std=c99 -Wall -Wextra -Werror -pedantic
        -mcpu=cortex-m4 -mfpu=fpv4-sp-d16 -mfloat-abi=hard -Os -fstack-usage -c

then ``arm-none-eabi-size`` (Berkeley: text includes the read-only tables of
the initial state), ``sizeof(NAME_t)`` (the RAM the caller reserves, read
with ``arm-none-eabi-nm -S`` from an object that defines one) and the
``-fstack-usage`` frames: ``NAME_update``'s own frame and the largest frame
of a static helper it calls (their sum bounds the stack of one update; with
-Os most helpers are inlined into it).

Usage::

    python benchmarks/embedded_sizes.py > sizes.md
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-mcpu=cortex-m4",
         "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard", "-Os", "-fstack-usage", "-c"]


def tool(name):
    path = shutil.which(name)
    if path is None:
        sys.exit(f"embedded_sizes: {name} not found (apt-get install gcc-arm-none-eabi "
                 "libnewlib-arm-none-eabi)")
    return path


def measure(est, dtype, folder):
    from adaptid.codegen import to_c
    to_c(est, folder, name="est", dtype=dtype)
    cc = tool("arm-none-eabi-gcc")
    subprocess.run([cc, *FLAGS, "est.c", "-o", "est.o"], cwd=folder, check=True)
    size = subprocess.run([tool("arm-none-eabi-size"), "est.o"], cwd=folder, check=True,
                          capture_output=True, text=True).stdout.splitlines()[1].split()
    text, data, bss = (int(v) for v in size[:3])
    (folder / "sz.c").write_text('#include "est.h"\nchar est_state_size[sizeof(est_t)];\n')
    subprocess.run([cc, *[f for f in FLAGS if f != "-fstack-usage"], "sz.c", "-o", "sz.o"],
                   cwd=folder, check=True)
    nm = subprocess.run([tool("arm-none-eabi-nm"), "-S", "sz.o"], cwd=folder, check=True,
                        capture_output=True, text=True).stdout
    state = int(re.search(r"^\S+ (\S+) \w est_state_size$", nm, re.M).group(1), 16)
    frames = {}
    for line in (folder / "est.su").read_text().splitlines():
        where, nbytes, kind = line.split("\t")
        frames[where.rsplit(":", 1)[-1]] = (int(nbytes), kind)
    assert all(kind == "static" for _, kind in frames.values()), frames
    update = frames["est_update"][0]
    helpers = [v[0] for k, v in frames.items() if not k.startswith("est_")]
    return text, data, bss, state, update, max(helpers, default=0), frames["est_init"][0]


def main():
    import adaptid
    print("| estimator | dtype | n | text | data | bss | sizeof(NAME_t) | stack update | "
          "largest helper | stack init |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    root = Path(tempfile.mkdtemp(prefix="adaptid-sizes-"))
    makers = [("RLS λ=0.99", lambda n: adaptid.RLS(n, forgetting=0.99)),
              ("SlidingWindowRLS M=50", lambda n: adaptid.SlidingWindowRLS(n, 50)),
              ("KalmanRLS", lambda n: adaptid.KalmanRLS(n, process_cov=1e-4))]
    for label, make in makers:
        for dtype in ("float32", "float64"):
            for n in (2, 4, 8, 16):
                folder = root / f"{label[:3]}_{dtype}_{n}"
                folder.mkdir()
                t, d, b, st, up, hp, ini = measure(make(n), dtype, folder)
                print(f"| {label} | {dtype} | {n} | {t} | {d} | {b} | {st} | {up} | {hp} | {ini} |")
    shutil.rmtree(root, ignore_errors=True)
    gcc = subprocess.run([tool("arm-none-eabi-gcc"), "--version"], capture_output=True,
                         text=True).stdout.splitlines()[0]
    print(f"\n{gcc}; bytes; stack: -fstack-usage frames (all static).")


if __name__ == "__main__":
    main()
