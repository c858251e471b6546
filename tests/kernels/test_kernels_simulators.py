"""The compiled DC-motor simulator (adaptid._kernels.layers._simulators) against its own Python source.

Oracle: the same kernel source run by the Python interpreter
(``NUMBA_DISABLE_JIT=1`` in a subprocess), which evaluates every IEEE
operation as written. The compiled kernel must give the same bits: it is
compiled without FMA contraction, so a data set of ``adaptid.datasets`` is
the same on every machine for a given seed (with ``fastmath={"contract"}``
the states differ by up to ~1e-13 on a CPU with FMA). Tolerance: none.
"""

import os
import subprocess
import sys

import numpy as np

from adaptid._kernels.layers._simulators import DC_MOTOR_PARAMETER_ORDER, simulate_dc_motor
from adaptid.datasets._dc_motor import MOTOR_PARAMETERS

_SCRIPT = r"""
import sys
import numpy as np
from adaptid._kernels.layers._simulators import simulate_dc_motor
v, p, x0 = (np.array(eval(a)) for a in sys.argv[1:4])
states = np.empty((v.shape[0], 4))
simulate_dc_motor(v, 1e-3, 20, v.shape[0] // 2, p, x0, states)
sys.stdout.write(states.tobytes().hex())
"""


def _inputs():
    # a voltage that reverses the motor (friction reversals and a stuck phase)
    # and the load step at the midpoint: every branch of the kernel runs
    k = np.arange(1200)
    v = np.where(k < 20, 0.0, 6.0 * np.sign(np.sin(2 * np.pi * k / 150.0)))
    # then the bridge off: friction and back-EMF stop the rotor, and it sticks
    # (|Kt·i − τ₀| → τ₀ = 2 mN·m < τ_c = 8 mN·m)
    v[700:] = 0.0
    prm = {**MOTOR_PARAMETERS, "Kt": MOTOR_PARAMETERS["Ke"]}
    p = np.array([prm[name] for name in DC_MOTOR_PARAMETER_ORDER])
    x0 = np.array([0.0, 0.0, prm["T_amb"], 0.0])
    return v, p, x0


def test_compiled_equals_interpreted_bit_for_bit():
    v, p, x0 = _inputs()
    states = np.empty((v.shape[0], 4))
    simulate_dc_motor(v, 1e-3, 20, v.shape[0] // 2, p, x0, states)
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
    out = subprocess.run([sys.executable, "-c", _SCRIPT, repr(v.tolist()), repr(p.tolist()),
                          repr(x0.tolist())], env=env, capture_output=True, text=True,
                         check=True, timeout=300)
    ref = np.frombuffer(bytes.fromhex(out.stdout), dtype=float).reshape(states.shape)
    # the run does what it is meant to exercise: both directions and a stuck phase
    assert states[:, 1].max() > 10.0 and states[:, 1].min() < -10.0
    assert np.all(states[-50:, 1] == 0.0)
    np.testing.assert_array_equal(states, ref)
