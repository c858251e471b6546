"""Property-based fuzzing (hypothesis) of the recursive estimators and lstsq.

Every public entry point — the constructors of RLS, SlidingWindowRLS and
KalmanRLS, their ``update``, ``run``, ``run_batched``, ``predict`` and
``run_segments``, and ``adaptid.lstsq`` — is called with arbitrary arguments: right and wrong
shapes, every dtype (ints, bool, float16/32, complex, object, strings),
NaN/inf, huge (1e300) and tiny (1e-300, subnormal) magnitudes, nested and
ragged lists, None. The contract (DESIGN.md, "Numerical rules"):

* the only exceptions are ValueError / TypeError carrying a message;
* numerical trouble is reported with adaptid's own warnings only
  (``AdaptidWarning`` subclasses), never a bare RuntimeWarning;
* a call that raises leaves the estimator exactly as it was (state vector
  bit for bit, ``n_updates``, ``n_skipped``, batch axis);
* complex input is rejected, never silently cast to real.

The fuzz also covers the bytes of state files (random mutations of a valid
file: only ``StateFileError``, bounded time and memory) and the arguments of
``adaptid fit`` (exit code 0 or 2, never 1 or a traceback).

Default runs are short (``max_examples=60``); ``ADAPTID_SOAK=1`` or
``pytest -m soak`` run many more examples.
"""

import os
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import adaptid
from adaptid import AdaptidWarning, KalmanRLS, RLS, SlidingWindowRLS

SOAK = os.environ.get("ADAPTID_SOAK") == "1"
_COMMON = dict(deadline=None, database=None, print_blob=True,
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                      HealthCheck.filter_too_much])
# the short default run is derandomized (the same examples every time, so CI is
# stable); the soak runs explore afresh each time
FUZZ = settings(max_examples=2000 if SOAK else 60, derandomize=not SOAK, **_COMMON)
FUZZ_SOAK = settings(max_examples=3000, **_COMMON)

# ---------------------------------------------------------------- strategies
WILD = [np.nan, np.inf, -np.inf, 1e300, -1e300, 1e-300, -1e-300, 5e-324, 0.0, -0.0,
        1.7e308, 1e150, 1e-150]
wild_floats = st.one_of(st.floats(-10, 10), st.sampled_from(WILD),
                        st.floats(allow_nan=True, allow_infinity=True))
shapes_any = hnp.array_shapes(min_dims=0, max_dims=4, min_side=0, max_side=4)
OTHER_DTYPES = [np.int64, np.int8, np.uint64, np.bool_, np.float32, np.float16,
                np.complex128, np.complex64]


def _arrays_of_shape(shape):
    """Arrays (or array-likes) of exactly this shape, of every kind of content."""
    finite = hnp.arrays(np.float64, shape, elements=st.floats(-10, 10))
    return st.one_of(
        finite,
        finite,
        hnp.arrays(np.float64, shape, elements=wild_floats),
        hnp.arrays(st.sampled_from(OTHER_DTYPES), shape),
        finite.map(lambda a: a.tolist()),                       # nested lists
        finite.map(lambda a: a.astype(object)),                 # object arrays of floats
        finite.map(lambda a: a.astype(np.complex128)),          # complex with zero imaginary part
        finite.map(lambda a: a.astype(str)),                    # numeric strings
        finite.map(lambda a: np.asfortranarray(a)),
        finite.map(lambda a: a[::-1] if a.ndim else a),         # negative strides
        finite.map(_readonly),
    )


def _readonly(a):
    a = a.copy()
    a.setflags(write=False)
    return a


junk = st.one_of(
    hnp.arrays(np.float64, shapes_any, elements=wild_floats),
    hnp.arrays(st.sampled_from(OTHER_DTYPES), shapes_any),
    hnp.arrays(np.dtype("U3"), hnp.array_shapes(max_dims=2, max_side=3)),
    st.none(),
    st.text(max_size=3),
    wild_floats,
    st.integers(-5, 10),
    st.booleans(),
    st.complex_numbers(max_magnitude=10),
    st.lists(st.one_of(wild_floats, st.text(max_size=2), st.none()), max_size=4),
    st.lists(st.lists(wild_floats, max_size=3), max_size=3),    # often ragged
    st.builds(object),
    st.just({"a": 1}),
    st.just(np.array([1.0, None], dtype=object)),
    st.just(np.array(["1.0", "x"])),
)


