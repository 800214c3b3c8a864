"""The paper's Crossroads case study: the default tree and the three social variants verify as
declared, from the command line and the library."""

from __future__ import annotations

import json

import pytest

from arena_league.cli import main
from arena_league.envs.games.crossroads import CASE_STUDY_TREES
from arena_league.envs.social.verify import verify


def test_cli_verify_classifies_every_node_as_declared(capsys):
    assert main(["verify", "Crossroads-2T2P-v1", "--samples", "32", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["ok"]
    assert [(n["path"], n["verified"]) for n in report["nodes"]] == [
        ("root", "CP"), ("root/0", "NL"), ("root/0/player_0", "IS"), ("root/0/player_1", "IS"),
        ("root/1", "NL"), ("root/1/player_2", "IS"), ("root/1/player_3", "IS")]


@pytest.mark.parametrize("variant, expected", [
    ("all_IS", [("root", "IS")]),
    ("all_CL", [("root", "CL")]),
    ("CL_under_CP", [("root", "CP"), ("root/0", "CL"), ("root/1", "CL")]),
])
def test_case_study_variants_verify(variant, expected):
    report = verify("Crossroads-2T2P-v1", tree=CASE_STUDY_TREES[variant], samples=32)
    assert [(n.path, n.verified) for n in report.nodes] == expected
    assert report.ok


def test_cli_refuses_a_tree_file_needing_a_measure_the_game_lacks(tmp_path, capsys):
    tree = {"scheme": "CC", "reward": "team_progress_race", "children": [
        {"scheme": "CL", "reward": "team_target", "children": ["player_0", "player_1"]},
        {"scheme": "CL", "reward": "team_target", "children": ["player_2", "player_3"]}]}
    path = tmp_path / "tree.json"
    path.write_text(json.dumps(tree))
    code = main(["verify", "Crossroads-2T2P-v1", "--tree", str(path), "--samples", "16", "--json"])
    out = capsys.readouterr().out
    assert code == 2 and "object_progress" in out  # Crossroads has no shared object: refused with the fix
