"""Issue 32, point 4: forged but checksummed forms and exact-diffuse tails are refused.

The covariance form (P), the square-root form (S, P = S Sᵀ) and the tails of
the exact diffuse start (RLS: SRIF R upper triangular with a non-negative
diagonal; Kalman: integer rank-step count in 0…n, P∞ and P* symmetric
positive semi-definite) are forged by hand in files written with the
documented checksum (the helpers of ``test_state_files_hostile``, which
re-implement the format, not adaptid's writer). Controls: the same files
unforged load; a genuine estimator at every stage of its diffuse start saves
and loads; a run that fails in the kernel leaves the state as it was.
"""

import numpy as np
import pytest

from adaptid import KalmanRLS, RLS, load_state
from estimators.test_state_files_hostile import _raw, _refused, _write


def _file(tmp_path, est, name="s.npz"):
    path = tmp_path / name
    est.save_state(path)
    return _raw(path)


def _forged(tmp_path, est, start, values, name="evil.npz"):
    header, arrays = _file(tmp_path, est)
    S = arrays["state"].copy()
    S[start:start + len(values)] = values
    arrays["state"] = S
    return _write(tmp_path / name, header, arrays)


@pytest.fixture
def data():
    rng = np.random.default_rng(7)
    Phi = rng.standard_normal((40, 2))
    return Phi, Phi @ [1.0, -2.0] + 0.1 * rng.standard_normal(40)


@pytest.mark.parametrize("P, what", [([-1.0, 0.0, 0.0, -1.0], "positive definite"),
                                     ([0.0, 0.0, 0.0, 0.0], "positive definite"),
                                     ([1.0, 0.5, 0.0, 1.0], "symmetric")])
def test_covariance_form_P_forged(tmp_path, data, P, what):
    est = RLS(2, form="covariance")
    est.run(*data)
    _refused(_forged(tmp_path, est, 2, P), "inconsistent state", what)
    assert load_state(_write(tmp_path / "ok.npz", *_file(tmp_path, est))).n_updates == 40


def test_sqrt_form_S_zero(tmp_path, data):
    est = RLS(2, form="sqrt")
    est.run(*data)
    _refused(_forged(tmp_path, est, 2, [0.0] * 4), "full rank")
    _refused(_forged(tmp_path, est, 2, [3.0, 0.0, 0.0, 0.0]), "full rank")  # a zero column
    assert load_state(_write(tmp_path / "ok.npz", *_file(tmp_path, est))).n_updates == 40


def _tail_start(est, tail):
    return est.get_state()["state"].size - tail


def test_rls_diffuse_R_forged(tmp_path, data):
    est = RLS(2, P0="diffuse")
    est.run(data[0][:1], data[1][:1])  # not identified yet: the SRIF tail is live
    t = _tail_start(est, 1 + 4 + 2)
    _refused(_forged(tmp_path, est, t + 1 + 2, [5.0]), "upper triangular")   # R[1, 0]
    _refused(_forged(tmp_path, est, t + 1, [-1.0]), "non-negative diagonal")  # R[0, 0]
    _refused(_forged(tmp_path, est, t, [0.5]), "flag")


@pytest.mark.parametrize("steps", [-1e18, -1.0, 0.5, 3.0, 1e18])
def test_kalman_diffuse_rank_steps_forged(tmp_path, data, steps):
    est = KalmanRLS(2, P0="diffuse", process_cov=1e-4)
    est.run(data[0][:1], data[1][:1])
    t = _tail_start(est, 2 + 8)
    _refused(_forged(tmp_path, est, t + 1, [steps]), "rank-step count")


@pytest.mark.parametrize("offset, M", [(2, [1.0, 0.5, 0.0, 1.0]), (2, [-1.0, 0.0, 0.0, 1.0]),
                                       (6, [-1.0, 0.0, 0.0, -1.0]), (6, [1.0, 2.0, 0.0, 1.0])])
def test_kalman_diffuse_matrices_forged(tmp_path, data, offset, M):
    est = KalmanRLS(2, P0="diffuse", process_cov=1e-4)
    est.run(data[0][:1], data[1][:1])
    t = _tail_start(est, 2 + 8)
    _refused(_forged(tmp_path, est, t + offset, M), "semi-definite")


@pytest.mark.parametrize("make", [lambda: RLS(3, P0="diffuse"),
                                  lambda: KalmanRLS(3, P0="diffuse", process_cov=1e-3),
                                  lambda: RLS(3, form="covariance", forgetting=0.98),
                                  lambda: RLS(3, form="sqrt")])
def test_genuine_states_at_every_stage_save_and_load(tmp_path, make):
    rng = np.random.default_rng(1)
    Phi = rng.standard_normal((400, 3))
    y = Phi @ [1.0, 2.0, 3.0] + rng.standard_normal(400)
    for m in (0, 1, 2, 3, 4, 400):
        est = make()
        est.run(Phi[:m], y[:m])
        est.save_state(tmp_path / "s.npz")
        back = load_state(tmp_path / "s.npz")
        np.testing.assert_array_equal(back.get_state()["state"], est.get_state()["state"])


def test_nothing_is_saved_that_load_would_refuse(tmp_path, data):
    est = RLS(2, form="covariance")
    est.run(*data)
    st = est.get_state()
    st["state"][2:6] = [1.0, 0.5, 0.0, 1.0]
    forged = RLS.from_state(st)
    target = tmp_path / "s.npz"
    with pytest.raises(ValueError, match="load_state would refuse"):
        forged.save_state(target)
    assert not target.exists() and list(tmp_path.iterdir()) == []


def test_failed_run_restores_the_state(data, monkeypatch):
    est = RLS(2)
    est.run(*data)
    before = est.get_state()["state"].copy()
    kern = est._kern

    class Failing:
        def __getattr__(self, name):
            return getattr(kern, name)

        def run(self, S, *args):
            S[:] = np.nan  # the kernel wrote into the state, then failed
            raise ZeroDivisionError("division by zero")

    monkeypatch.setattr(est, "_kern", Failing())
    with pytest.raises(ZeroDivisionError):
        est.run(*data)
    np.testing.assert_array_equal(est.get_state()["state"], before)
