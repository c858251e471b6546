"""Property-based fuzzing of adaptid.constrained's public functions.

Any argument may be replaced by junk — wrong shapes (including empty and
0-d), wrong dtypes (int, bool, float32, complex, strings, objects, ragged
lists), NaN and inf. The only acceptable failures are ValueError and
TypeError carrying a message.
"""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from adaptid import AdaptidWarning
from adaptid.constrained import (
    ConstrainedRLS,
    PiecewisePolynomial,
    constrained_lstsq,
    lq_control,
    lq_estimate,
    lq_estimate_cv,
    multi_objective_lstsq,
    open_loop,
    piecewise_polyfit,
)

FUZZ = settings(max_examples=60, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

values = st.one_of(st.floats(-10, 10), st.just(np.nan), st.just(np.inf), st.just(-np.inf))
shapes = hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4)
junk = st.one_of(
    hnp.arrays(np.float64, shapes, elements=values),
    hnp.arrays(st.sampled_from([np.int64, np.bool_, np.float32, np.complex128]), shapes),
    hnp.arrays(np.dtype("U2"), hnp.array_shapes(max_dims=2, max_side=3)),
    st.none(),
    st.text(max_size=3),
    values,
    st.integers(-3, 6),
    st.lists(st.one_of(values, st.text(max_size=2)), max_size=3),
    st.lists(st.lists(values, max_size=3), max_size=3),        # often ragged
    st.builds(object),
)


def maybe(valid):
    """The valid value or, half of the time, junk."""
    return st.one_of(st.just(valid), junk)


