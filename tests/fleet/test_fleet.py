"""adaptid.fleet: identify over many devices on Dask, tall-skinny lstsq, the fleet data set.

Oracles: a plain Python loop of the single-stream estimator ``run`` per
group (the definition of what ``identify`` computes), numpy for residual
variances, :func:`adaptid.diagnostics.cusum` for the change flag,
statsmodels OLS for standard errors, numpy/adaptid ``lstsq`` for the dask
least squares, and the data set's own ground truth for faults.
"""

import functools

import numpy as np
import pandas as pd
import pytest

import adaptid
from adaptid import fleet
from adaptid.datasets import fleet as make_fleet
from adaptid.diagnostics import cusum, recursive_residuals

import dask  # noqa: E402  (the test extra installs dask[dataframe] and distributed)
import dask.array as da  # noqa: E402
import dask.dataframe as dd  # noqa: E402
import distributed  # noqa: E402

PHI = ["i", "di_dt", "omega", "sign_i"]


_TRUTH = {}


def fleet_with_truth(**kw):
    """make_fleet's frame; its ground truth is kept for truth_of()."""
    df, truth = make_fleet(**kw, return_truth=True)
    _TRUTH[id(df)] = truth
    return df


def truth_of(df):
    return _TRUTH[id(df)]


# The equality tests below compare with loop_reference, whose change flag is
# Brown-Durbin-Evans' CUSUM of the a-priori errors: they pin that test (the
# default supF, with p-values and multiple-testing control, is checked in
# tests/fleet/test_fleet_change.py against adaptid.diagnostics and statsmodels).
identify = functools.partial(fleet.identify, change_test="a-priori")


# ------------------------------------------------------------------ helpers
def loop_reference(df, est, *, phi=PHI, y="v", time="time", alpha=0.05, burn_in=None,
                   window=0, noise_var=1.0, forgetting=1.0):
    """What identify must give, by a plain loop of `run` over the groups."""
    n = len(phi)
    a_rows = {}
    for dev, g in df.groupby("device", sort=True):
        if time is not None:
            g = g.sort_values(time, kind="stable")
        Phi = g[phi].to_numpy(dtype=float)
        Y = g[y].to_numpy(dtype=float)
        e = est.copy().reset()
        tr = e.run(Phi, Y)
        used = np.ones(len(Y), bool) if tr.skipped is None else ~np.asarray(tr.skipped)
        iu = np.flatnonzero(used)
        if window:
            iu = iu[-window:]
        r = Y[iu] - Phi[iu] @ e.theta
        # issue 13 point 3 (one rule, docs/guide.md): sample k weighs λ^(used samples after k)
        c = forgetting ** np.arange(iu.size - 1, -1, -1.0)
        sigma2 = (c @ (r * r)) / (c.sum() - n)
        stderr = np.sqrt(np.diag(e.P) * sigma2 / noise_var)
        burn = max(10 * n, int(np.ceil(0.1 * used.sum()))) if burn_in is None else burn_in
        err_rows = np.flatnonzero(used)[burn:]
        c = cusum(tr.error[err_rows], alpha, scale="ols")   # the fleet flag is BDE's
        tcol = g[time].to_numpy() if time is not None else np.arange(len(g))
        at = float(tcol[err_rows[c.first_crossing]]) if c.crossed else np.nan
        a_rows[dev] = dict(zip(phi, e.theta), **{f"stderr_{p}": s for p, s in zip(phi, stderr)},
                           n_samples=int(used.sum()), sigma2=sigma2, change=c.crossed,
                           change_at=at, change_stat=np.max(np.abs(c.statistic) / c.upper))
    return pd.DataFrame.from_dict(a_rows, orient="index")


def assert_same(res, ref, *, exact_theta=True, phi=PHI):
    assert list(res.index) == list(ref.index)
    if exact_theta:  # run_segments is bit for bit run
        np.testing.assert_array_equal(res[phi].to_numpy(), ref[phi].to_numpy())
    else:
        np.testing.assert_allclose(res[phi].to_numpy(), ref[phi].to_numpy(), rtol=1e-12)
    se = [f"stderr_{p}" for p in phi]
    # same numbers, summed in a different order: a few ulps
    np.testing.assert_allclose(res[se].to_numpy(), ref[se].to_numpy(), rtol=1e-9)
    np.testing.assert_allclose(res["sigma2"], ref["sigma2"], rtol=1e-9)
    np.testing.assert_array_equal(res["n_samples"], ref["n_samples"])
    np.testing.assert_array_equal(res["change"], ref["change"])
    np.testing.assert_array_equal(res["change_at"], ref["change_at"])
    np.testing.assert_allclose(res["change_stat"], ref["change_stat"], rtol=1e-9)