def like(shape):
    """Mostly something of the expected shape, sometimes anything at all."""
    return st.one_of(_arrays_of_shape(shape), _arrays_of_shape(shape), junk)


def scalar_like():
    return st.one_of(st.floats(0.01, 2.0), st.sampled_from([0.0, 1.0, 1, 0.5, -1.0]),
                     wild_floats, junk)


# ---------------------------------------------------------------- helpers
def snapshot(est):
    st_ = est.get_state()
    return (st_["state"].tobytes(), st_["state"].shape, st_["n_updates"], st_["n_skipped"],
            st_["batch"], est.theta.tobytes())


def call(fn, *args, est=None, **kwargs):
    """Call fn; check the exception and warning contract. Returns (ok, value)."""
    before = snapshot(est) if est is not None else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.simplefilter("ignore", AdaptidWarning)
        try:
            value = fn(*args, **kwargs)
            ok = True
        except (ValueError, TypeError) as err:
            assert str(err).strip(), f"{type(err).__name__} without a message"
            value, ok = err, False
    stray = [f"{w.category.__name__}: {w.message}" for w in caught]
    assert stray == [], f"warnings other than AdaptidWarning: {stray}"
    if est is not None and not ok:
        assert snapshot(est) == before, f"a failed {fn.__name__} changed the state ({value})"
    return ok, value


def _has_complex(x):
    if isinstance(x, complex):
        return True
    try:
        return np.asarray(x).dtype.kind == "c"
    except Exception:  # noqa: BLE001 - ragged and the like are not complex arrays
        return False


@st.composite
def estimators(draw, batched=None):
    """A valid estimator of any kind, fresh or after some data, maybe batched."""
    kind = draw(st.sampled_from(["RLS", "SlidingWindowRLS", "KalmanRLS"]))
    # every n is a compiled specialisation of every kernel family (adaptid._kernels.toolchain._dims):
    # n = 1 (the edge) and n = 3 keep the suite's cold compile time in bounds; the kernels'
    # dependence on n is tested against references at n = 1..18 elsewhere
    n = draw(st.sampled_from([1, 3]))
    p = draw(st.sampled_from([None, None, 1, 2]))
    kw = dict(nan_policy=draw(st.sampled_from(["raise", "skip"])))
    if p is not None:
        kw["n_outputs"] = p
    if draw(st.booleans()):
        kw["P0"] = draw(st.sampled_from([1e-3, 1.0, 1e4, 1e8]))
    if kind == "RLS":
        est = RLS(n, forgetting=draw(st.sampled_from([1.0, 0.99, 0.9])), **kw)
    elif kind == "SlidingWindowRLS":
        est = SlidingWindowRLS(n, draw(st.integers(n, n + 4)),
                               forgetting=draw(st.sampled_from([1.0, 0.98])), **kw)
    else:
        est = KalmanRLS(n, process_cov=draw(st.sampled_from([0.0, 1e-4, 1.0])),
                        noise_var=draw(st.sampled_from([1.0, 0.01])), **kw)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    N0 = draw(st.integers(0, 8))
    yshape = () if p is None else (p,)
    if batched is None:
        batched = draw(st.booleans())
    # data of any magnitude, so that θ itself may be huge or tiny
    scale = draw(st.sampled_from([1.0, 1.0, 1e3, 1e100, 1e300, 1e-300]))
    theta = rng.standard_normal((n,) + yshape) * scale

    def data(lead):
        Phi = rng.standard_normal(lead + (N0, n))
        return Phi, Phi @ theta + rng.standard_normal(lead + (N0,) + yshape)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdaptidWarning)
        if batched:
            est.run_batched(*data((draw(st.integers(1, 3)),)))
        elif N0:
            est.run(*data(()))
    return est


def _shapes(est, N, batched):
    n = est.n_params
    ys = () if est._single else (est.n_outputs,)
    lead = (est.batch_size,) if (batched and est.batch_size) else ()
    return n, ys, lead


