"""Base-population build end to end at size 8 on a tiny budget: the frozen folder (manifest, stacked
bundle, member folders), registration in a league (frozen, rated), resuming after an interruption
at every stage; and the selection rule on its own."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors.torch import load_file

from arena_league.league import open_home
from arena_league.league.population import build as build_module
from arena_league.league.population import round_robin as round_robin_module
from arena_league.league.population.build import BuildOptions, build_population, load_bundles
from arena_league.league.population.selection import behaviour_distances, select_spanning, target_order
from arena_league.league.service import base_population
from arena_league.registry import get_population

GAME = "GoBang-2T1P-v1"
SCHEMES = ["sp", "pbt", "dppo"]
TINY = {"num_envs": 4, "num_steps": 32}
OPTIONS = {"sp": TINY, "pbt": {**TINY, "population_size": 2}, "dppo": TINY}


def build(work, out, **kwargs):
    return build_population(GAME, size=8, name="base-t", schemes=SCHEMES, steps_per_scheme=384, snapshots=3,
                            seed=0, work_dir=work, out_dir=out, scheme_options=OPTIONS, verify_matches=20,
                            bootstrap_rounds=20, **kwargs)


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """The training stage alone, run once for the module: 3 snapshots per learner."""
    work = tmp_path_factory.mktemp("work")
    report = build(work, work / "unused", stop_after="train")
    return work, report


def test_training_stage_trains_every_scheme_and_stops(trained):
    work, report = trained
    assert report.stage == "train" and report.trained == SCHEMES and report.reused_runs == []
    assert all((work / "runs" / f"{s}-seed0" / "run.json").exists() for s in SCHEMES)
    assert not (work / "matches").exists()


def test_build_resumes_freezes_and_registers_frozen(trained, tmp_path, monkeypatch):
    work, _ = trained
    finished = {s: (work / "runs" / f"{s}-seed0" / "run.json").stat().st_mtime_ns for s in SCHEMES}
    monkeypatch.setattr(round_robin_module, "CHUNK_MATCHES", 64)
    out = tmp_path / "checkpoints" / GAME / "base-t"
    league = open_home(tmp_path / "league")

    # interrupted in the middle of the round robin ...
    def interrupt(stage, done, total):
        if stage == "round_robin" and done >= 128:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        build(work, out, league=league, progress=interrupt)
    # ... then started again: no scheme retrains, saved matches are read back, the rest is played
    report = build(work, out, league=league)
    assert report.trained == [] and report.reused_runs == SCHEMES
    assert {s: (work / "runs" / f"{s}-seed0" / "run.json").stat().st_mtime_ns for s in SCHEMES} == finished
    n_agents = report.candidates + 2
    round_robin = n_agents * (n_agents - 1)  # two matches per pair
    assert report.matches_reused == 128
    assert report.matches_played == round_robin - 128 + 40  # the rest, best vs worst and vs the heuristic
    assert report.stage == "register" and report.population == "base-t:1"

    # the manifest: members with provenance and rating intervals, the population's figures
    manifest = json.loads((out / "population.json").read_text())
    assert manifest["name"] == "base-t" and manifest["game_id"] == GAME and manifest["frozen"]
    members = manifest["members"]
    assert len(members) == 8 and len({m["name"] for m in members}) == 8
    for m in members:
        meta = m["metadata"]
        assert meta["scheme"] in SCHEMES and meta["steps"] > 0 and meta["seed"] == 0
        assert meta["rating_lower"] <= meta["rating"] <= meta["rating_upper"]
        assert (out / m["artifact"] / "manifest.json").exists()
    ratings = [m["metadata"]["rating"] for m in members]
    assert ratings == sorted(ratings)  # weakest first
    figures = manifest["provenance"]["figures"]
    assert figures["spread"] == pytest.approx(ratings[-1] - ratings[0], abs=0.2)
    assert figures["best_vs_worst_matches"] == 20 and 0 <= figures["best_vs_worst_win_rate"] <= 1
    assert figures["best_vs_heuristic_matches"] == 20 and 0 <= figures["best_vs_heuristic_win_rate"] <= 1
    assert 1 <= figures["random_rank"] <= 9 and sum(figures["schemes"].values()) == 8
    assert set(manifest["provenance"]["criteria"]) == set(build_module.CRITERIA)
    assert "Bradley-Terry spread" in (out / "README.md").read_text()

    # the stacked bundle holds every member's weights as [P, ...] tensors, equal to its own folder
    (bundle,) = manifest["bundles"]
    tensors = load_file(str(out / bundle["file"]))
    assert all(t.shape[0] == 8 for t in tensors.values())
    (stacked,) = load_bundles(out)
    assert list(stacked.member_names) == bundle["members"] == [m["name"] for m in members]
    for m in members:
        own = load_file(str(out / m["artifact"] / "weights.safetensors"))
        for name, tensor in own.items():
            assert torch.equal(tensors[name][m["bundle_index"]], tensor)

    # registered frozen, with the members' ratings the league ranks entrants against
    with league.reading() as session:
        population = get_population(session, "base-t")
        assert population.frozen and len(population.members) == 8
    label, names, base_ratings = base_population(league, GAME, "someone", "base-t")
    assert label == "base-t:1" and sorted(names) == sorted(m["name"] for m in members)
    assert sorted(base_ratings.tolist()) == ratings

    # a finished build asked again reuses everything and registers nothing twice
    again = build(work, out, league=league)
    assert again.matches_played == 0 and again.population == "base-t:1"
    assert again.members == report.members


def test_a_second_population_keeps_the_first_and_adds_search_agents(trained, tmp_path, monkeypatch):
    """base-v2 from base-v1's members and built-in search agents: nothing trained, the members rated
    again, the search members frozen without artifacts, imported as scripted agents; the newest
    shipped population becomes the game's default base."""
    from arena_league.league import population_index, populations

    work, _ = trained
    shipped = tmp_path / "checkpoints" / GAME
    first = build(work, shipped / "base-t1").out_dir
    ladder = ["search-w2-r1-h4", "search-w4-r2-h8-e0.2"]
    top = [{"scheme": "sp", "steps": 128, **TINY, "fixed_opponents": ["scripted:heuristic"], "fixed_share": 1.0}]
    second = build_population(GAME, size=8, name="base-t2", schemes=[], base=first, scripted=ladder, top_runs=top,
                              seed=0, snapshots=1, work_dir=tmp_path / "work2", out_dir=shipped / "base-t2",
                              verify_matches=20, bootstrap_rounds=20)
    assert second.trained == ["sp-seed1000"] and second.candidates == 8 + 2 + 1  # the top run's one snapshot
    manifest = json.loads((shipped / "base-t2" / "population.json").read_text())
    build_record = manifest["provenance"]["build"]
    assert build_record["base"]["name"] == "base-t" and build_record["scripted"] == ladder
    assert build_record["top_runs"] == top and "top_runs=" in (shipped / "base-t2" / "README.md").read_text()
    kept = {m["name"].split(".", 1)[1] for m in json.loads((shipped / "base-t1" / "population.json").read_text())
            ["members"]}
    scripted = [m for m in manifest["members"] if m["kind"] == "scripted"]
    assert {m["agent_metadata"]["scripted"] for m in scripted} <= set(ladder)
    assert all(m["artifact"] is None and m["metadata"]["scheme"] == "search" for m in scripted)
    assert {m["name"].split(".", 1)[1] for m in manifest["members"] if m["kind"] != "scripted"} <= \
        kept | {"sp-s1000-sp-128@" + GAME}
    assert sum(len(p.member_names) for p in load_bundles(shipped / "base-t2")) + len(scripted) == 8
    readme = (shipped / "base-t2" / "README.md").read_text()
    assert "the 8 members of `base-t`" in readme and "best member vs the heuristic" in readme
    for m in manifest["members"]:  # every member loads, learned or built in
        assert build_module.member_policy(shipped / "base-t2", m, GAME) is not None

    # shipped beside base-t1, base-t2 is the newest: a fresh league ranks against it by default,
    # its search members registered as scripted agents
    population_index.write_index(tmp_path / "checkpoints", tmp_path / "population_index.json")
    monkeypatch.setattr(population_index, "INDEX_PATH", tmp_path / "population_index.json")
    monkeypatch.setattr(population_index, "CHECKOUT_POPULATIONS", tmp_path / "checkpoints")
    assert populations.shipped_populations(GAME) == ["base-t1", "base-t2"]
    assert populations.shipped_population(GAME) == shipped / "base-t2"
    league = open_home(tmp_path / "league")
    assert populations.game_population(league, GAME) == "base-t2:1"
    label, names, _ = base_population(league, GAME, "someone")
    assert label == "base-t2:1" and len(names) == 8
    with league.reading() as session:
        population = get_population(session, "base-t2")
        kinds = {m.agent.name: m.agent.kind for m in population.members}
    assert sorted(n for n, k in kinds.items() if k == "scripted") == sorted(m["name"] for m in scripted)


