"""State files of ConstrainedRLS (same safe format as the core estimators).

Oracles: the uninterrupted run (bit for bit), constrained_lstsq on the data so
far, and the file-damage checks of test_state_files.py applied to this kind.
"""

import io
import json
import zipfile

import numpy as np
import pytest

import adaptid
from adaptid import RLS, StateFileError
from adaptid.estimators._statefile import _digest
from adaptid.constrained import ConstrainedRLS, constrained_lstsq

N_PARAMS = 5
C = np.array([[1.0, 1.0, 1.0, 0.0, 0.0], [0.0, 1.0, -1.0, 2.0, 0.0]])
D = np.array([1.0, 0.5])


def _data(rng, N, B=None):
    shape = (N, N_PARAMS) if B is None else (B, N, N_PARAMS)
    Phi = rng.standard_normal(shape)
    theta = np.array([0.2, 0.5, 0.3, 0.4, -1.0])
    y = Phi @ theta + 0.05 * rng.standard_normal(shape[:-1])
    return Phi, y


def _make(**kw):
    kw.setdefault("forgetting", 0.995)
    kw.setdefault("theta0", np.arange(N_PARAMS, dtype=float) / 10)
    kw.setdefault("P0", np.diag(np.linspace(10.0, 100.0, N_PARAMS)))
    return ConstrainedRLS(N_PARAMS, C, D, **kw)


@pytest.mark.parametrize("batch", [None, 3])
def test_round_trip_resumes_bit_for_bit(tmp_path, rng, batch):
    Phi, y = _data(rng, 400, batch)
    k = 157
    full = _make()
    run = full.run_batched if batch else full.run
    ref = run(Phi, y)

    first = _make()
    (first.run_batched if batch else first.run)(Phi[..., :k, :], y[..., :k])
    path = tmp_path / "c.adaptid"
    first.save_state(path)
    again = ConstrainedRLS.load_state(path)
    assert type(again) is ConstrainedRLS
    assert again.n_updates == first.n_updates
    np.testing.assert_array_equal(again.theta, first.theta)
    np.testing.assert_array_equal(again.P, first.P)
    rest = (again.run_batched if batch else again.run)(Phi[..., k:, :], y[..., k:])
    np.testing.assert_array_equal(rest.theta, ref.theta[..., k:, :])
    np.testing.assert_array_equal(again.theta, full.theta)
    # the generic reader gives the same estimator
    assert type(adaptid.load_state(path)) is ConstrainedRLS