def call_and_check(fn, *args, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            fn(*args, **kwargs)
        except (ValueError, TypeError) as err:
            assert str(err), f"{type(err).__name__} without a message"
    # numerical trouble is reported under adaptid's own warning classes only
    for w in caught:
        assert issubclass(w.category, AdaptidWarning), (w.category, str(w.message))


RNG = np.random.default_rng(0)
A5 = RNG.standard_normal((5, 3))
B5 = RNG.standard_normal(5)


@FUZZ
@given(st.fixed_dictionaries({
    "A": maybe(A5), "b": maybe(B5), "C": maybe(np.ones((1, 3))), "d": maybe(np.ones(1)),
    "G": maybe(np.eye(3)[:2]), "h": maybe(np.ones(2)), "lb": maybe(-1.0), "ub": maybe(2.0),
    "method": st.sampled_from(["auto", "qr", "kkt", "qp", "bogus", 3]),
}))
def test_fuzz_constrained_lstsq(kw):
    A, b = kw.pop("A"), kw.pop("b")
    C, d = kw.pop("C"), kw.pop("d")
    call_and_check(constrained_lstsq, A, b, C, d, **kw)


@FUZZ
@given(A=maybe(A5), b=maybe(B5), C=maybe(np.ones((1, 3))), d=maybe(np.ones(1)),
       method=st.sampled_from(["auto", "qr", "kkt"]))
def test_fuzz_equality_only(A, b, C, d, method):
    call_and_check(constrained_lstsq, A, b, C, d, method=method)


@FUZZ
@given(As=st.one_of(st.just([A5, np.eye(3)]), st.lists(junk, max_size=3), junk),
       bs=st.one_of(st.just([B5, np.zeros(3)]), st.lists(junk, max_size=3), junk),
       weights=maybe(np.array([1.0, 0.5])))
def test_fuzz_multi_objective(As, bs, weights):
    call_and_check(multi_objective_lstsq, As, bs, weights)


X40 = np.linspace(-1, 1, 40)


@FUZZ
@given(x=maybe(X40), y=maybe(X40**3), knots=maybe(np.array([-1.0, 0.0, 1.0])),
       degree=maybe(3), continuity=maybe(1))
def test_fuzz_piecewise_polyfit(x, y, knots, degree, continuity):
    call_and_check(piecewise_polyfit, x, y, knots, degree, continuity)


@FUZZ
@given(knots=maybe(np.array([0.0, 1.0])), coef=maybe(np.ones((1, 2))), at=maybe(0.5),
       k=maybe(1))
def test_fuzz_piecewise_polynomial(knots, coef, at, k):
    def use():
        p = PiecewisePolynomial(knots, coef)
        p(at)
        p.derivative(k)
    call_and_check(use)


A3 = np.array([[0.855, 1.161, 0.667], [0.015, 1.073, 0.053], [-0.084, 0.059, 1.022]])
B3 = np.array([-0.076, -0.139, 0.342])
C3 = np.array([0.218, -3.597, -1.683])


@FUZZ
@given(A=maybe(A3), B=maybe(B3), C=maybe(C3), x_init=maybe(np.ones(3)),
       x_des=maybe(np.zeros(3)), T=maybe(12), rho=maybe(0.2))
def test_fuzz_lq_control(A, B, C, x_init, x_des, T, rho):
    call_and_check(lq_control, A, B, C, x_init, x_des, T, rho)
    call_and_check(open_loop, A, C, x_init, T)


I2, Z2 = np.eye(2), np.zeros((2, 2))
ADI = np.block([[I2, I2], [Z2, I2]])
BDI = np.vstack([Z2, I2])
CDI = np.hstack([I2, Z2])
YDI = np.column_stack([np.linspace(0, 5, 12), np.sin(np.linspace(0, 5, 12))])


@FUZZ
@given(A=maybe(ADI), B=maybe(BDI), C=maybe(CDI), y=maybe(YDI), lam=maybe(10.0),
       lams=maybe([1.0, 10.0]), holdout=maybe(0.25), rng=maybe(0))
def test_fuzz_lq_estimate(A, B, C, y, lam, lams, holdout, rng):
    call_and_check(lq_estimate, A, B, C, y, lam)
    call_and_check(lq_estimate_cv, A, B, C, y, lams, holdout=holdout, rng=rng)


@FUZZ
@given(n=maybe(3), C=maybe(np.ones((1, 3))), d=maybe(np.ones(1)), P0=maybe(10.0),
       phi=maybe(np.ones(3)), y=maybe(0.5), Phi=maybe(np.ones((4, 3))), Y=maybe(np.ones(4)))
def test_fuzz_constrained_rls(n, C, d, P0, phi, y, Phi, Y):
    def use():
        est = ConstrainedRLS(n, C, d, P0=P0)
        est.update(phi, y)
        est.run(Phi, Y)
        est.predict(phi)
    call_and_check(use)


entries = st.one_of(st.sampled_from([0.0, 1.0, -1.0, 0.5]), st.floats(-5, 5),
                    st.just(np.nan))


@FUZZ
@given(data=st.data())
def test_fuzz_consistent_shapes_degenerate_values(data):
    # Shapes that fit together, values that are often degenerate (zeros,
    # repeated rows) or occasionally NaN: rank errors, infeasibility and
    # solver trouble must all surface as ValueError / TypeError.
    m, n = data.draw(st.integers(0, 6)), data.draw(st.integers(1, 4))
    p, q = data.draw(st.integers(0, 3)), data.draw(st.integers(0, 4))

    def arr(shape):
        return data.draw(hnp.arrays(np.float64, shape, elements=entries))
    kwargs = {}
    if q:
        kwargs.update(G=arr((q, n)), h=arr((q,)))
    if data.draw(st.booleans()):
        kwargs.update(lb=arr((n,)) - 2.0, ub=arr((n,)) + 2.0)
    call_and_check(constrained_lstsq, arr((m, n)), arr((m,)),
                   arr((p, n)) if p else None, arr((p,)) if p else None, **kwargs)


def test_fuzz_strategy_reaches_deep_code():
    # Guard against a fuzzer that only ever fails at the first check: the
    # valid defaults above must themselves succeed.
    constrained_lstsq(A5, B5, np.ones((1, 3)), np.ones(1), G=np.eye(3)[:2], h=np.ones(2),
                      lb=-1.0, ub=2.0)
    piecewise_polyfit(X40, X40**3, [-1.0, 0.0, 1.0], 3, 1)
    lq_control(A3, B3, C3, np.ones(3), np.zeros(3), 12, 0.2)
    lq_estimate_cv(ADI, BDI, CDI, YDI, [1.0, 10.0], holdout=0.25, rng=0)
    est = ConstrainedRLS(3, np.ones((1, 3)), np.ones(1), P0=10.0)
    est.update(np.ones(3), 0.5)
    with pytest.raises(ValueError):
        constrained_lstsq(A5, B5 * np.nan)