def test_tuned_heuristics_join_a_build_as_their_own_scheme(tmp_path):
    """Built-in tuned heuristics (PushBox's heuristic with other constants) join the candidates
    with scheme ``tuned``, frozen with their options instead of a budget, named in the README."""
    game = "PushBox-2T2P-v1"
    tuned = ["heuristic-lane0.6", "heuristic-lane0.6-side0.3", "heuristic-side0.3"]
    report = build_population(game, size=3, name="base-tuned", schemes=[], scripted=tuned, top_runs=[], seed=0,
                              matches_per_pair=1, work_dir=tmp_path / "w", out_dir=tmp_path / "out",
                              verify_matches=4, bootstrap_rounds=10)
    assert report.candidates == 3 and report.trained == []
    manifest = json.loads((tmp_path / "out" / "population.json").read_text())
    assert {m["metadata"]["scheme"] for m in manifest["members"]} == {build_module.TUNED_SCHEME}
    options = {m["agent_metadata"]["scripted"]: m["metadata"]["budget"] for m in manifest["members"]}
    assert options["heuristic-lane0.6-side0.3"] == {"options": {"lane": 0.6, "side": 0.3}}
    readme = (tmp_path / "out" / "README.md").read_text()
    assert "3 tuned heuristics, the game's heuristic with other constants (scheme `tuned`" in readme
    assert "lane L: an ant pushes within L m of its push line" in readme
    assert "3 tuned heuristics above them" in readme
    for m in manifest["members"]:
        assert build_module.member_policy(tmp_path / "out", m, game).name == m["agent_metadata"]["scripted"]


