"""Fleet inputs a careless user or an attacker gives (issue 32, "Fleet"), each built here.

* labels 1 and "1" (one object column): their texts name one tracks partition
  (``device=1``) and one row of a CSV of the results, so they are refused, naming
  both, before anything is written;
* ``tracks`` inside the input folder: the next run over the folder would read the
  tracks as data (the oracle: the folder's files are exactly the input ones after
  the refused call);
* a glob that matches nothing says so (not "group must be a column (columns: )").
"""

import os

import numpy as np
import pandas as pd
import pytest

from adaptid import fleet

import dask.dataframe  # noqa: E402,F401 - the test extra installs it (missing: a failure)


def _frame(labels, N=30, seed=0):
    rng = np.random.default_rng(seed)
    parts = []
    for g in labels:
        x = rng.standard_normal(N)
        parts.append(pd.DataFrame({"device": [g] * N, "x": x, "y": 2.0 * x}))
    df = pd.concat(parts, ignore_index=True)
    return df.astype({"device": object})


def test_labels_whose_texts_collide_are_refused_naming_both(tmp_path):
    df = _frame([1, "1", 2])
    tracks = tmp_path / "tracks"
    with pytest.raises(ValueError, match=r"group must be labels whose texts differ.*1 and '1'"):
        fleet.identify(df, group="device", y="y", phi=["x"], tracks=tracks)
    assert not tracks.exists() or not any(tracks.iterdir())  # nothing written
    # distinct texts of mixed types are fine: 1 and "one"
    ok = _frame([1, "one"])
    res = fleet.identify(ok, group="device", y="y", phi=["x"])
    # the ridge closed form of RLS with λ = 1, P0 = 1e4: Σxy / (Σx² + 1/P0)
    want = {g: (d.x @ d.y) / (d.x @ d.x + 1e-4) for g, d in ok.groupby(ok.device.astype(str))}
    assert sorted(map(str, res.index)) == sorted(want)
    for g, row in res.iterrows():
        np.testing.assert_allclose(row["x"], want[str(g)], rtol=1e-12)


def test_colliding_labels_found_inside_a_partition():
    from adaptid.fleet._inputs import _check_label_texts
    with pytest.raises(ValueError, match=r"1 and '1'"):
        _check_label_texts(np.array([1, "1"], dtype=object))
    _check_label_texts(np.array([1, 2, 3]))  # one numeric type: never a collision


@pytest.mark.parametrize("inside", ["tracks", os.path.join("deep", "er")])
def test_tracks_inside_the_input_folder_is_refused(tmp_path, inside):
    data = tmp_path / "in"
    data.mkdir()
    _frame(["a", "b"]).astype({"device": str}).to_parquet(data / "p.parquet")
    before = sorted(p.relative_to(data) for p in data.rglob("*"))
    for given in (str(data), str(data / "*.parquet").replace("*", "**/*")):
        with pytest.raises(ValueError, match="tracks must be a folder outside the input"):
            fleet.identify(given, group="device", y="y", phi=["x"], tracks=data / inside)
    assert sorted(p.relative_to(data) for p in data.rglob("*")) == before
    # beside the input: allowed, and the tracks are written there
    res = fleet.identify(str(data), group="device", y="y", phi=["x"], tracks=tmp_path / "t")
    assert len(res) == 2 and any((tmp_path / "t").iterdir())


def test_glob_matching_nothing_says_so(tmp_path):
    pattern = str(tmp_path / "nope-*.parquet")
    with pytest.raises(ValueError, match=r"no files match .*nope-\*\.parquet"):
        fleet.identify(pattern, group="device", y="y", phi=["x"])
