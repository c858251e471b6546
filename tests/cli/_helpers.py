"""What the CLI test files share: run ``adaptid`` in-process and read its JSON."""

import json

from typer.testing import CliRunner

from adaptid.cli._app import app


def invoke(*args):
    """``adaptid ARGS`` through typer's runner (arguments made strings)."""
    return CliRunner().invoke(app, [str(a) for a in args])


run = invoke


def run_json(*args):
    """``adaptid ARGS --json``: exit status 0 asserted, the JSON document returned."""
    r = invoke(*args, "--json")
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)
