"""adaptid's build backend: setuptools', plus the kernels compiled ahead of time.

``pip install`` (a wheel or an editable install) builds through this module. Before
setuptools builds, it runs ``python -m adaptid.cli._aot build`` on the source tree in
pip's build environment, which has numba, NumPy and SciPy (``[build-system]
requires`` in pyproject.toml): numba's cache files of the kernels that first calls
need go to ``src/adaptid/_kernels/_aot`` (package data, and the source folder of an
editable install). At run time they are used only when they match the installed
numba, the kernels' sources and the CPU (see ``adaptid/_kernels/toolchain/_installed.py``); otherwise numba
compiles as it would without them.

``ADAPTID_AOT_BUILD=0`` skips the step (the install is then as before: every kernel
compiled on first use). A failure of the step is reported and does not fail the
install.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import build_meta as _orig
from setuptools.build_meta import *  # noqa: F401,F403 - the other hooks as setuptools has them

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src"
OUT = SRC / "adaptid" / "_kernels" / "_aot"


def _precompile():
    if os.environ.get("ADAPTID_AOT_BUILD", "1") == "0":
        print("adaptid: ADAPTID_AOT_BUILD=0, kernels not compiled ahead of time", file=sys.stderr)
        shutil.rmtree(OUT, ignore_errors=True)
        return
    print("adaptid: compiling the kernels ahead of time (about 1-2 minutes on 2 cores; "
          "ADAPTID_AOT_BUILD=0 skips it)", file=sys.stderr, flush=True)
    try:
        code = (f"import sys; sys.path[:0] = {[str(SRC)] + [p for p in sys.path if p]!r}; "
                "from adaptid.cli._aot import main; sys.exit(main(['build', sys.argv[1]]))")
        proc = subprocess.run([sys.executable, "-c", code, str(OUT)], cwd=str(ROOT), timeout=1800, stdin=subprocess.DEVNULL,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        ok = proc.returncode == 0
        tail = proc.stdout.strip().splitlines()[-1:] if proc.stdout else []
    except (OSError, subprocess.TimeoutExpired) as err:
        ok, tail = False, [str(err)]
    if not ok:
        shutil.rmtree(OUT, ignore_errors=True)
        print("adaptid: ahead-of-time compilation failed; kernels will compile on first use "
              f"({' '.join(tail)})", file=sys.stderr)
    else:
        print(f"adaptid: {' '.join(tail)}", file=sys.stderr)


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    _precompile()
    return _orig.build_wheel(wheel_directory, config_settings, metadata_directory)


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    _precompile()
    return _orig.build_editable(wheel_directory, config_settings, metadata_directory)