# ------------------------------------------------------------------ fixtures
@pytest.fixture(scope="module")
def small():
    return fleet_with_truth(n_devices=24, n_samples=300, seed=3, fault_fraction=0.25)


@pytest.fixture(scope="module")
def small_ref(small):
    return loop_reference(small, adaptid.RLS(4))


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as lc, \
            distributed.Client(lc, set_as_default=False) as client:
        yield client


@pytest.fixture(scope="module")
def parquet_dir(small, tmp_path_factory):
    path = tmp_path_factory.mktemp("fleet") / "data"
    # rows shuffled over 3 files, so each device is spread over several files
    shuffled = small.sample(frac=1.0, random_state=1).reset_index(drop=True)
    dd.from_pandas(shuffled, npartitions=3, sort=False).to_parquet(path, write_index=False)
    return path


# ------------------------------------------------------------- equivalence
def test_pandas_equals_loop(small, small_ref):
    res = identify(small, group="device", y="v", phi=PHI, time="time")
    assert res.index.name == "device"
    assert_same(res, small_ref)
    assert (res["n_skipped"] == 0).all()


def test_dask_input_equals_loop(small, small_ref):
    shuffled = small.sample(frac=1.0, random_state=7)
    ddf = dd.from_pandas(shuffled, npartitions=5, sort=False)
    res = identify(ddf, group="device", y="v", phi=PHI, time="time")
    assert_same(res, small_ref)


def test_parquet_input_equals_loop(parquet_dir, small_ref):
    res = identify(str(parquet_dir), group="device", y="v", phi=PHI, time="time")
    assert_same(res, small_ref)
    res_glob = identify(str(parquet_dir / "*.parquet"), group="device", y="v", phi=PHI,
                              time="time")
    assert_same(res_glob, small_ref)


@pytest.mark.parametrize("kind", ["pandas", "dask", "parquet"])
def test_local_cluster_equals_loop(kind, cluster, small, small_ref, parquet_dir):
    data = {"pandas": small,
            "dask": dd.from_pandas(small.sample(frac=1.0, random_state=2), npartitions=4,
                                   sort=False),
            "parquet": str(parquet_dir)}[kind]
    res = identify(data, group="device", y="v", phi=PHI, time="time", client=cluster)
    assert_same(res, small_ref)


def test_scheduler_address(cluster, small, small_ref):
    res = identify(small, group="device", y="v", phi=PHI, time="time",
                         client=cluster.scheduler.address)
    assert_same(res, small_ref)


@pytest.mark.parametrize("method, options, window, noise_var", [
    ("rls", {"forgetting": 0.99, "P0": 1e3}, 0, 1.0),
    ("window", {"window": 80}, 80, 1.0),
    ("kalman", {"process_cov": 1e-6, "noise_var": 0.01}, 0, 0.01),
])
def test_methods_equal_loop(small, method, options, window, noise_var):
    cls = {"rls": adaptid.RLS, "window": adaptid.SlidingWindowRLS,
           "kalman": adaptid.KalmanRLS}[method]
    est = cls(4, **options)
    ref = loop_reference(small, est, window=window, noise_var=noise_var,
                         forgetting=options.get("forgetting", 1.0))
    res = identify(small, group="device", y="v", phi=PHI, time="time", method=method,
                         **options)
    assert_same(res, ref)


def test_shuffled_rows_with_time_equal_sorted(small, small_ref):
    sorted_res = identify(small, group="device", y="v", phi=PHI, time="time")
    shuffled = small.sample(frac=1.0, random_state=11)
    res = identify(shuffled, group="device", y="v", phi=PHI, time="time", npartitions=3)
    pd.testing.assert_frame_equal(res, sorted_res)
    assert_same(res, small_ref)


def test_time_none_takes_stored_order(small):
    # reverse the rows of every device: without `time` that reversed order is used
    rev = small.iloc[::-1].reset_index(drop=True)
    ref = loop_reference(rev, adaptid.RLS(4), time=None)
    assert_same(identify(rev, group="device", y="v", phi=PHI), ref)
    ddf = dd.from_pandas(rev, npartitions=4, sort=False)
    assert_same(identify(ddf, group="device", y="v", phi=PHI), ref)


