"""The Python blocks of docs/models/closed_loop.md run as written (one namespace)."""

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

PAGE = Path(__file__).resolve().parents[3] / "docs" / "models" / "closed_loop.md"


def test_closed_loop_page_runs():
    text = PAGE.read_text(encoding="utf-8")
    assert text.count("```") % 2 == 0, "an unclosed code fence"
    blocks = re.findall(r"^```python\n(.*?)^```", text, re.S | re.M)
    assert len(blocks) >= 5
    ns = {"__name__": "docs_closed_loop"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"closed_loop.md[block {i}]", "exec"), ns)
