import os

# pytest-xdist runs one worker per core: one BLAS thread per worker, so that
# the workers' OpenBLAS pools do not oversubscribe the cores (set before numpy
# loads OpenBLAS; an explicit setting in the environment wins).
for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

# Long-running soak tests are opt-in: `pytest -m soak`. CI runs shortened versions.
SOAK = os.environ.get("ADAPTID_SOAK") == "1"


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)


def pytest_collection_modifyitems(config, items):
    markexpr = config.getoption("-m") or ""
    if "soak" in markexpr or SOAK:
        return
    skip = pytest.mark.skip(reason="soak test: run with `pytest -m soak` (a shortened version runs in CI)")
    for item in items:
        if "soak" in item.keywords:
            item.add_marker(skip)
