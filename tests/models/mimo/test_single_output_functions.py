"""Single-output functions refuse MIMO order matrices by name (after MIMO ARX landed).

``ARX`` with order matrices is a :class:`MIMOARX`; iv4, ivx and arx_regul
work on one output and must say so instead of failing inside.
"""

import numpy as np
import pytest

from adaptid.models import arx_regul, iv4, ivx


@pytest.fixture
def data():
    rng = np.random.default_rng(0)
    return rng.standard_normal(300), rng.standard_normal(300)


@pytest.mark.parametrize("call", [lambda d: iv4(d, np.ones((1, 1), int), 1, 1),
                                  lambda d: ivx(d, np.ones((1, 1), int), 1, 1, d[1]),
                                  lambda d: arx_regul(d, np.ones((1, 1), int), 2, 1)])
def test_order_matrices_refused(data, call):
    with pytest.raises(ValueError, match="na must be a scalar order"):
        call(data)