# ----------------------------------------------------------------- estimators
def _op_update(est, data):
    n, ys, _ = _shapes(est, 1, False)
    phi = data.draw(like((n,)), label="phi")
    y = data.draw(st.one_of(like(ys), wild_floats), label="y")
    kw = {}
    if data.draw(st.booleans()):
        kw["weight"] = data.draw(scalar_like(), label="weight")
    if not isinstance(est, KalmanRLS) and data.draw(st.booleans()):
        kw["forgetting"] = data.draw(scalar_like(), label="forgetting")
    ok, val = call(est.update, phi, y, est=est, **kw)
    if ok:
        assert not (_has_complex(phi) or _has_complex(y)), "complex input silently accepted"
        if ys:
            assert isinstance(val, np.ndarray) and val.shape == ys
        else:
            assert isinstance(val, float)


def _op_run(est, data, batched):
    n, ys, lead = _shapes(est, None, batched)
    if batched and not lead:
        lead = (data.draw(st.integers(1, 3), label="B"),)
    N = data.draw(st.integers(0, 6), label="N")
    Phi = data.draw(like(lead + (N, n)), label="Phi")
    y = data.draw(like(lead + (N,) + ys), label="y")
    kw = {"store": data.draw(st.sampled_from([True, False]))}
    if data.draw(st.booleans()):
        kw["weights"] = data.draw(st.one_of(like(lead + (N,)), scalar_like()), label="weights")
    if not isinstance(est, KalmanRLS) and data.draw(st.booleans()):
        kw["forgetting"] = data.draw(st.one_of(like(lead + (N,)), scalar_like()),
                                     label="forgetting")
    fn = est.run_batched if batched else est.run
    ok, traj = call(fn, Phi, y, est=est, **kw)
    if ok:
        assert not any(_has_complex(v) for v in (Phi, y, *kw.values())), \
            "complex input silently accepted"
        Nr = np.shape(Phi)[-2]
        assert traj.error.shape[-1 - len(ys)] == Nr


def _op_predict(est, data):
    n, ys, lead = _shapes(est, None, True)
    shape = data.draw(st.sampled_from([lead + (n,), lead + (3, n), (n,), (2, n)]))
    phi = data.draw(like(shape), label="phi")
    ok, val = call(est.predict, phi, est=est)
    if ok:
        assert not _has_complex(phi), "complex input silently accepted"


def _op_run_segments(est, data):
    """run_segments (where the estimator has it) never changes the estimator."""
    n, ys, _ = _shapes(est, None, False)
    N = data.draw(st.integers(0, 6), label="N")
    Phi = data.draw(like((N, n)), label="Phi")
    y = data.draw(like((N,) + ys), label="y")
    cut = sorted(data.draw(st.lists(st.integers(0, N), max_size=3), label="cuts"))
    offsets = data.draw(st.one_of(st.just([0, *cut, N]), like((3,)),
                                  st.just([0, N + 1]), st.just([1, 0, N])), label="offsets")
    kw = {"store": data.draw(st.booleans())}
    if data.draw(st.booleans()):
        kw["weights"] = data.draw(st.one_of(like((N,)), scalar_like()), label="weights")
    before = snapshot(est)
    ok, _ = call(est.run_segments, Phi, y, offsets, est=est, **kw)
    assert snapshot(est) == before
    if ok:
        assert not any(_has_complex(v) for v in (Phi, y, offsets, *kw.values()))


def _fuzz_estimator(data):
    est = data.draw(estimators(), label="estimator")
    for _ in range(data.draw(st.integers(1, 4), label="n_ops")):
        op = data.draw(st.sampled_from(["update", "run", "run_batched", "predict",
                                        "run_segments"]), label="op")
        if op == "run_segments":
            if hasattr(est, "run_segments"):
                _op_run_segments(est, data)
        elif op == "update":
            _op_update(est, data)
        elif op == "run":
            _op_run(est, data, batched=False)
        elif op == "run_batched":
            _op_run(est, data, batched=True)
        else:
            _op_predict(est, data)
    # whatever happened, the estimator is still usable with good data, and its
    # state round trip still works
    call(est.predict, np.ones((2, est.n_params)) if est.batch_size is None
         else np.ones((est.batch_size, est.n_params)), est=est)
    type(est).from_state(est.get_state())


@FUZZ
@given(st.data())
def test_fuzz_estimator_methods(data):
    _fuzz_estimator(data)


@pytest.mark.soak
@FUZZ_SOAK
@given(st.data())
def test_fuzz_estimator_methods_soak(data):
    _fuzz_estimator(data)