def test_loaded_estimator_is_the_constrained_minimiser(tmp_path, rng):
    """Oracle: constrained_lstsq on the stacked data (λ = 1, diffuse prior)."""
    Phi, y = _data(rng, 60)
    est = ConstrainedRLS(N_PARAMS, C, D, P0=1e10)
    est.run(Phi[:30], y[:30])
    est.save_state(tmp_path / "s")
    est = ConstrainedRLS.load_state(tmp_path / "s")
    est.run(Phi[30:], y[30:])
    ref = constrained_lstsq(Phi, y, C, D).x
    np.testing.assert_allclose(est.theta, ref, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(C @ est.theta, D, atol=1e-12)


def test_options_and_skips_survive(tmp_path, rng):
    Phi, y = _data(rng, 50)
    y[7] = np.nan
    est = _make(nan_policy="skip", forgetting=0.97)
    est.run(Phi, y)
    est.save_state(tmp_path / "s")
    again = ConstrainedRLS.load_state(tmp_path / "s")
    assert again.forgetting == 0.97 and again.nan_policy == "skip"
    assert again.n_skipped == est.n_skipped == 1
    np.testing.assert_array_equal(again.C, C)
    np.testing.assert_array_equal(again.d, D)
    np.testing.assert_array_equal(again.theta0, est.theta0)
    np.testing.assert_array_equal(again.P0, est.P0)


def test_wrong_estimator_type_is_refused(tmp_path, rng):
    Phi, y = _data(rng, 20)
    c = _make()
    c.run(Phi, y)
    c.save_state(tmp_path / "c")
    r = RLS(N_PARAMS)
    r.run(Phi, y)
    r.save_state(tmp_path / "r")
    with pytest.raises(StateFileError, match="ConstrainedRLS, not a RLS"):
        RLS.load_state(tmp_path / "c")
    with pytest.raises(StateFileError, match="RLS, not a ConstrainedRLS"):
        ConstrainedRLS.load_state(tmp_path / "r")


def _read(path):
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(arrays.pop("header").tobytes().decode())
    return header, arrays


def _write(path, header, arrays, *, checksum=True):
    """Write a state file; checksum=True recomputes the checksum (a forgery),
    False keeps the header's old one (damage)."""
    header = dict(header)
    if checksum:
        header.pop("checksum", None)
        header["checksum"] = _digest(header, arrays)
    buf = io.BytesIO()
    np.savez(buf, header=np.frombuffer(json.dumps(header).encode(), dtype=np.uint8), **arrays)
    path.write_bytes(buf.getvalue())


@pytest.fixture
def saved(tmp_path, rng):
    Phi, y = _data(rng, 30)
    est = _make()
    est.run(Phi, y)
    path = tmp_path / "c.adaptid"
    est.save_state(path)
    return path


def test_layout_is_the_inner_rls_plus_the_constraint(saved):
    header, arrays = _read(saved)
    assert header["estimator"] == "ConstrainedRLS"
    assert header["inner_estimator"] == "RLS"
    assert header["n_params"] == N_PARAMS - C.shape[0]
    assert header["outer"]["n_params"] == N_PARAMS
    assert sorted(arrays) == ["C", "P0", "d", "outer_P0", "outer_theta0", "state", "theta0"]


def test_truncated_and_bit_flipped_files_are_refused(tmp_path, saved):
    data = saved.read_bytes()
    bad = tmp_path / "bad"
    for cut in (0, 10, len(data) // 2, len(data) - 1):
        bad.write_bytes(data[:cut])
        with pytest.raises(StateFileError):
            ConstrainedRLS.load_state(bad)
    rng = np.random.default_rng(5)
    for pos in rng.choice(len(data), 200, replace=False):
        flipped = bytearray(data)
        flipped[pos] ^= 1 << int(rng.integers(8))
        bad.write_bytes(bytes(flipped))
        try:
            est = ConstrainedRLS.load_state(bad)
        except StateFileError:
            continue
        # a flip the zip layer ignores (e.g. in a timestamp) must give the same estimator
        ref = ConstrainedRLS.load_state(saved)
        np.testing.assert_array_equal(est.theta, ref.theta)
        np.testing.assert_array_equal(est.P, ref.P)


@pytest.mark.parametrize("case", [
    "C_wrong_shape", "d_wrong_length", "C_rank_deficient", "inner_too_big",
    "outer_missing", "outer_options_not_dict", "inner_unknown", "extra_arrays_on_rls",
])
def test_forged_but_checksummed_files_are_refused(tmp_path, saved, case):
    header, arrays = _read(saved)
    if case == "C_wrong_shape":
        arrays["C"] = np.ones((2, N_PARAMS + 1))
    elif case == "d_wrong_length":
        arrays["d"] = np.ones(3)
    elif case == "C_rank_deficient":
        arrays["C"] = np.vstack([C[0], C[0]])
    elif case == "inner_too_big":
        header["outer"]["n_params"] = N_PARAMS + 1
    elif case == "outer_missing":
        del header["outer"]
    elif case == "outer_options_not_dict":
        header["outer"]["options"] = [1, 2]
    elif case == "inner_unknown":
        header["inner_estimator"] = "ConstrainedRLS"
    elif case == "extra_arrays_on_rls":
        header["estimator"] = "RLS"
    path = tmp_path / "forged"
    _write(path, header, arrays)
    with pytest.raises(StateFileError):
        adaptid.load_state(path)


def test_rewritten_file_with_recomputed_checksum_loads(tmp_path, saved):
    """The forging helper itself is right: an unchanged rewrite loads."""
    header, arrays = _read(saved)
    path = tmp_path / "rewritten"
    _write(path, header, arrays)
    est = ConstrainedRLS.load_state(path)
    np.testing.assert_array_equal(est.theta, ConstrainedRLS.load_state(saved).theta)


@pytest.mark.parametrize("name", ["C", "d", "outer_theta0", "outer_P0", "state"])
def test_altered_array_under_the_old_checksum_is_refused(tmp_path, saved, name):
    header, arrays = _read(saved)
    arrays[name] = arrays[name] + 1e-3
    path = tmp_path / "altered"
    _write(path, header, arrays, checksum=False)
    assert zipfile.is_zipfile(path)
    with pytest.raises(StateFileError, match="checksum"):
        ConstrainedRLS.load_state(path)
