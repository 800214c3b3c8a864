"""``population build`` makes the recorded population: a small Crossroads build (8 members out of 16
trained snapshots, a warm-started run among them) gives the very members, ratings, intervals,
figures and provenance recorded in ``tests/data`` (first by the commit before the build was cut
into stages; re-recorded when training's numbers changed on purpose, as its ``about`` says)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import run

pytest_plugins = ["cli_helpers"]  # the home fixture

RECORDED = Path(__file__).parent / "data" / "population_build_crossroads_size8.json"


@pytest.mark.slow
def test_a_small_crossroads_build_gives_the_recorded_population(capsys, home, tmp_path):
    recorded = json.loads(RECORDED.read_text())
    out = tmp_path / "out"
    code, report, err = run(capsys, *recorded["argv"], "--work-dir", tmp_path / "work", "--out-dir", out, "--json")
    assert code == 0, err
    built = json.loads((out / "population.json").read_text())
    assert built["provenance"]["build"].pop("code")  # the code version is the one field that may differ
    expected = recorded["population"]
    got = {m["name"]: m["metadata"]["rating"] for m in built["members"]}
    assert got == {m["name"]: m["metadata"]["rating"] for m in expected["members"]}
    assert built == expected
    assert report["stage"] == "register" and {m["name"] for m in report["members"]} == set(got)