def test_equal_times_keep_stored_order(small):
    coarse = small.assign(time=(small["time"] * 20).round() / 20)  # many equal times
    ref = loop_reference(coarse, adaptid.RLS(4))
    ddf = dd.from_pandas(coarse.sample(frac=1.0, random_state=3), npartitions=4, sort=False)
    ddf_ref = loop_reference(ddf.compute(), adaptid.RLS(4))
    assert_same(identify(coarse, group="device", y="v", phi=PHI, time="time"), ref)
    assert_same(identify(ddf, group="device", y="v", phi=PHI, time="time"), ddf_ref)


def test_nan_skip_equals_loop(small):
    bad = small.copy()
    bad.loc[bad.index[[5, 400, 401, 2000]], "v"] = np.nan
    bad.loc[bad.index[1000], "omega"] = np.nan
    ref = loop_reference(bad, adaptid.RLS(4, nan_policy="skip"))
    res = identify(bad, group="device", y="v", phi=PHI, time="time", nan_policy="skip")
    assert_same(res, ref)
    assert res["n_skipped"].sum() == 5


def test_model_callable_equals_loop(small):
    """A model with a lag (v[k-1] as regressor): rows are built per group."""
    from adaptid.models import Regression

    names = ("i", "omega", "v[k-1]")

    def model(g):
        v = g["v"].to_numpy()
        Phi = np.column_stack([g["i"].to_numpy()[1:], g["omega"].to_numpy()[1:], v[:-1]])
        return Regression(Phi=Phi, y=v[1:], names=names, index=np.arange(1, len(g)))

    res = identify(small, group="device", y=None, model=model, time="time")
    assert list(res.columns[:3]) == list(names)
    for dev in (0, 7, 23):
        g = small[small.device == dev].sort_values("time")
        reg = model(g)
        e = adaptid.RLS(3)
        e.run(reg.Phi, reg.y)
        np.testing.assert_array_equal(res.loc[dev, list(names)].to_numpy(float), e.theta)
        assert res.loc[dev, "n_samples"] == len(g) - 1


def test_tracks_written(tmp_path, small):
    out = tmp_path / "tracks"
    identify(small, group="device", y="v", phi=PHI, time="time", tracks=str(out))
    tr = pd.read_parquet(out)
    assert len(tr) == len(small)
    g = tr[tr["device"].astype(int) == 4].sort_values("time")
    d = small[small.device == 4]
    ref = adaptid.RLS(4).run(d[PHI].to_numpy(), d["v"].to_numpy())
    np.testing.assert_array_equal(g[PHI].to_numpy(), ref.theta)
    np.testing.assert_array_equal(g["error"].to_numpy(), ref.error)


# ------------------------------------------------------------ change flag
@pytest.fixture(scope="module")
def faulty_fleet():
    return fleet_with_truth(n_devices=60, n_samples=1000, seed=0, fault_fraction=0.2)


@pytest.mark.parametrize("change_test", ["a-priori", "recursive"])
def test_change_flag_finds_faults(faulty_fleet, change_test):
    truth = truth_of(faulty_fleet)
    G = len(truth)
    alpha = 0.05 / G  # family-wise 5 % over the fleet (Bonferroni)
    res = identify(faulty_fleet, group="device", y="v", phi=PHI, time="time",
                         alpha=alpha, change_test=change_test)
    assert truth["fault"].sum() == 12
    np.testing.assert_array_equal(res["change"].to_numpy(), truth["fault"].to_numpy())
    # the first crossing comes after the fault
    f = truth["fault"].to_numpy()
    assert (res["change_at"].to_numpy()[f] >= truth["fault_time"].to_numpy()[f]).all()
    assert res["change_at"][~f].isna().all()


def test_recursive_change_test_matches_diagnostics(faulty_fleet):
    res = identify(faulty_fleet, group="device", y="v", phi=PHI, time="time",
                         change_test="recursive", alpha=0.01)
    for dev in range(0, 60, 7):
        g = faulty_fleet[faulty_fleet.device == dev]
        w = recursive_residuals(g[PHI].to_numpy(), g["v"].to_numpy())
        c = cusum(w, alpha=0.01, scale="ols")
        assert res.loc[dev, "change"] == c.crossed
        np.testing.assert_allclose(res.loc[dev, "change_stat"],
                                   np.max(np.abs(c.statistic) / c.upper), rtol=1e-9)
        if c.crossed:
            assert res.loc[dev, "change_at"] == g["time"].to_numpy()[4 + c.first_crossing]


