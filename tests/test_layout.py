"""tests/ mirrors src/adaptid/ (issue 31, point 7): one test package per package.

The tests of ``adaptid.<package>`` live in ``tests/<package>/`` (``adaptid._kernels``
in ``tests/kernels/``); tests of the top-level modules and cross-cutting ones
(architecture, docs, environment, ...) at ``tests/``. Every test folder is a
package, so two folders may hold test files of the same name.
"""

from pathlib import Path

TESTS = Path(__file__).resolve().parent
SRC = TESTS.parent / "src" / "adaptid"


def _packages(root):
    return {p.name.lstrip("_") for p in root.iterdir() if (p / "__init__.py").is_file()}


def test_every_package_has_its_test_folder_and_no_other():
    assert _packages(TESTS) == _packages(SRC)


def test_every_folder_with_tests_is_a_package():
    for path in TESTS.rglob("test_*.py"):
        assert (path.parent / "__init__.py").is_file(), path.parent
