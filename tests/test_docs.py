"""The Python code blocks of the documentation run as written.

Each page's ```python blocks are executed in order in one namespace, so a
page is one script; a block that raises fails the test with the page and the
block's first line. The blocks carry their own asserts against closed forms
and numpy.
"""

import re
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
_BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
# the pages of the model families (docs/models/) that hold python blocks
_MODEL_PAGES = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs" / "models").glob("*.md")
                      if _BLOCK.search(p.read_text(encoding="utf-8")))
PAGES = ["README.md", "docs/guide.md", "docs/migrating.md", *_MODEL_PAGES]


def _blocks(page):
    return _BLOCK.findall((ROOT / page).read_text(encoding="utf-8"))


@pytest.mark.parametrize("page", PAGES)
def test_page_code_runs(page):
    blocks = _blocks(page)
    assert blocks, f"{page} has no python blocks"
    ns = {"__name__": f"docs_{Path(page).stem}"}
    for i, code in enumerate(blocks):
        try:
            exec(compile(code, f"{page}[block {i}]", "exec"), ns)
        except Exception as err:  # noqa: BLE001 - re-raised with the place
            first = code.strip().splitlines()[0]
            raise AssertionError(f"{page}, block {i} ({first!r}) failed: "
                                 f"{type(err).__name__}: {err}") from err