def test_a_later_population_retires_superseded_members_of_its_base(trained, tmp_path):
    """retire leaves named base members out of the candidates (a search agent its next version
    supersedes); the provenance, the README and the rebuild line name them; a key the base lacks is
    refused before anything is played."""
    work, _ = trained
    first = build(work, tmp_path / "base-t1").out_dir
    manifest = json.loads((Path(first) / "population.json").read_text())
    keys = [m["name"].split(".", 1)[1].rsplit("@", 1)[0] for m in manifest["members"]]
    kwargs = {"size": 8, "schemes": [], "base": first, "seed": 0, "work_dir": tmp_path / "work2",
              "verify_matches": 20, "bootstrap_rounds": 20, "top_runs": []}
    with pytest.raises(ValueError, match=r"retire names 'search-w9-r1-h4', not a member of base .*\(e.g. '"):
        build_population(GAME, name="base-t2", retire=["search-w9-r1-h4"], **kwargs)
    with pytest.raises(ValueError, match="retire names a member twice"):
        build_population(GAME, name="base-t2", retire=keys[:1] * 2, **kwargs)
    with pytest.raises(ValueError, match="give the base too"):
        build_population(GAME, name="base-t2", retire=keys[:1], **{**kwargs, "base": None,
                                                                   "scripted": ["search-w2-r1-h4"]})
    assert not (tmp_path / "work2").exists() and not (tmp_path / "base-t2").exists()

    second = build_population(GAME, name="base-t2", retire=keys[:2], scripted=["search-w2-r1-h4", "search-w4-r1-h4"],
                              out_dir=tmp_path / "base-t2", **kwargs)
    assert second.candidates == 8 - 2 + 2
    assert not {m.key for m in second.members} & set(keys[:2])
    record = json.loads((tmp_path / "base-t2" / "population.json").read_text())["provenance"]["build"]["base"]
    assert record["retired"] == sorted(keys[:2]) and record["members"] == 6
    readme = (tmp_path / "base-t2" / "README.md").read_text()
    assert "the 6 members of `base-t`" in readme and f"2 retired: `{min(keys[:2])}`" in readme
    assert f"retire={sorted(keys[:2])!r}" in readme


def _weights(run_dir: Path) -> dict[str, bytes]:
    return {str(f.relative_to(run_dir)): f.read_bytes() for f in sorted(run_dir.rglob("*.safetensors"))}


