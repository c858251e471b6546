"""`adaptid fit --arx / --ar / --fir` with a recursive --method runs the streaming objects
(issue 33, point 3: "the CLI's recursive methods for model options use them").

What the CLI must agree with, on the same CSV:

* ``RecursiveARX`` / ``RecursiveAR`` (``start="filled"``, MATLAB's method of the
  CLI's estimator) called in Python: θ after every sample and the one-step
  errors ``y - yhat``, bit for bit (the CLI runs the same object in chunks,
  which equals one run bit for bit);
* the old path, written out here: the regressor matrix built by hand in NumPy
  (rows k = s … N-1, columns -y(k-1) … -y(k-na), u(k-nk) … u(k-nk-nb+1))
  and the estimator of :func:`adaptid.estimator` run over it; θ bit for bit,
  the errors to 1e-12 (the estimator's a-priori error is formed in the
  compiled loop, the object's ``y - yhat`` in NumPy: rounding only).
"""


import numpy as np
import pandas as pd
import pytest
from scipy import signal

import adaptid
import adaptid.codegen
from ._helpers import invoke, run_json
from adaptid.estimators._statefile import save_state
from adaptid.models import IDData, RecursiveAR, RecursiveARX




@pytest.fixture(scope="module")
def record(tmp_path_factory):
    rng = np.random.default_rng(33)
    N = 400
    u = rng.standard_normal((N, 2))
    y = (signal.lfilter([0, 1.0, 0.5], [1, -1.2, 0.5], u[:, 0])
         + signal.lfilter([0, 0, 0.3], [1, -1.2, 0.5], u[:, 1]) + 0.1 * rng.standard_normal(N))
    path = tmp_path_factory.mktemp("arxstream") / "rec.csv"
    pd.DataFrame({"u": u[:, 0], "v": u[:, 1], "y": y}).to_csv(path, index=False,
                                                                float_format="%.17g")
    return path, y, u


#: (CLI options, the core estimator's method and options, RecursiveARX's method and options)
METHODS = {
    "rls": (["--forgetting", "0.98", "--P0", "100"], ("rls", dict(forgetting=0.98, P0=100.0)),
            dict(method="forgetting", forgetting=0.98, P0=100.0)),
    "window": (["--window", "60", "--forgetting", "0.995", "--P0", "1000"],
               ("window", dict(window=60, forgetting=0.995, P0=1000.0)),
               dict(method="forgetting", window=60, forgetting=0.995, P0=1000.0)),
    "kalman": (["--process-cov", "1e-4", "--noise-var", "0.5", "--P0", "10"],
               ("kalman", dict(process_cov=1e-4, noise_var=0.5, P0=10.0)),
               dict(method="kalman", noise_cov=1e-4, noise_var=0.5, P0=10.0)),
    "lms": (["--step", "0.01"], ("lms", dict(step=0.01)), dict(method="gradient", step=0.01)),
    "nlms": (["--step", "0.5", "--eps", "1e-3"], ("nlms", dict(step=0.5, eps=1e-3)),
             dict(method="ngradient", step=0.5, bias=1e-3)),
}
#: (CLI options, na, nb, nk, the input columns)
KINDS = {
    "arx": (["--u", "u", "--arx", "2,2,1"], 2, 2, 1, [0]),
    "arx2": (["--u", "u,v", "--arx", "2,2,1"], 2, 2, 1, [0, 1]),
    "ar": (["--ar", "2"], 2, 0, 1, []),
    "fir": (["--u", "u", "--fir", "3,1"], 0, 3, 1, [0]),
}


def hand_regressors(y, u, na, nb, nk, cols):
    """The old path's Φ, written out: rows where every lag is measured."""
    s = max([na] + [nk + nb - 1] * bool(cols and nb))
    k = np.arange(s, len(y))
    Phi = [-y[k - j] for j in range(1, na + 1)]
    for i in cols:
        Phi += [u[k - j, i] for j in range(nk, nk + nb)]
    return np.column_stack(Phi), y[s:], s


def python_object(kind, na, nb, nk, cols, opts):
    if kind == "ar":
        return RecursiveAR(na, start="filled", **opts)
    if len(cols) == 1:
        return RecursiveARX(na, nb, nk, start="filled", **opts)
    return RecursiveARX(na, [nb] * len(cols), [nk] * len(cols), start="filled", **opts)