def test_stderr_equals_ols(small):
    """RLS with λ = 1 and a diffuse prior is OLS: θ and standard errors (statsmodels)."""
    import statsmodels.api as sm
    truth = truth_of(small)
    healthy = truth.index[~truth["fault"]][:4]
    res = identify(small, group="device", y="v", phi=PHI, time="time", P0=1e10)
    for dev in healthy:
        g = small[small.device == dev]
        ols = sm.OLS(g["v"].to_numpy(), g[PHI].to_numpy()).fit()
        # prior weight 1e-10 against data information ≥ 300·0.5²: relative 1e-8
        np.testing.assert_allclose(res.loc[dev, PHI].to_numpy(float), ols.params, rtol=1e-6)
        np.testing.assert_allclose(res.loc[dev, [f"stderr_{p}" for p in PHI]].to_numpy(float),
                                   ols.bse, rtol=1e-6)
        np.testing.assert_allclose(res.loc[dev, "sigma2"], ols.scale, rtol=1e-6)


# ------------------------------------------------------------------ bad input
def test_missing_columns_named(small):
    with pytest.raises(ValueError, match="group must be .*'dev'"):
        identify(small, group="dev", y="v", phi=PHI)
    with pytest.raises(ValueError, match="phi must be .*'current'"):
        identify(small, group="device", y="v", phi=["current", "omega"])
    with pytest.raises(ValueError, match="y must be .*'voltage'"):
        identify(small, group="device", y="voltage", phi=PHI)
    with pytest.raises(ValueError, match="time must be .*'t'"):
        identify(small, group="device", y="v", phi=PHI, time="t")
    ddf = dd.from_pandas(small, npartitions=2, sort=False)
    with pytest.raises(ValueError, match="phi must be .*'current'"):
        identify(ddf, group="device", y="v", phi=["current"])


def test_nan_raise_names_group(small):
    bad = small.copy()
    row = bad.index[(bad.device == 13).to_numpy()][50]
    bad.loc[row, "omega"] = np.nan
    with pytest.raises(ValueError, match="group 13"):
        identify(bad, group="device", y="v", phi=PHI, time="time")
    with pytest.raises(ValueError, match="group 13"):
        identify(dd.from_pandas(bad, npartitions=3, sort=False), group="device", y="v",
                       phi=PHI, time="time")


def test_short_group_named(small):
    short = pd.concat([small, small[small.device == 0].head(3).assign(device=99)])
    with pytest.raises(ValueError, match="3 samples in group 99"):
        identify(short, group="device", y="v", phi=PHI, time="time")


def test_bad_options(small):
    with pytest.raises(TypeError, match="window"):
        identify(small, group="device", y="v", phi=PHI, window=10)
    with pytest.raises(TypeError, match="process_cov"):
        identify(small, group="device", y="v", phi=PHI, method="kalman")
    with pytest.raises(ValueError, match="method"):
        identify(small, group="device", y="v", phi=PHI, method="lsm")
    with pytest.raises(TypeError, match="step"):  # lms is a method since issue 16; it needs step
        identify(small, group="device", y="v", phi=PHI, method="lms")
    with pytest.raises(ValueError, match="forgetting"):
        identify(small, group="device", y="v", phi=PHI, forgetting=1.5)
    with pytest.raises(TypeError, match="phi"):
        identify(small, group="device", y="v")
    with pytest.raises(TypeError, match="data"):
        identify(np.zeros((3, 3)), group="device", y="v", phi=PHI)


# ------------------------------------------------------------------ lstsq
def test_lstsq_dask_equals_lstsq(rng):
    N = 20_011
    Phi = rng.standard_normal((N, 4)) * [1.0, 10.0, 100.0, 0.1]
    y = Phi @ [1.0, -2.0, 0.5, 3.0] + rng.standard_normal(N)
    w = rng.uniform(0.0, 2.0, N)
    for weights in (None, w):
        ref = adaptid.lstsq(Phi, y, weights=weights)
        res = fleet.lstsq(da.from_array(Phi, chunks=(1999, 2)), da.from_array(y, chunks=3001),
                          weights=None if weights is None else da.from_array(w, chunks=5000))
        np.testing.assert_allclose(res.theta, ref.theta, rtol=0, atol=1e-10)
        np.testing.assert_allclose(res.stderr, ref.stderr, rtol=0, atol=1e-10)
        np.testing.assert_allclose(res.cov, ref.cov, rtol=0, atol=1e-10)
        assert res.sigma2 == pytest.approx(ref.sigma2, rel=1e-10)
        assert res.dof == ref.dof
        np.testing.assert_allclose(res.residuals.compute(), ref.residuals, rtol=0, atol=1e-9)
    # independent oracle: numpy's SVD-based lstsq
    np.testing.assert_allclose(res.theta if weights is None else
                               fleet.lstsq(da.from_array(Phi, chunks=(5000, 4)), y).theta,
                               np.linalg.lstsq(Phi, y, rcond=None)[0], rtol=0, atol=1e-10)