def test_side_by_side_processes_train_the_same_runs_and_play_the_same_matches(trained, tmp_path, monkeypatch):
    """processes=2 trains the runs and plays the round robin's chunks in worker processes: every
    snapshot's weights and every chunk's scores equal those of one process."""
    import shutil

    work, _ = trained
    side = tmp_path / "side"
    lines = []
    report = build(side, tmp_path / "unused", stop_after="train", processes=2, log=lines.append)
    assert report.trained == SCHEMES and report.reused_runs == []
    assert any("in 2 processes" in line for line in lines)
    for scheme in SCHEMES:
        assert _weights(side / "runs" / f"{scheme}-seed0") == _weights(work / "runs" / f"{scheme}-seed0") != {}

    monkeypatch.setattr(round_robin_module, "CHUNK_MATCHES", 64)
    scores = {}
    for processes in (1, 2):
        folder = tmp_path / f"robin{processes}"
        shutil.copytree(work / "runs", folder / "runs")
        reused = 0
        if processes == 2:  # interrupted after its first chunk: the workers end, the chunk stays

            def interrupt(stage, done, total):
                if stage == "round_robin":
                    raise KeyboardInterrupt

            with pytest.raises(KeyboardInterrupt):
                build(folder, tmp_path / "unused", stop_after="round_robin", processes=processes, progress=interrupt)
            assert len(list((folder / "matches").glob("*/chunk-*.json"))) == 1
            reused = 64
        report = build(folder, tmp_path / "unused", stop_after="round_robin", processes=processes)
        assert report.matches_played > 128 and report.matches_reused == reused
        (digest,) = (folder / "matches").iterdir()
        scores[processes] = {f.name: json.loads(f.read_text()) for f in sorted(digest.glob("chunk-*.json"))}
    assert len(scores[1]) > 2 and scores[2] == scores[1]


def test_the_backend_is_local_or_ray_and_an_address_is_for_ray(tmp_path):
    with pytest.raises(ValueError, match="backend must be one of local, ray, not 'spark'"):
        build(tmp_path / "w", tmp_path / "o", backend="spark")
    with pytest.raises(ValueError, match="add --backend ray"):
        build(tmp_path / "w", tmp_path / "o", ray_address="127.0.0.1:6379")


def test_processes_must_be_a_positive_whole_number(tmp_path):
    for processes in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="processes must be a whole number"):
            build(tmp_path / "w", tmp_path / "o", processes=processes)
    assert not (tmp_path / "w").exists()


def test_options_are_one_dataclass_and_keywords_are_its_fields(tmp_path):
    """``build_population`` takes a BuildOptions; keywords change its fields, and a keyword that is
    no field is refused with the fields there are."""
    options = BuildOptions(size=8, seed=3, work_dir=tmp_path / "w")
    assert options.replaced({"seed": 4}) == BuildOptions(size=8, seed=4, work_dir=tmp_path / "w")
    with pytest.raises(TypeError, match="BuildOptions has no sizes; its fields are .*size"):
        build_population(GAME, options, sizes=9)
    with pytest.raises(ValueError, match="at least 2 members, not 1"):
        build_population(GAME, options, size=1)
    assert not (tmp_path / "w").exists()


def test_out_dir_of_another_build_is_not_overwritten(trained, tmp_path):
    work, _ = trained
    out = tmp_path / "base"
    out.mkdir()
    (out / "population.json").write_text(json.dumps({"provenance": {"build": {"build_id": "other"}}}))
    with pytest.raises(ValueError, match="overwrite=True"):
        build(work, out)


def test_selection_spans_the_range_above_the_floor():
    rng = np.random.default_rng(0)
    ratings = np.concatenate([rng.uniform(0, 100, 50), rng.uniform(100, 1000, 30)])
    behaviour = rng.normal(size=(80, 5))
    chosen = select_spanning(ratings, behaviour, 10, floor=100.0)
    assert len(set(chosen.tolist())) == 10 and (ratings[chosen] > 100).all()
    picked = np.sort(ratings[chosen])
    eligible = ratings[ratings > 100]
    assert picked[0] == eligible.min() and picked[-1] == eligible.max()
    # evenly spread: no gap much wider than the candidates' own gaps force
    assert np.diff(picked).max() < 3 * (eligible.max() - eligible.min()) / 9


