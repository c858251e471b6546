"""Issue 32, point 5: the reader converts only the columns a command uses.

Oracles: pandas' own reading of the same file (values), the header written
here (names), and the reader's table of converted columns (only those asked
for). A file of many columns is read by the CLI with the same result as a
file holding just the used columns.
"""

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptid import io
from adaptid._exceptions import DataFileError
from adaptid.cli._app import app


@pytest.fixture(params=["csv", "parquet"])
def wide(tmp_path, request):
    rng = np.random.default_rng(0)
    df = pd.DataFrame(rng.standard_normal((50, 2000)), columns=[f"c{j}" for j in range(2000)])
    df["y"] = df["c3"] - 2 * df["c1999"] + 0.01 * rng.standard_normal(50)
    path = tmp_path / f"wide.{request.param}"
    (df.to_csv(path, index=False, float_format="%.17g") if request.param == "csv"
     else df.to_parquet(path))
    return path, df


def test_only_the_asked_columns_are_converted(wide):
    path, df = wide
    tb = io.read_table(path, columns=["y", "c3", "c1999", "nope"])
    assert tb.names == list(df.columns)                    # the whole header, for messages
    assert set(tb._get) == {"y", "c3", "c1999"}            # converted: only those used
    np.testing.assert_array_equal(tb.column("c1999", "--phi"), df["c1999"].to_numpy())
    with pytest.raises(DataFileError, match="no column 'nope'.*'c0'"):
        tb.column("nope", "--phi")


def test_duplicated_header_names_still_reported(tmp_path):
    path = tmp_path / "dup.csv"
    path.write_text("a,b,a\n1,2,3\n4,5,6\n")
    tb = io.read_table(path, columns=["a", "b"])
    with pytest.raises(DataFileError, match="'a'.*2 times"):
        tb.column("a", "--phi")
    np.testing.assert_array_equal(tb.column("b", "--y"), [2.0, 5.0])


def test_cli_on_a_wide_file_equals_the_narrow_file(wide, tmp_path):
    path, df = wide
    narrow = tmp_path / "narrow.csv"
    df[["c3", "c1999", "y"]].to_csv(narrow, index=False, float_format="%.17g")
    runner = CliRunner()
    args = ["--y", "y", "--phi", "c3,c1999", "--method", "batch", "--json"]
    a = runner.invoke(app, ["fit", str(path), *args])
    b = runner.invoke(app, ["fit", str(narrow), *args])
    assert a.exit_code == 0 and b.exit_code == 0, (a.output, b.output)
    import json

    ja, jb = json.loads(a.stdout), json.loads(b.stdout)
    assert ja["theta"] == jb["theta"] and ja["names"] == jb["names"]
