"""FastRLS against SLICOT FD01AD's published example (tests/reference/slicot_fd01ad/).

FD01AD is the QR-decomposition fast least-squares lattice that
``method="lattice"`` implements; its example program prints, after 500
samples, the lattice's variables XF, YQ, EPSBCK (six decimals) and EFOR
(three digits). The data are generated as in TFD01AD.f. LAMBDA there is the
square root of the forgetting factor and DELTA the square root of the
initial forward energy, so λ = LAMBDA², δ = DELTA².
"""

import re
from pathlib import Path

import numpy as np
import pytest

from adaptid import RLS, FastRLS

REF = Path(__file__).resolve().parents[1] / "reference" / "slicot_fd01ad"
LAMBDA = 0.99  # PARAMETER ( LAMBDA = 0.99D0 ) in TFD01AD.f
IMAX = 500  # PARAMETER ( IMAX = 500 ) in TFD01AD.f


def example():
    L, delta, jp = (REF / "FD01AD.dat").read_text().splitlines()[1].split()
    L, delta = int(L), float(delta.replace("D", "e"))
    i = np.arange(1, IMAX + 1, dtype=float)
    x = np.sin(0.3 * i)                                  # XFCN
    y = 0.5 * np.sin(0.3 * i) + 2.0 * np.sin(0.3 * (i - 1))  # YFCN
    return L, delta, jp, x, y


def printed():
    rows, efor = {}, None
    for line in (REF / "FD01AD.res").read_text().splitlines():
        f = line.split()
        if len(f) == 4 and f[0].isdigit():
            rows[int(f[0])] = [float(v) for v in f[1:]]
        elif len(f) == 2 and f[0].isdigit():
            rows[int(f[0])] = [float(f[1])]
        elif "EFOR" in line:
            efor = float(re.sub("D", "e", line.split("=")[1]))
    return rows, efor


def test_lattice_reproduces_fd01ad_printed_results():
    L, delta, jp, x, y = example()
    assert jp == "B"  # both prediction and filtering parts
    est = FastRLS(L, forgetting=LAMBDA ** 2, delta=delta ** 2, method="lattice")
    est.run_fir(x, y)
    S = est.get_state()["state"]
    n = L  # layout of adaptid/_kernels/recursions/_fastrls.py (QR lattice)
    xf, eps, yq = S[n: 2 * n], S[2 * n: 3 * n + 1], S[5 * n + 1: 6 * n + 1]
    efor = S[7 * n + 1]
    rows, efor_ref = printed()
    assert sorted(rows) == list(range(1, L + 2))
    # F10.6: half a unit in the sixth decimal
    np.testing.assert_allclose(xf, [rows[i][0] for i in range(1, L + 1)], rtol=0, atol=5e-7)
    np.testing.assert_allclose(yq, [rows[i][1] for i in range(1, L + 1)], rtol=0, atol=5e-7)
    np.testing.assert_allclose(eps, [rows[i][-1] for i in range(1, L + 2)], rtol=0, atol=5e-7)
    # D10.3: 0.197D-02, half a unit in the third digit
    assert abs(efor - efor_ref) <= 0.5e-5


@pytest.mark.parametrize("method", ["ftf", "lattice"])
def test_fd01ad_example_errors_equal_rls_and_identify_the_filter(method):
    L, delta, _, x, y = example()
    lam = LAMBDA ** 2
    t = FastRLS(L, forgetting=lam, delta=delta ** 2, method=method).run_fir(x, y)
    Phi = np.column_stack([x, np.concatenate([[0.0], x[:-1]])])
    ref = RLS(L, forgetting=lam, P0=np.diag(lam ** np.arange(L)) / delta ** 2).run(Phi, y)
    # a sinusoid of two taps: well conditioned after a few samples; rounding only
    np.testing.assert_allclose(t.error, ref.error, rtol=0, atol=1e-10 * np.abs(ref.error).max())
    # the reference is y = 0.5 x(i) + 2 x(i-1) exactly (YFCN)
    np.testing.assert_allclose(t.theta[-1], [0.5, 2.0], atol=1e-9)
