import os

# pytest-xdist runs one worker per core: one BLAS thread per worker, so that
# the workers' OpenBLAS pools do not oversubscribe the cores (set before numpy
# loads OpenBLAS; an explicit setting in the environment wins).
for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

# The suite already runs one worker per core: `adaptid demo`'s helper process
# that compiles kernels on the second core (adaptid.cli._prewarm) would only
# compete with the other worker. tests/cli/test_cli_prewarm.py switches it on.
os.environ.setdefault("ADAPTID_PREWARM", "0")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

# Long-running soak tests are opt-in: `pytest -m soak`. CI runs shortened versions.
SOAK = os.environ.get("ADAPTID_SOAK") == "1"


# The cold suite is compile-bound: numba compiles each kernel once per model
# size n for which it is specialised (n <= 16, the Python default). The files
# below test the specialisation itself (the core recursions, the kernels'
# stack scratch and literal sizes, the SIMD streams, the forms (whose state
# round trips run there), the generated C, the benchmarks, the kernel cache)
# and run on those specialised kernels; every other file (state files,
# fuzzing, diffuse starts, statistics, segments, strategies, models,
# diagnostics, CLI, fleet, scikit-learn, ...) runs on the size-generic
# kernels, one compilation for every n. Both give bit for bit the same results:
# tests/kernels/test_kernels_scratch.py checks it for every algorithm, form, diffuse
# start and the statistics;
# tests/test_fit_stats_agree.py between the shell and Python.
# ADAPTID_MAX_SPECIALISED_N in the environment applies to every file. The names are
# the files' base names, whichever folder of tests/ holds them.
SPECIALISED_FILES = {
    "test_recursive", "test_kernels_scratch", "test_codegen",
    "test_benchmarks_smoke", "test_kernel_cache", "test_environment", "test_rls_forms",
    "test_soa",
}


@pytest.fixture(autouse=True, scope="module")
def _kernel_sizes(request):
    from adaptid.estimators import size_generic_kernels

    if request.module.__name__.rsplit(".", 1)[-1] in SPECIALISED_FILES:
        yield
        return
    with size_generic_kernels():
        yield


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
