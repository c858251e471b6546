"""The report's constancy section (issue 17, point 7): it shows CUSUM, CUSUM
of squares and the F statistics with the dated break, and says "no evidence
of change" only when every test agrees.

The issue's case: 5000 samples, x1's coefficient jumps from 1.0 to 1.5 half
way through; the recursive CUSUM alone (the old report) said "no evidence of
change". Oracles: the data's known break, and adaptid.diagnostics' tests
(checked against R strucchange in tests/diagnostics/test_strucchange_r.py).
"""

import re

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptid import diagnostics
from adaptid.cli._app import app

N = 5000


def _table(tmp_path, jump, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((N, 3))
    b1 = np.where(np.arange(N) < N // 2, 1.0, 1.5 if jump else 1.0)
    y = b1 * X[:, 0] + 0.5 * X[:, 1] - 0.3 * X[:, 2] + 0.1 * rng.standard_normal(N)
    path = tmp_path / ("jump.csv" if jump else "steady.csv")
    pd.DataFrame({"y": y, "x1": X[:, 0], "x2": X[:, 1], "x3": X[:, 2]}).to_csv(path, index=False)
    return path, X, y


def _report(tmp_path, path):
    out = tmp_path / ("rep_" + path.stem)
    r = CliRunner().invoke(app, ["fit", str(path), "--y", "y", "--phi", "x1,x2,x3",
                                 "--method", "window", "--window", "200", "--out", str(out),
                                 "--quiet"])
    assert r.exit_code == 0, r.output
    html = (out / "index.html").read_text(encoding="utf-8")
    assert (out / "cusum.png").stat().st_size > 10_000
    return html


def test_a_coefficient_jump_is_reported_and_dated(tmp_path):
    path, X, y = _table(tmp_path, jump=True)
    html = _report(tmp_path, path)
    assert "no evidence of change" not in html
    m = re.search(r"parameters not constant: rejected by ([^<]*?) at 5 %; break\(s\) dated "
                  r"after sample\(s\) ([\d, ]+)", html)
    assert m, html[html.find("Parameter constancy"):][:800]
    assert "supF" in m.group(1)
    dates = [int(v) for v in m.group(2).split(",")]
    assert any(abs(d - (N // 2 - 1)) <= 25 for d in dates)
    # the recursive CUSUM alone is blind to it: what the old report showed
    assert not diagnostics.cusum(diagnostics.recursive_residuals(X, y)).crossed


def test_steady_data_say_no_evidence_only_when_all_tests_agree(tmp_path):
    path, X, y = _table(tmp_path, jump=False, seed=1)
    assert diagnostics.change_tests(X, y).no_change  # this draw: no test rejects
    html = _report(tmp_path, path)
    assert "no evidence of change (CUSUM, CUSUM of squares, supF, RE and Nyblom–Hansen agree)" \
        in html