def test_selection_prefers_different_behaviour_among_equals():
    # candidates 1 and 2 are rated alike; 2 behaves like the already chosen 0, 1 does not
    ratings = np.array([0.0, 500.0, 500.0, 1000.0])
    behaviour = np.array([[0.0, 0.0], [5.0, 5.0], [0.1, 0.0], [5.0, -5.0]])
    assert select_spanning(ratings, behaviour, 3, pool=2).tolist() == [0, 1, 3]


def test_selection_fills_below_the_floor_when_short_and_orders_targets():
    ratings = np.array([10.0, 20.0, 30.0, 300.0])
    assert select_spanning(ratings, np.zeros((4, 1)), 3, floor=100.0).tolist() == [1, 2, 3]
    assert target_order(5).tolist() == [0, 4, 2, 1, 3]
    d = behaviour_distances(np.array([[0.0, np.nan], [3.0, 4.0]]))
    assert d[0, 1] == pytest.approx(3.0) and d[1, 1] == 0.0


def test_bad_budgets_are_refused_before_training(tmp_path):
    with pytest.raises(ValueError, match="runs_per_scheme names cf"):
        build(tmp_path / "w", tmp_path / "o", runs_per_scheme={"cf": 2})
    with pytest.raises(ValueError, match="no budget for pbt"):
        build_population(GAME, schemes=SCHEMES, steps_per_scheme={"sp": 10, "dppo": 10}, work_dir=tmp_path / "w")
    with pytest.raises(ValueError, match="base populations are rated by two-team matches"):
        build_population("Snake-4T1P-v1", work_dir=tmp_path / "w")
    assert not (tmp_path / "w" / "runs").exists()


def test_recipe_gives_one_scheme_its_own_budget(tmp_path, monkeypatch):
    """A recipe's ``scheme_steps`` trains that scheme's runs from scratch for longer (Soccer's
    self-play against random needs a million steps); the others keep ``steps``."""
    import dataclasses

    recipe = dataclasses.replace(build_module.RECIPES["GoBang"], steps=256, snapshots=2,
                                 scheme_steps={"sp": 512})
    monkeypatch.setitem(build_module.RECIPES, "GoBang", recipe)
    report = build_population(GAME, size=8, name="base-t", schemes=SCHEMES, seed=0, work_dir=tmp_path / "w",
                              out_dir=tmp_path / "o", scheme_options=OPTIONS, stop_after="train")
    assert report.steps_per_scheme == {"sp": 512, "pbt": 256, "dppo": 256}
    run = json.loads((tmp_path / "w" / "runs" / "sp-seed0" / "run.json").read_text())
    assert run["request"]["steps"] == 512
    assert json.loads((tmp_path / "w" / "runs" / "dppo-seed0" / "run.json").read_text())["request"]["steps"] == 256


def test_warm_started_runs_join_the_build_with_their_provenance(tmp_path):
    """A warm-started run (DAgger on the heuristic, then RL) follows the runs from scratch: its seed
    comes after theirs, its members' keys read ``<scheme>-ws-...`` and population.json, the
    members' manifests and the README say what they imitated."""
    imitation = {"steps": 400, "rounds": 2, "epochs": 1, "num_envs": 4}
    report = build_population(GAME, size=6, name="base-w", schemes=["sp"], steps_per_scheme=256, snapshots=2,
                              seed=0, work_dir=tmp_path / "w", out_dir=tmp_path / "o", scheme_options={"sp": TINY},
                              warm_runs_per_scheme=1, warm_start=imitation, verify_matches=10,
                              bootstrap_rounds=10)
    assert report.trained == ["sp", "sp-seed1"]
    run = json.loads((tmp_path / "w" / "runs" / "sp-seed1" / "run.json").read_text())
    assert run["request"]["warm_start"]["steps"] == 400
    assert "warm_start" not in json.loads((tmp_path / "w" / "runs" / "sp-seed0" / "run.json").read_text())["request"]
    manifest = json.loads((tmp_path / "o" / "population.json").read_text())
    assert manifest["provenance"]["build"]["warm_runs"]["warm_start"] == imitation
    warm = [m for m in manifest["members"] if m["metadata"]["warm_start"]]
    cold = [m for m in manifest["members"] if not m["metadata"]["warm_start"]]
    assert all(".sp-ws-s1-" in m["name"] and m["metadata"]["seed"] == 1 for m in warm)
    assert all(".sp-s0-" in m["name"] for m in cold)
    assert warm and cold
    member = json.loads((tmp_path / "o" / warm[0]["artifact"] / "manifest.json").read_text())
    assert member["provenance"]["warm_start"] == "scripted:heuristic"
    readme = (tmp_path / "o" / "README.md").read_text()
    assert "warm-started runs" in readme and "DAgger" in readme and "warm_runs_per_scheme={'sp': 1}" in readme