@pytest.mark.parametrize("method", list(METHODS))
@pytest.mark.parametrize("kind", list(KINDS))
def test_cli_equals_streaming_object_and_old_path(record, tmp_path, kind, method):
    path, y, u = record
    cli_opts, na, nb, nk, cols = KINDS[kind]
    m_opts, (core, core_opts), obj_opts = METHODS[method]
    tracks = tmp_path / "t.parquet"
    out = run_json("fit", path, "--y", "y", *cli_opts, "--method", method, *m_opts,
                   "--tracks", tracks)
    df = pd.read_parquet(tracks)
    names = [c for c in df.columns if c not in ("sample", "error")]
    # the streaming object in Python, on the same record
    obj = python_object(kind, na, nb, nk, cols, obj_opts)
    res = obj.run(y) if kind == "ar" else obj.run(y, u[:, cols] if len(cols) > 1 else u[:, 0])
    s = obj._s
    assert out["method"] == method and out["names"] == list(obj.names) == names
    np.testing.assert_array_equal(df["sample"], np.arange(s, len(y)))
    np.testing.assert_array_equal(df[names].to_numpy(), res.theta[s:])
    np.testing.assert_array_equal(df["error"], y[s:] - res.yhat[s:])
    np.testing.assert_array_equal(out["theta"], res.theta[-1])
    assert out["n_updates"] == obj.estimator.n_updates == len(y) - s
    # the old path: the estimator over the regressor matrix written out here
    Phi, yy, s2 = hand_regressors(y, u, na, nb, nk, cols)
    assert s2 == s
    est = adaptid.estimator(core, Phi.shape[1], **core_opts)
    tr = est.run(Phi, yy)
    np.testing.assert_allclose(df[names].to_numpy(), tr.theta, rtol=0, atol=1e-12)
    np.testing.assert_allclose(df["error"], tr.error, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out["theta"], est.theta, rtol=0, atol=1e-12)


def test_intercept_keeps_the_estimator_on_the_regressors(record):
    """--intercept: RecursiveARX has no constant term; the estimator runs on [Φ, 1]."""
    path, y, u = record
    out = run_json("fit", path, "--y", "y", "--u", "u", "--arx", "2,2,1", "--intercept",
                   "--method", "rls", "--forgetting", "0.99")
    Phi, yy, _ = hand_regressors(y, u, 2, 2, 1, [0])
    est = adaptid.RLS(5, forgetting=0.99)
    est.run(np.column_stack([Phi, np.ones(len(yy))]), yy)
    assert out["names"][-1] == "intercept"
    np.testing.assert_allclose(out["theta"], est.theta, rtol=0, atol=1e-12)


def test_nan_words_with_a_model_option(record, tmp_path):
    """--nan skip on a complete record: the object's numbers; a record with a gap is refused
    with either word (the model options need complete records, as before)."""
    path, y, u = record
    clean = run_json("fit", path, "--y", "y", "--u", "u", "--fir", "3,1", "--method", "rls",
                     "--nan", "skip")
    res = RecursiveARX(0, 3, 1, start="filled").run(y, u[:, 0])
    np.testing.assert_array_equal(clean["theta"], res.theta[-1])
    assert clean["nan_policy"] == "skip" and clean["n_skipped"] == 0
    yg = y.copy()
    yg[100] = np.nan
    gap = tmp_path / "gap.csv"
    pd.DataFrame({"u": u[:, 0], "y": yg}).to_csv(gap, index=False, float_format="%.17g")
    for word in ("skip", "raise"):
        r = invoke("fit", gap, "--y", "y", "--u", "u", "--fir", "3,1", "--method", "rls",
                   "--nan", word)
        assert r.exit_code == 2 and len(r.stderr.strip().splitlines()) == 1, word


def test_detrend_validate_out_are_the_objects(record, tmp_path):
    """--detrend each part, --validate on the held-out part, --out: the object's θ."""
    path, y, u = record
    rep = tmp_path / "rep"
    out = run_json("fit", path, "--y", "y", "--u", "u", "--arx", "2,2,1", "--method", "kalman",
                   "--process-cov", "1e-5", "--detrend", "constant", "--validate", "0.6",
                   "--out", rep)
    est_part, val_part = IDData(y, u[:, 0]).split(0.6)
    est_part, val_part = est_part.detrend("constant"), val_part.detrend("constant")
    obj = RecursiveARX(2, 2, 1, start="filled", method="kalman", noise_cov=1e-5)
    obj.run(est_part)
    np.testing.assert_array_equal(out["theta"], obj.theta)
    # the model at the object's estimate, simulated on the detrended held-out part
    model = adaptid.models.ARX(2, 2, 1).fit(est_part)
    model.theta = obj.theta
    fit = adaptid.models.compare(val_part, model).fit[0]
    assert out["validation"]["fit_percent"] == pytest.approx(fit, rel=1e-12)
    for name in ("index.html", "tracks.png", "compare.png"):
        assert (rep / name).is_file()