# ---------------------------------------------------------------- constructors
def _ctor_args(data):
    n = data.draw(st.one_of(st.integers(-2, 6), st.integers(1, 4), junk,
                            st.sampled_from([np.int64(3), 2.0, True, "3"])), label="n_params")
    nn = n if type(n) is int and 1 <= n <= 6 else 2
    kw = {}
    if data.draw(st.booleans()):
        kw["P0"] = data.draw(st.one_of(
            st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(WILD),
            like((nn, nn)),
            hnp.arrays(np.float64, (nn, nn), elements=st.floats(-5, 5)),          # non-SPD mostly
            hnp.arrays(np.float64, (nn, nn), elements=st.floats(-5, 5)).map(lambda a: a + a.T),
            st.just(np.zeros((nn, nn))), st.just(np.eye(nn) * 1e300), st.just(np.eye(nn) * 1e-300),
            st.just(np.ones((nn, nn))),                                           # singular
            st.just(np.eye(nn) + 1e-3j)), label="P0")
    if data.draw(st.booleans()):
        kw["theta0"] = data.draw(st.one_of(like((nn,)), like((nn, 2)), like((nn + 1,))),
                                 label="theta0")
    if data.draw(st.booleans()):
        kw["nan_policy"] = data.draw(st.sampled_from(
            ["raise", "skip", "omit", "RAISE", "", None, 1, "propagate"]), label="nan_policy")
    if data.draw(st.booleans()):
        kw["n_outputs"] = data.draw(st.one_of(st.integers(-1, 3), junk), label="n_outputs")
    if data.draw(st.booleans()):
        kw["windup_threshold"] = data.draw(scalar_like(), label="windup_threshold")
    return n, nn, kw


def _forgetting_arg(data):
    fg = adaptid.forgetting
    return data.draw(st.one_of(
        st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(
            [1.0, 0.5, 1 + 1e-16, np.nextafter(1.0, 2.0), 0.0, -0.1, 1e-300, 1e300]),
        st.just(fg.Exponential(0.9)), st.just(fg.Directional()), st.just(fg.ConstantTrace()),
        st.just(fg.EFRA()), st.just(fg.Variable()),
        st.just({"strategy": "Directional", "lam": 0.9}), st.just({"strategy": "Nope"}),
        st.just({"strategy": "EFRA", "bogus": 1}),
        junk), label="forgetting")


def _fuzz_constructor(data):
    kind = data.draw(st.sampled_from(["RLS", "SlidingWindowRLS", "KalmanRLS"]), label="kind")
    n, nn, kw = _ctor_args(data)
    if kind == "RLS":
        if data.draw(st.booleans()):
            kw["forgetting"] = _forgetting_arg(data)
        if data.draw(st.booleans()):
            kw["P_max"] = data.draw(scalar_like(), label="P_max")
        ok, est = call(RLS, n, **kw)
    elif kind == "SlidingWindowRLS":
        window = data.draw(st.one_of(st.integers(-1, 12), junk), label="window")
        if data.draw(st.booleans()):
            kw["forgetting"] = _forgetting_arg(data)
        ok, est = call(SlidingWindowRLS, n, window, **kw)
    else:
        q = data.draw(st.one_of(scalar_like(), like((nn, nn)),
                                st.just(-np.eye(nn)), st.just(np.triu(np.ones((nn, nn))))),
                      label="process_cov")
        if data.draw(st.booleans()):
            kw["noise_var"] = data.draw(scalar_like(), label="noise_var")
        ok, est = call(KalmanRLS, n, process_cov=q, **kw)
    if not ok:
        return
    assert not any(_has_complex(v) for v in kw.values()), "complex argument silently accepted"
    # a constructed estimator is consistent and usable
    n = est.n_params
    assert np.isfinite(est.P).all()
    np.linalg.cholesky(est.P0)
    rng = np.random.default_rng(0)
    ys = () if est._single else (est.n_outputs,)
    for fn, args in ((est.update, (rng.standard_normal(n), rng.standard_normal(ys))),
                     (est.run, (rng.standard_normal((4, n)), rng.standard_normal((4,) + ys)))):
        ok, _ = call(fn, *args, est=est)
        assert ok, "a valid estimator refused valid data"
    back = type(est).from_state(est.get_state())
    assert snapshot(back) == snapshot(est)


