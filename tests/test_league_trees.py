"""Social trees as a league resource: the editor's catalog, checks with the library's messages,
bounds on hostile specs, saved trees owned like agents, and the verify and preview jobs."""

from __future__ import annotations

import copy

import pytest
import yaml

from arena_league.envs import make
from arena_league.envs.games.crossroads import CASE_STUDY_TREES
from arena_league.league import (
    ForbiddenError,
    Identity,
    NotFoundError,
    RateLimitedError,
    check_spec,
    collect_garbage,
    delete_saved_tree,
    job_rows,
    job_view,
    list_tree_views,
    open_home,
    preview_replay,
    queue_preview,
    queue_verify,
    save_tree,
    set_setting,
    tree_catalog,
    tree_text,
    tree_view,
)
from arena_league.league.schedules import run_worker
from arena_league.league.trees import MAX_SPEC_BYTES, MAX_TEXT

GAME = "Crossroads-2T2P-v1"
ALICE = Identity("alice", False)
BOB = Identity("bob", False)
ADMIN = Identity("root", True)


def test_the_catalog_offers_the_games_seats_schemes_rewards_and_the_case_study():
    catalog = tree_catalog(GAME)
    assert catalog["agents"] == ["player_0", "player_1", "player_2", "player_3"] and catalog["teams"] == [0, 0, 1, 1]
    assert [s["name"] for s in catalog["schemes"]] == ["NL", "IS", "CP", "CL", "CC"]
    assert {"ranking", "win_loss"} <= {f["name"] for f in catalog["rewards"]["CP"]}
    ranking = next(f for f in catalog["rewards"]["CP"] if f["name"] == "ranking")
    assert ranking["params"] == {"order": "depart", "tie_penalty": 0.0}
    assert set(catalog["examples"]) == {"all_IS", "all_CL", "CL_under_CP"}
    assert check_spec(GAME, catalog["default"])["ok"]
    # a game without a target measure offers no reward that needs one
    gobang = tree_catalog("GoBang-2T1P-v1")
    assert gobang["examples"] == {} and "target" not in {f["name"] for f in gobang["rewards"]["IS"]}


def test_checks_name_the_node_and_bound_hostile_specs():
    ok = check_spec(GAME, CASE_STUDY_TREES["CL_under_CP"])
    assert ok["ok"] and [n["path"] for n in ok["nodes"]] == ["root", "root/0", "root/1"]
    twice = copy.deepcopy(CASE_STUDY_TREES["CL_under_CP"])
    twice["children"][1]["children"][0] = "player_0"
    bad = check_spec(GAME, twice)
    assert not bad["ok"] and bad["path"] == "root/1/player_0" and "listed twice" in bad["error"]
    assert check_spec(GAME, {"scheme": "XX", "children": ["player_0"]})["path"] == "root"
    deep: dict = {"scheme": "NL", "reward": "none", "children": ["player_0"]}
    for _ in range(100):
        deep = {"scheme": "NL", "reward": "none", "children": [deep]}
    assert "too deep" in check_spec(GAME, deep)["error"]
    wide = {"scheme": "IS", "reward": "target", "children": [f"player_{i}" for i in range(4)] * 100}
    assert "too large" in check_spec(GAME, wide)["error"]
    board = {"scheme": "IS", "reward": "target", "board": 10**9, "children": [f"player_{i}" for i in range(4)]}
    assert "over the limit" in check_spec(GAME, board)["error"]
    assert not check_spec(GAME, ["player_0"])["ok"]


def test_saved_trees_are_owned_listed_and_read_back_by_make(tmp_path):
    with open_home(tmp_path / "home") as league:
        saved = save_tree(league, ALICE, "blocking", GAME, CASE_STUDY_TREES["CL_under_CP"])
        assert saved["owner"] == "alice" and yaml.safe_load(saved["yaml"]) == CASE_STUDY_TREES["CL_under_CP"]
        with pytest.raises(ValueError, match="tree name"):
            save_tree(league, ALICE, "../x", GAME, CASE_STUDY_TREES["all_IS"])
        with pytest.raises(ValueError, match="leaves out agent"):
            save_tree(league, ALICE, "broken", GAME, {"scheme": "IS", "reward": "target", "children": ["player_0"]})
        assert [t["name"] for t in list_tree_views(league, owner="alice")] == ["blocking"]
        for fmt in ("yaml", "json"):
            path = tmp_path / f"tree.{fmt}"
            path.write_text(tree_text(tree_view(league, saved["id"])["spec"], fmt))
            env = make(GAME, tree=str(path))
            assert [n["scheme"] for n in env.tree.describe()] == ["CP", "CL", "CL"]
        with pytest.raises(ForbiddenError):
            delete_saved_tree(league, BOB, saved["id"])
        assert delete_saved_tree(league, ADMIN, saved["id"]) == {"deleted": saved["id"]}
        with pytest.raises(NotFoundError):
            tree_view(league, saved["id"])