def test_a_ladder_of_warm_starts_gives_each_warm_run_its_own(tmp_path):
    """``warm_start`` as a list: the r-th warm-started run of a scheme imitates with entry r (a
    ladder from clumsy to faithful copies), cycling when there are more runs than entries."""
    ladder = [{"steps": 400, "rounds": 2, "epochs": 1, "num_envs": 4}, {"steps": 64, "rounds": 1, "epochs": 1,
                                                                         "num_envs": 4}]
    report = build_population(GAME, size=6, name="base-w", schemes=["sp"], steps_per_scheme=128, snapshots=1,
                              seed=0, work_dir=tmp_path / "w", out_dir=tmp_path / "o", scheme_options={"sp": TINY},
                              warm_runs_per_scheme=3, warm_start=ladder, stop_after="train")
    assert report.trained == ["sp", "sp-seed1", "sp-seed2", "sp-seed3"]
    log = (tmp_path / "w" / "train-sp.log").read_text().splitlines()  # each line names its run (runs/sp-seedN)
    assert log and {line.split(":")[0] for line in log} == {"seed 0", "seed 1", "seed 2", "seed 3"}
    taken = [json.loads((tmp_path / "w" / "runs" / f"sp-seed{k}" / "run.json").read_text())["request"]["warm_start"]
             for k in (1, 2, 3)]
    assert [(w["steps"], w["rounds"]) for w in taken] == [(400, 2), (64, 1), (400, 2)]


@pytest.mark.parametrize("top, error, words", [
    ([{"scheme": "sp"}], ValueError, "positive number of steps"),
    ([{"scheme": "nope", "steps": 10}], ValueError, "needs a scheme"),
    ([{"scheme": "sp", "steps": 10, "warm_start": {"stepz": 5}}], TypeError, "stepz"),
    ([{"scheme": "sp", "steps": 10, "fixed_opponent": ["scripted:heuristic"]}], TypeError,
     "sp: unknown option.*fixed_opponent"),
    ([{"scheme": "sp", "steps": 10, "max_cycles": -3}], ValueError, "max_cycles"),
    ([{"scheme": "sp", "steps": 10, "warm_start": {"steps": 5}, "family": "gru"}], ValueError, "feed-forward"),
])
def test_bad_top_runs_are_refused_before_training(tmp_path, top, error, words):
    with pytest.raises(error, match=words):
        build(tmp_path / "w", tmp_path / "o", top_runs=top)
    assert not (tmp_path / "w" / "runs").exists()


def test_a_bad_option_of_the_last_scheme_is_refused_before_the_first_trains(tmp_path):
    options = {**OPTIONS, SCHEMES[-1]: {**OPTIONS.get(SCHEMES[-1], {}), "learnin_rate": 1e-3}}
    with pytest.raises(TypeError, match=f"{SCHEMES[-1]}: unknown option.*learnin_rate"):
        build_population(GAME, size=8, name="base-t", schemes=SCHEMES, steps_per_scheme=384, snapshots=3, seed=0,
                         work_dir=tmp_path / "w", out_dir=tmp_path / "o", scheme_options=options)
    assert not (tmp_path / "w" / "runs").exists()


def test_bad_warm_start_is_refused_before_training(tmp_path):
    with pytest.raises(TypeError, match="unknown warm_start field.*rouns"):
        build(tmp_path / "w", tmp_path / "o", warm_runs_per_scheme=1, warm_start={"rouns": 2})
    with pytest.raises(TypeError, match="unknown warm_start field.*rouns"):
        build(tmp_path / "w", tmp_path / "o", warm_runs_per_scheme=2, warm_start=[{"steps": 64}, {"rouns": 2}])
    with pytest.raises(TypeError, match="a non-empty list of them"):
        build(tmp_path / "w", tmp_path / "o", warm_runs_per_scheme=1, warm_start=[])
    with pytest.raises(ValueError, match="warm_runs_per_scheme must be a number of runs >= 0"):
        build(tmp_path / "w", tmp_path / "o", warm_runs_per_scheme=-1)
    assert not (tmp_path / "w" / "runs").exists()