def test_save_resume_continue_the_estimator(record, tmp_path):
    """Two halves with --save-state/--resume: the state is the core estimator (as before),
    each half starts with empty lag buffers (start="filled"), so the run equals the estimator
    over the two halves' regressor matrices, one after the other."""
    path, y, u = record
    half = len(y) // 2
    first, second = tmp_path / "a.csv", tmp_path / "b.csv"
    for p, sl in ((first, slice(0, half)), (second, slice(half, None))):
        pd.DataFrame({"u": u[sl, 0], "y": y[sl]}).to_csv(p, index=False, float_format="%.17g")
    state = tmp_path / "s.npz"
    base = ("--y", "y", "--u", "u", "--arx", "2,2,1")
    run_json("fit", first, *base, "--method", "window", "--window", "50", "--save-state", state)
    out = run_json("fit", second, *base, "--resume", state, "--save-state", state)
    est = adaptid.SlidingWindowRLS(4, 50)
    for sl in (slice(0, half), slice(half, None)):
        Phi, yy, _ = hand_regressors(y[sl], u[sl], 2, 2, 1, [0])
        est.run(Phi, yy)
    assert out["method"] == "window" and out["n_updates"] == est.n_updates
    np.testing.assert_allclose(out["theta"], est.theta, rtol=0, atol=1e-12)
    saved = adaptid.load_state(state)
    np.testing.assert_allclose(saved.theta, est.theta, rtol=0, atol=1e-12)
    # another structure with the same regressor names (nk) is refused
    r = invoke("fit", second, "--y", "y", "--u", "u", "--arx", "2,2,3", "--resume", state)
    assert r.exit_code == 2 and "--resume" in r.stderr and "2,2,1" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_state_of_the_old_path_still_resumes(record, tmp_path):
    """A state file as the old path wrote it (the core estimator, labels without the
    orders) resumes under the object path."""
    path, y, u = record
    Phi, yy, _ = hand_regressors(y, u, 2, 2, 1, [0])
    est = adaptid.RLS(4, forgetting=0.99)
    est.run(Phi[:100], yy[:100])
    state = tmp_path / "old.npz"
    save_state(est, state, labels={"saved_by": "adaptid fit", "model": "arx", "output": "y",
                                   "regressors": ["a1", "a2", "b0", "b1"]})
    out = run_json("fit", path, "--y", "y", "--u", "u", "--arx", "2,2,1", "--resume", state)
    est.run(Phi, yy)
    np.testing.assert_allclose(out["theta"], est.theta, rtol=0, atol=1e-12)
    assert out["n_updates"] == 100 + len(yy)


def test_export_c_is_the_objects_estimator(record, tmp_path):
    """--export-c writes the model C of a fresh RecursiveARX (start="filled", empty buffers)
    that continues the fitted estimator, with the detrend offsets."""
    path, y, u = record
    cdir = tmp_path / "c"
    run_json("fit", path, "--y", "y", "--u", "u", "--arx", "2,2,1", "--method", "rls",
             "--detrend", "constant", "--export-c", cdir, "--c-name", "m")
    data = IDData(y, u[:, 0]).detrend("constant")
    fitted = RecursiveARX(2, 2, 1, start="filled")
    fitted.run(data)
    state = RecursiveARX(2, 2, 1, start="filled").get_state()
    state["inner"] = fitted.estimator.get_state()
    fresh = RecursiveARX.from_state(state)
    ref = tmp_path / "ref"
    y0 = float(np.asarray(data.y_trend).reshape(-1)[0])
    u0 = float(np.asarray(data.u_trend).reshape(-1)[0])
    adaptid.codegen.to_c(fresh, ref, name="m", offsets=(y0, u0))
    for f in ("m.h", "m.c"):
        assert (cdir / f).read_text() == (ref / f).read_text()


def test_which_runs_go_through_the_object(record, monkeypatch):
    """A recursive method runs the object (RecursiveARX / RecursiveAR on the CLI's
    estimator); the batch fit and --intercept do not."""
    path, _, _ = record
    seen = []
    run_on = RecursiveARX._run_on

    def spy(self, est):
        seen.append(type(self).__name__)
        return run_on(self, est)

    monkeypatch.setattr(RecursiveARX, "_run_on", spy)
    for opts, want in ((["--u", "u", "--arx", "1,1,1", "--method", "lms", "--step", "0.01"],
                        ["RecursiveARX"]),
                       (["--ar", "1", "--P0", "10"], ["RecursiveAR"]),
                       (["--u", "u", "--fir", "2,0", "--method", "nlms", "--step", "0.1"],
                        ["RecursiveARX"]),
                       (["--u", "u", "--arx", "1,1,1"], []),
                       (["--u", "u", "--arx", "1,1,1", "--method", "rls", "--intercept"], [])):
        seen.clear()
        run_json("fit", path, "--y", "y", *opts)
        assert seen == want, opts


def test_resume_of_a_python_streaming_object_is_refused_in_one_line(record, tmp_path):
    path, y, u = record
    state = tmp_path / "obj.npz"
    obj = RecursiveARX(2, 2, 1, start="filled")
    obj.run(y[:100], u[:100, 0])
    obj.save_state(state)
    r = invoke("fit", path, "--y", "y", "--u", "u", "--arx", "2,2,1", "--resume", state)
    assert r.exit_code == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "RecursiveARX" in r.stderr and "load_state" in r.stderr