@FUZZ
@given(st.data())
def test_fuzz_constructors(data):
    _fuzz_constructor(data)


@pytest.mark.soak
@FUZZ_SOAK
@given(st.data())
def test_fuzz_constructors_soak(data):
    _fuzz_constructor(data)


# --------------------------------------------------------------------- lstsq
def _fuzz_lstsq(data):
    N = data.draw(st.integers(0, 7), label="N")
    n = data.draw(st.integers(1, 4), label="n")
    p = data.draw(st.sampled_from([(), (), (2,)]), label="p")
    Phi = data.draw(like((N, n)), label="Phi")
    y = data.draw(like((N,) + p), label="y")
    kw = {}
    if data.draw(st.booleans()):
        kw["weights"] = data.draw(like((N,)), label="weights")
    if data.draw(st.booleans()):
        kw["ridge"] = data.draw(scalar_like(), label="ridge")
    ok, res = call(adaptid.lstsq, Phi, y, **kw)
    if not ok:
        return
    assert not any(_has_complex(v) for v in (Phi, y, *kw.values())), \
        "complex input silently accepted"
    # the derived statistics follow the same contract
    for attr in ("cov", "stderr", "sigma2", "residuals", "theta"):
        call(getattr, res, attr)
    call(res.conf_int, data.draw(st.one_of(st.sampled_from([0.05, 0.5]), scalar_like()),
                                 label="alpha"))


@FUZZ
@given(st.data())
def test_fuzz_lstsq(data):
    _fuzz_lstsq(data)


@pytest.mark.soak
@FUZZ_SOAK
@given(st.data())
def test_fuzz_lstsq_soak(data):
    _fuzz_lstsq(data)


# ------------------------------------------------------- deterministic corners
@pytest.mark.parametrize("make", [
    lambda: RLS(2), lambda: SlidingWindowRLS(2, 3), lambda: KalmanRLS(2, process_cov=1e-3)])
def test_complex_is_refused_not_cast(make):
    est = make()
    before = snapshot(est)
    for phi, y in (([1 + 0j, 2], 1.0), ([1.0, 2.0], 1 + 0j), (np.ones(2, complex), 2.0)):
        with pytest.raises((TypeError, ValueError), match="complex"):
            est.update(phi, y)
    with pytest.raises((TypeError, ValueError), match="complex"):
        est.run(np.ones((3, 2), complex), np.ones(3))
    with pytest.raises((TypeError, ValueError), match="complex"):
        est.run_batched(np.ones((1, 3, 2)), np.ones((1, 3), complex))
    with pytest.raises((TypeError, ValueError), match="complex"):
        est.predict(np.ones(2, complex))
    assert snapshot(est) == before
    with pytest.raises((TypeError, ValueError), match="complex"):
        adaptid.lstsq(np.eye(2, dtype=complex), np.ones(2))
    with pytest.raises((TypeError, ValueError), match="complex"):
        type(est)(2, P0=np.eye(2) * (1 + 0j), **(
            {"process_cov": 0.0} if isinstance(est, KalmanRLS) else
            {"window": 3} if isinstance(est, SlidingWindowRLS) else {}))