def test_lstsq_dask_multi_output_and_small_blocks(rng):
    N = 2500
    Phi = rng.standard_normal((N, 3))
    Y = Phi @ rng.standard_normal((3, 2)) + rng.standard_normal((N, 2))
    ref = adaptid.lstsq(Phi, Y)
    res = fleet.lstsq(da.from_array(Phi, chunks=(7, 3)), da.from_array(Y, chunks=(700, 1)))
    np.testing.assert_allclose(res.theta, ref.theta, rtol=0, atol=1e-10)
    np.testing.assert_allclose(res.sigma2, ref.sigma2, rtol=1e-10)
    np.testing.assert_allclose(res.conf_int(), ref.conf_int(), rtol=0, atol=1e-10)


def test_lstsq_dask_bad_input(rng):
    Phi = rng.standard_normal((100, 2))
    y = rng.standard_normal(100)
    with pytest.raises(ValueError, match="y must be"):
        fleet.lstsq(da.from_array(Phi, chunks=50), da.from_array(y[:99], chunks=50))
    with pytest.raises(ValueError, match="weights must be non-negative"):
        fleet.lstsq(Phi, y, weights=-np.ones(100))
    bad = Phi.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="Phi must be finite"):
        fleet.lstsq(da.from_array(bad, chunks=20), y)
    with pytest.raises(ValueError, match="rank"):
        fleet.lstsq(np.column_stack([Phi[:, 0], Phi[:, 0]]), y)


# ------------------------------------------------------------------ data set
def test_fleet_dataset_truth_and_regression():
    kw = dict(n_devices=12, n_samples=400, seed=5, fault_fraction=0.25)
    df = fleet_with_truth(**kw)
    pd.testing.assert_frame_equal(df, make_fleet(**kw))
    assert list(df.columns) == ["device", "time", "v", "i", "di_dt", "omega", "sign_i"]
    truth = truth_of(df)
    assert truth["fault"].sum() == 3 and len(truth) == 12
    # without noise the voltage is exactly the stated regression with the true θ,
    # the faulty parameter switching at fault_sample
    clean = make_fleet(**kw, noise_std=0.0)
    for dev in truth.index:
        g = clean[clean.device == dev]
        theta = np.tile(truth.loc[dev, ["R", "L", "Ke", "V_b"]].to_numpy(float), (len(g), 1))
        if truth.loc[dev, "fault"]:
            k = truth.loc[dev, "fault_sample"]
            assert 0.3 * 400 <= k <= 0.7 * 400
            assert truth.loc[dev, "fault_time"] == pytest.approx(k * 1e-3)
            theta[k:, 0] = truth.loc[dev, "value_after"]
            assert truth.loc[dev, "value_after"] == pytest.approx(1.3 * truth.loc[dev, "R"])
        v = np.einsum("kj,kj->k", g[PHI].to_numpy(), theta)
        np.testing.assert_allclose(g["v"].to_numpy(), v, rtol=1e-12, atol=1e-12)
    # the noise has the stated standard deviation
    r = df["v"].to_numpy() - clean["v"].to_numpy()
    assert r.std() == pytest.approx(0.05, rel=0.03)
    # the current's backward difference is the di_dt column; the current is positive
    g = df[df.device == 2]
    np.testing.assert_allclose(g["di_dt"].to_numpy()[1:], np.diff(g["i"].to_numpy()) / 1e-3)
    assert (df["i"] > 0).all() and (df["sign_i"] == 1).all()


def test_fleet_dataset_bad_arguments():
    with pytest.raises(ValueError, match="fault_fraction"):
        make_fleet(fault_fraction=1.5)
    with pytest.raises(ValueError, match="fault_param"):
        make_fleet(fault_param="J")


# ------------------------------------------------------------------ CLI work
def test_fleet_command(parquet_dir, small_ref, tmp_path):
    from adaptid.cli._fleet import fleet_command, summary_text, write_result
    res = fleet_command(str(parquet_dir), "device", "v", "i,di_dt,omega,sign_i", time="time",
                        change_test="a-priori", quiet=True)
    assert_same(res, small_ref)
    text = summary_text(res)
    assert f"{len(res)} devices identified, {int(res['change'].sum())} with a change" in text
    write_result(res, tmp_path / "out.csv")
    back = pd.read_csv(tmp_path / "out.csv", index_col="device")
    np.testing.assert_allclose(back[PHI].to_numpy(), res[PHI].to_numpy(), rtol=1e-15)


def test_public_index():
    assert sorted(fleet.__all__) == ["fit_models", "identify", "lstsq"]  # fit_models: fleetb
