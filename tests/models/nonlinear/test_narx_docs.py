"""docs/models/nonlinear.md runs as written: its Python blocks in order in one
namespace (as tests/test_docs.py does for the guide), then its C block compiled with
host gcc against the files its Python exported, and run: the free run it prints is
the model's ``simulate`` of the same inputs."""

import re
import shutil
import subprocess
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

PAGE = Path(__file__).resolve().parents[3] / "docs" / "models" / "nonlinear.md"


def _blocks(lang):
    text = PAGE.read_text(encoding="utf-8")
    assert text.count("```") % 2 == 0, "a code fence is not closed"
    return re.findall(rf"^```{lang}\n(.*?)^```", text, re.S | re.M)


def test_page_runs_and_its_c_example_compiles(tmp_path):
    ns = {"__name__": "docs_nonlinear"}
    for i, code in enumerate(_blocks("python")):
        exec(compile(code, f"nonlinear.md[block {i}]", "exec"), ns)
    import matplotlib.pyplot as plt
    plt.close("all")
    (c_main,) = _blocks("c")
    folder = Path(ns["folder"])
    (folder / "main.c").write_text(c_main)
    gcc = shutil.which("gcc")
    if gcc is None:  # a failure, not a skip: .ci/run installs gcc
        pytest.fail("gcc not found")
    exe = tmp_path / "main"
    res = subprocess.run([gcc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2",
                          "-I", str(folder), str(folder / "main.c"), str(folder / "plant.c"),
                          "-o", str(exe)], capture_output=True, text=True)
    assert res.returncode == 0 and res.stderr == "", res.stderr
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    m = ns["m"]
    want = m.simulate(np.tile([0.5, -0.2], (5, 1)), y0=np.full(5, 0.3))
    np.testing.assert_allclose([float(v) for v in out.split()], want, rtol=1e-5)
    shutil.rmtree(folder)