# ------------------------------------------ regressions found by fuzzing
# Each is the shrunk example hypothesis reported, written out so that it
# runs every time.
def _no_bare_warnings(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", AdaptidWarning)
        try:
            return fn(*args, **kwargs)
        except (ValueError, TypeError) as err:
            assert str(err)
            return err


def test_bug_predict_overflow_is_a_bare_runtime_warning():
    """Found by fuzzing (fixed in e75ed3f): predict: `out = phi @ theta`
    (src/adaptid/_estimators.py, _RecursiveEstimator.predict) overflows for phi =
    [1.7e308, 1.7e308] with |theta| > 1 and emits a bare 'RuntimeWarning: overflow
    encountered in matmul' (should be silent inf, an AdaptidWarning or a ValueError)
    """
    est = RLS(2, P0=1e8)
    Phi = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    est.run(Phi, Phi @ [3.0, 4.0])
    _no_bare_warnings(est.predict, [1.7e308, 1.7e308])


def test_bug_lstsq_cov_overflow_is_a_bare_runtime_warning():
    """Found by fuzzing (fixed in e75ed3f): lstsq(Phi=[[4.1e-221]], y=[0.]).cov:
    LSResult.unscaled_cov computes `Ri @ Ri.T` (src/adaptid/_lstsq.py) with Ri =
    2.4e220, which overflows with a bare 'RuntimeWarning: overflow encountered in
    matmul'
    """
    res = adaptid.lstsq(np.array([[4.10114682e-221]]), np.array([0.0]))
    _no_bare_warnings(getattr, res, "cov")


def test_bug_huge_P0_matrix_overflows_in_symmetrisation():
    """Found by fuzzing (fixed in e75ed3f): check_spd (src/adaptid/_validation.py)
    symmetrises with `M = 0.5 * (M + M.T)`, which overflows for entries > 8.99e307:
    RLS(2, P0=1.7e308 * eye(2)) is accepted with P0 = inf (a bare RuntimeWarning
    'overflow encountered in add') and P = NaN; it should keep P0 exact (0.5*M +
    0.5*M.T) or raise ValueError
    """
    out = _no_bare_warnings(RLS, 2, P0=np.eye(2) * 1.7e308)
    if isinstance(out, RLS):
        assert np.isfinite(out.P0).all() and np.isfinite(out.P).all()


def test_bug_huge_process_cov_overflows_in_symmetrisation():
    """Found by fuzzing (fixed in e75ed3f): KalmanRLS.__init__ (src/adaptid/_estimators.py)
    checks symmetry with `Q - Q.T` and symmetrises with `Q = 0.5 * (Q + Q.T)`:
    process_cov=[[9e307]] (fuzz: [[8.98846567e+307]]) overflows (bare 'RuntimeWarning:
    overflow encountered in add') and is stored as inf
    """
    out = _no_bare_warnings(KalmanRLS, 1, process_cov=np.array([[9e307]]))
    if isinstance(out, KalmanRLS):
        assert np.isfinite(out.process_cov).all()


def test_bug_lstsq_residual_square_overflows():
    """Found by fuzzing (fixed in e75ed3f): lstsq(Phi=[[0.]], y=[1e300], ridge=1.0): `wr2 =
    resid ** 2` (src/adaptid/_lstsq.py, lstsq) overflows for finite residuals > 1.3e154
    with a bare 'RuntimeWarning: overflow encountered in square' and sigma2 = inf (scale
    the residuals before squaring, or report with an AdaptidWarning)
    """
    _no_bare_warnings(adaptid.lstsq, np.array([[0.0]]), np.array([1e300]), ridge=1.0)


def test_bug_lstsq_cov_of_tiny_design_is_nan_with_bare_warning():
    """Found by fuzzing (fixed in e75ed3f): lstsq(Phi=[[1e-300], [1e-300]], y=[0, 0]):
    LSResult.unscaled_cov overflows to inf (`Ri @ Ri.T`), then LSResult.cov `s2 *
    self.unscaled_cov` and LSResult.stderr `d * s` compute 0 * inf with a bare
    'RuntimeWarning: invalid value encountered in multiply' and return NaN
    (src/adaptid/_lstsq.py)
    """
    res = _no_bare_warnings(adaptid.lstsq, np.array([[1e-300], [1e-300]]), np.array([0.0, 0.0]))
    _no_bare_warnings(getattr, res, "unscaled_cov")
    assert np.array_equal(_no_bare_warnings(getattr, res, "stderr"), [0.0])  # σ̂ = 0
    assert np.array_equal(_no_bare_warnings(getattr, res, "cov"), [[0.0]])


def test_bug_lstsq_subnormal_design_returns_infinite_theta():
    """Found by fuzzing (fixed in e75ed3f): lstsq(Phi=[[2.22507386e-313], [0.]], y=[1.,
    1.]) passes the rank test (tolerance relative to max|R_ii|) but theta = 1/2.2e-313
    overflows to inf in solve_triangular; then `resid = Y2 - Phi @ theta`
    (src/adaptid/_lstsq.py) gives a bare 'RuntimeWarning: invalid value encountered in
    matmul' and a result with theta = inf, residuals NaN is returned silently (should
    raise ValueError, or at least warn with an AdaptidWarning)
    """
    res = _no_bare_warnings(adaptid.lstsq, np.array([[2.22507386e-313], [0.0]]),
                            np.array([1.0, 1.0]))
    if not isinstance(res, Exception):
        assert np.isfinite(res.theta).all() and np.isfinite(res.residuals).all()


def test_bug_lstsq_weighted_y_and_residual_sum_overflow():
    """Found by fuzzing (fixed after 1f54957): lstsq(Phi=[[0.]], y=[1.7e308],
    weights=[2.]) overflowed in sqrt(w)·y ('overflow encountered in multiply') and a
    sum of huge squared residuals in `wr2.sum` ('overflow encountered in reduce')."""
    err = _no_bare_warnings(adaptid.lstsq, np.array([[0.0]]), np.array([1.7e308]),
                            weights=np.array([2.0]))
    assert isinstance(err, ValueError) and "weights" in str(err)
    res = _no_bare_warnings(adaptid.lstsq, np.array([[1.0], [1.0], [1.0]]),
                            np.array([1.7e308, -1.7e308, 1.7e308]))
    assert res.sigma2 == np.inf


def test_bug_lstsq_cov_with_infinite_sigma2():
    """Found by fuzzing (fixed after 1f54957): with σ̂² = inf (residuals > 1e154),
    LSResult.cov computed inf·0 for the zero entries of R⁻¹ with a bare 'invalid value
    encountered in multiply'."""
    res = _no_bare_warnings(adaptid.lstsq, np.array([[0.0, 1.0], [1.0, 0.0], [1.0, 1.0]]),
                            np.full(3, 1e300))
    assert res.sigma2 == np.inf
    _no_bare_warnings(getattr, res, "cov")
    _no_bare_warnings(res.conf_int)


# ------------------------------------------------------ state files: the bytes
# A valid file of each kind is mutated at random (bytes overwritten, inserted,
# deleted, ranges duplicated, the file truncated). The contract (issue 14): the
# loader raises StateFileError only, or returns exactly the saved estimator (a
# mutation of the zip's bookkeeping it does not read), and its time and memory
# stay bounded (tracemalloc sees NumPy's and zlib's allocations).
_STATE_FILES = {}


def _state_file_bytes(kind):
    if kind not in _STATE_FILES:
        import tempfile
        rng = np.random.default_rng(11)
        Phi = rng.standard_normal((20, 3))
        est = {"RLS": lambda: RLS(3, forgetting=0.98),
               "SlidingWindowRLS": lambda: SlidingWindowRLS(3, 6),
               "KalmanRLS": lambda: KalmanRLS(3, process_cov=1e-3)}[kind]()
        est.run(Phi, Phi @ [1.0, 2.0, 3.0])
        with tempfile.TemporaryDirectory() as folder:
            est.save_state(os.path.join(folder, "s.npz"))
            with open(os.path.join(folder, "s.npz"), "rb") as fh:
                _STATE_FILES[kind] = (fh.read(), est.get_state())
    return _STATE_FILES[kind]


@st.composite
def _mutated(draw, data):
    b = bytearray(data)
    for _ in range(draw(st.integers(1, 6))):
        op = draw(st.sampled_from(["set", "set", "xor", "insert", "delete", "dup", "cut"]))
        if not b:
            break
        i = draw(st.integers(0, len(b) - 1))
        if op == "set":
            b[i] = draw(st.integers(0, 255))
        elif op == "xor":
            b[i] ^= 1 << draw(st.integers(0, 7))
        elif op == "insert":
            b[i:i] = draw(st.binary(min_size=1, max_size=16))
        elif op == "delete":
            del b[i: i + draw(st.integers(1, 16))]
        elif op == "dup":
            j = draw(st.integers(i, min(len(b), i + 64)))
            b[j:j] = b[i:j]
        else:
            del b[i:]
    return bytes(b)


def _same_state(a, b):
    if set(a) != set(b):
        return False
    for k in a:
        if isinstance(a[k], np.ndarray):
            if a[k].tobytes() != np.asarray(b[k]).tobytes():
                return False
        elif k == "options":
            if not _same_state(a[k], b[k]):
                return False
        elif a[k] != b[k]:
            return False
    return True


def _fuzz_state_bytes(data, tmp_path_factory):
    import time
    import tracemalloc
    kind = data.draw(st.sampled_from(["RLS", "SlidingWindowRLS", "KalmanRLS"]), label="kind")
    raw, state = _state_file_bytes(kind)
    bad = data.draw(_mutated(raw), label="mutated")
    path = tmp_path_factory.getbasetemp() / "fuzz-state.npz"
    path.write_bytes(bad)
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        est = adaptid.load_state(path)
    except adaptid.StateFileError as err:
        assert str(err)
        est = None
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert time.perf_counter() - t0 < 5.0
    assert peak < 20 * 2 ** 20, peak            # the valid file is ~2 KB
    if est is not None:                          # only the zip's bookkeeping was hit
        assert _same_state(est.get_state(), state)


@FUZZ
@given(st.data())
def test_fuzz_state_file_bytes(tmp_path_factory, data):
    _fuzz_state_bytes(data, tmp_path_factory)


@pytest.mark.soak
@FUZZ_SOAK
@given(st.data())
def test_fuzz_state_file_bytes_soak(tmp_path_factory, data):
    _fuzz_state_bytes(data, tmp_path_factory)


# ------------------------------------------------------ the CLI's arguments
# `adaptid fit` with random option values (numbers of every magnitude and sign,
# NaN/inf spellings, words, empty strings, wrong column names, a state file that
# may be damaged): the exit code is 0 or 2, never 1 ("internal error") and never
# a traceback.
_CLI_NUMBERS = st.one_of(
    st.sampled_from(["0", "-1", "1", "0.5", "1e-300", "1e308", "1e400", "nan", "inf",
                     "-inf", "", "abc", "1,5", "0x10", "1e-100", "1e100", "2", "3", "10"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10 ** 6, 10 ** 6).map(str))


def _cli_env(tmp_path_factory):
    folder = tmp_path_factory.getbasetemp() / "cli-fuzz"
    if not (folder / "d.csv").exists():
        folder.mkdir(exist_ok=True)
        rng = np.random.default_rng(3)
        Phi = rng.standard_normal((60, 2))
        y = Phi @ [1.0, -1.0] + 0.1 * rng.standard_normal(60)
        lines = ["a,b,y"] + [f"{a!r},{b!r},{c!r}" for (a, b), c in zip(Phi, y)]
        (folder / "d.csv").write_text("\n".join(lines) + "\n")
        est = RLS(2)
        est.run(Phi, y)
        est.save_state(folder / "s.npz")
    return folder


def _fuzz_cli(data, tmp_path_factory):
    from typer.testing import CliRunner
    from adaptid.cli._app import app
    folder = _cli_env(tmp_path_factory)
    args = ["fit", str(folder / "d.csv"), "--y",
            data.draw(st.sampled_from(["y", "a", "nope", ""]), label="y")]
    args += ["--phi", data.draw(st.sampled_from(["a,b", "a", "b,a", "a,a", "a,,b", "zz"]),
                                label="phi")]
    for opt in ("--forgetting", "--window", "--P0", "--process-cov", "--noise-var"):
        if data.draw(st.booleans(), label=f"use {opt}"):
            args += [opt, data.draw(_CLI_NUMBERS, label=opt)]
    if data.draw(st.booleans(), label="use --method"):
        args += ["--method", data.draw(st.sampled_from(
            ["rls", "window", "kalman", "batch", "RLS", "bogus", ""]), label="method")]
    if data.draw(st.booleans(), label="use --nan"):
        args += ["--nan", data.draw(st.sampled_from(["skip", "error", "x"]), label="nan")]
    if data.draw(st.booleans(), label="use --resume"):
        state = folder / "s.npz"
        raw = bytearray(state.read_bytes())
        if data.draw(st.booleans(), label="damage the state"):
            i = data.draw(st.integers(0, len(raw) - 1), label="byte")
            raw[i] ^= 0xFF
        (folder / "r.npz").write_bytes(bytes(raw))
        args += ["--resume", str(folder / "r.npz")]
    args.append("--json")
    res = CliRunner().invoke(app, args)
    assert res.exit_code in (0, 2), (args, res.exit_code, res.output[-2000:])
    assert "Traceback" not in res.output and "internal error" not in res.output, args


@settings(max_examples=400 if SOAK else 40, derandomize=not SOAK, **_COMMON)
@given(st.data())
def test_fuzz_cli_fit_arguments(tmp_path_factory, data):
    _fuzz_cli(data, tmp_path_factory)