def test_verify_paints_the_blocking_tree_and_preview_records_a_match(tmp_path):
    with open_home(tmp_path / "home") as league:
        with pytest.raises(ValueError, match="samples"):
            queue_verify(league, GAME, CASE_STUDY_TREES["CL_under_CP"], samples=10**6)
        verify_job = queue_verify(league, GAME, CASE_STUDY_TREES["CL_under_CP"], samples=16)
        preview_job = queue_preview(league, GAME, CASE_STUDY_TREES["CL_under_CP"])
        with pytest.raises(NotFoundError, match="queued"):
            preview_replay(league, preview_job)
        assert run_worker(league, until_idle=True).completed == 2
        verified = job_view(league, verify_job)["result"]
        assert [(n["path"], n["declared"], n["verified"]) for n in verified["nodes"]] == [
            ("root", "CP", "CP"), ("root/0", "CL", "CL"), ("root/1", "CL", "CL")]
        preview = job_view(league, preview_job)["result"]
        assert preview["steps"] > 0 and len(preview["rewards"]) == 4
        # the teams share their rewards (CL), and the root's ranking sets them apart
        assert preview["rewards"][0] == preview["rewards"][1] and preview["rewards"][2] == preview["rewards"][3]
        document = preview_replay(league, preview_job)
        assert len(document["frames"]) == preview["steps"] + 1
        with pytest.raises(NotFoundError, match="no preview job"):
            preview_replay(league, verify_job)
        removed = collect_garbage(league, min_age_s=0)
        assert [e["path"] for e in removed["previews"]] == [f"previews/{preview_job}"]
        with pytest.raises(NotFoundError, match="gone"):
            preview_replay(league, preview_job)


def test_the_api_keeps_trees_behind_tokens(tmp_path):
    from fastapi.testclient import TestClient

    from arena_league.league import create_token
    from arena_league.web.app import create_app

    home = tmp_path / "home"
    with open_home(home) as league:
        alice = create_token(league, "alice")["token"]
        bob = create_token(league, "bob")["token"]
    with TestClient(create_app(home)) as client:
        body = {"game": GAME, "spec": CASE_STUDY_TREES["all_CL"], "name": "waiting"}
        assert client.post("/api/trees", json=body).status_code == 401
        saved = client.post("/api/trees", json=body, headers={"Authorization": f"Bearer {alice}"})
        assert saved.status_code == 201
        tree_id = saved.json()["id"]
        check = client.post("/api/trees/check", json={"game": GAME, "spec": {"scheme": "CL", "children": []}})
        assert check.status_code == 200 and check.json()["path"] == "root"
        assert client.post("/api/trees/check", json={"game": "Nope", "spec": {}}).status_code == 400
        download = client.get(f"/api/trees/{tree_id}/download?format=json")
        assert download.status_code == 200 and "attachment" in download.headers["content-disposition"]
        assert client.delete(f"/api/trees/{tree_id}", headers={"Authorization": f"Bearer {bob}"}).status_code == 403
        assert client.get("/trees").status_code == 200 and "waiting" in client.get("/trees").text
        assert client.get(f"/trees/{tree_id}").status_code == 200
        assert [t["id"] for t in client.get("/api/trees?limit=1").json()] == [tree_id]  # still a list
        assert client.get("/api/trees?limit=501").status_code == 422
        few = client.post("/api/trees/verify", json={"game": GAME, "spec": CASE_STUDY_TREES["all_CL"], "samples": 2},
                          headers={"Authorization": f"Bearer {alice}"})
        assert few.status_code == 422
        huge = b'{"game": "' + b"x" * (2 << 20) + b'", "spec": {}}'
        assert client.post("/api/trees/check", content=huge,
                           headers={"content-type": "application/json"}).status_code == 413


def test_a_spec_is_bounded_in_bytes_and_in_each_string():
    named = copy.deepcopy(CASE_STUDY_TREES["CL_under_CP"])
    named["name"] = "x" * 900_000
    huge = check_spec(GAME, named)
    assert not huge["ok"] and f"limit of {MAX_SPEC_BYTES}" in huge["error"] and "\n" not in huge["error"]
    named["name"] = "x" * (MAX_TEXT + 1)
    long = check_spec(GAME, named)
    assert not long["ok"] and f"limit of {MAX_TEXT}" in long["error"] and "node's name" in long["error"]
    keyed = copy.deepcopy(CASE_STUDY_TREES["CL_under_CP"])
    keyed["params"] = {"k" * 200: 1}
    assert f"limit of {MAX_TEXT}" in check_spec(GAME, keyed)["error"]
    named["name"] = "x" * MAX_TEXT
    assert check_spec(GAME, named)["ok"]
    assert tree_catalog(GAME)["limits"]["bytes"] == MAX_SPEC_BYTES


def test_an_owner_keeps_at_most_trees_per_owner_and_a_listing_is_one_page(tmp_path):
    with open_home(tmp_path / "home") as league:
        set_setting(league, "trees.per_owner", 3)
        for i in range(3):
            save_tree(league, ALICE, f"t{i}", GAME, CASE_STUDY_TREES["all_IS"])
        with pytest.raises(RateLimitedError, match="trees.per_owner") as refused:
            save_tree(league, ALICE, "t3", GAME, CASE_STUDY_TREES["all_IS"])
        assert "\n" not in str(refused.value)
        save_tree(league, BOB, "b0", GAME, CASE_STUDY_TREES["all_IS"])  # another owner's quota is their own
        for i in range(3):
            save_tree(league, ADMIN, f"r{i}", GAME, CASE_STUDY_TREES["all_IS"])  # administrators are not limited
        delete_saved_tree(league, ALICE, list_tree_views(league, owner="alice")[0]["id"])
        save_tree(league, ALICE, "t3", GAME, CASE_STUDY_TREES["all_IS"])  # room again once one is deleted
        assert [t["name"] for t in list_tree_views(league, limit=2)] == ["t3", "r2"]  # newest first
        assert len(list_tree_views(league)) == 7
        for wrong in (0, 501):
            with pytest.raises(ValueError, match="limit"):
                list_tree_views(league, limit=wrong)


def test_verify_refuses_fewer_than_four_samples_at_once(tmp_path):
    with open_home(tmp_path / "home") as league:
        for samples in (2, 3):
            with pytest.raises(ValueError, match="at least 4 paired samples") as refused:
                queue_verify(league, GAME, CASE_STUDY_TREES["CL_under_CP"], samples=samples, who=ALICE)
            assert "\n" not in str(refused.value)
        assert job_rows(league) == []  # nothing queued to fail later
