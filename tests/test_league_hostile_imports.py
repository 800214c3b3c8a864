"""Hostile population folders and submissions: an import passes the same gate as a submission
(paths inside the folder, artifacts read and validated, no squatted names adopted), the league's
own names are reserved, a refused or failed submission leaves no file behind, and `gc` removes
what no agent references."""

from __future__ import annotations

import json
import os
import pickle
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import gobang_agent, run
from sqlalchemy.exc import OperationalError

from arena_league import registry as reg
from arena_league.league import open_home
from arena_league.policies import Architecture, init_parameters
from arena_league.policies.artifacts import save_arena_policy

pytest_plugins = ["cli_helpers"]  # the home fixture
GAME = "GoBang-2T1P-v1"
ROOT = Path(__file__).resolve().parent.parent
SHIPPED = ROOT / "checkpoints" / GAME / "base-v1"
SHIPPED_AGENTS = sorted((SHIPPED / "agents").iterdir())
#: Address-space cap of the subprocess that imports a hostile folder (torch alone maps ~1-2 GiB).
MEMORY_LIMIT = 6 << 30




def population_folder(folder: Path, artifacts: list[str], *, copy: bool = True) -> Path:
    """A population folder of ``len(artifacts)`` members named hostile.m<i>@GAME; with ``copy``,
    member i's folder is a copy of a shipped member at ``agents/m<i>``."""
    folder.mkdir(parents=True)
    members = []
    for i, artifact in enumerate(artifacts):
        if copy:
            shutil.copytree(SHIPPED_AGENTS[i], folder / "agents" / f"m{i}")
        members.append({"name": f"hostile.m{i}@{GAME}", "kind": "base", "artifact": artifact,
                        "format": "arena-policy", "metadata": {"rating": 1000.0 + i}, "agent_metadata": {}})
    manifest = {"name": "hostile-v1", "version": 1, "game_id": GAME, "frozen": True, "members": members}
    (folder / "population.json").write_text(json.dumps(manifest))
    return folder


def store_files(home: Path) -> list[str]:
    """Every file in the artifact store and every entry of its .incoming area (empty two-letter
    prefix folders are not content and are not listed)."""
    root = home / "artifacts"
    if not root.exists():
        return []
    found = {p for p in root.rglob("*") if p.is_file()} | set((root / ".incoming").glob("*"))
    return sorted(p.relative_to(root).as_posix() for p in found)


def league_state(home: Path) -> dict:
    with open_home(home) as league, league.reading() as session:
        return {"agents": sorted(a.name for a in reg.list_agents(session)),
                "populations": [p.name for p in reg.list_populations(session)],
                "artifacts": sorted(a.sha256 for a in reg.list_artifacts(session))}


def assert_refused(capsys, home: Path, folder: Path, *words: str) -> None:
    before_files, before = store_files(home), league_state(home)
    code, doc, err = run(capsys, "population", "import", folder, "--json")
    assert code == 2, err
    for word in words:
        assert word in doc["error"], doc["error"]
    assert store_files(home) == before_files  # nothing stored, nothing left in .incoming
    assert league_state(home) == before  # nothing adopted, no population


def test_a_member_path_outside_the_folder_is_refused(capsys, home, tmp_path):
    secret = tmp_path / "secret"
    shutil.copytree(SHIPPED_AGENTS[5], secret)
    cases = {"absolute": ("/etc/passwd", "absolute path"),
             "dotdot": ("../x", "leads out of the folder"),
             "dotdot-inside": ("agents/../../secret", "leads out of the folder")}
    for label, (artifact, words) in cases.items():
        (tmp_path / "x").mkdir(exist_ok=True)
        folder = population_folder(tmp_path / label, ["agents/m0", artifact])
        assert_refused(capsys, home, folder, "hostile.m1", words)
    # a link inside the folder that leads out of it
    folder = population_folder(tmp_path / "link", ["agents/m0", "agents/escape"])
    (folder / "agents" / "escape").symlink_to(secret, target_is_directory=True)
    assert_refused(capsys, home, folder, "hostile.m1", "leads out of the folder")
    (folder / "agents" / "passwd").symlink_to("/etc/passwd")
    manifest = json.loads((folder / "population.json").read_text())
    manifest["members"][1]["artifact"] = "agents/passwd"
    (folder / "population.json").write_text(json.dumps(manifest))
    assert_refused(capsys, home, folder, "leads out of the folder")


def _import_in_a_limited_process(home: Path, folder: Path) -> subprocess.CompletedProcess:
    code = ("import resource, sys\n"
            f"resource.setrlimit(resource.RLIMIT_AS, ({MEMORY_LIMIT}, {MEMORY_LIMIT}))\n"
            "from arena_league.cli import main\n"
            f"sys.exit(main(['population', 'import', {str(folder)!r}, '--json']))\n")
    env = {**os.environ, "ARENA_LEAGUE_HOME": str(home)}
    env.pop("ARENA_LEAGUE_DB", None)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300,
                          cwd=ROOT, check=False)


def test_a_pickled_member_is_refused_unread_under_a_memory_limit(home, tmp_path):
    folder = population_folder(tmp_path / "pickle", ["agents/m0", "agents/evil.onnx"])
    (folder / "agents" / "evil.onnx").write_bytes(pickle.dumps({"weights": list(range(1000))}))
    manifest = json.loads((folder / "population.json").read_text())
    manifest["members"][1]["format"] = "onnx"
    (folder / "population.json").write_text(json.dumps(manifest))
    done = _import_in_a_limited_process(home, folder)
    assert done.returncode == 2, done.stderr
    error = json.loads(done.stdout)["error"]
    assert "hostile.m1" in error and "pickle" in error.lower() and "nothing was imported" in error.lower()
    assert store_files(home) == []
    assert league_state(home) == {"agents": [], "populations": [], "artifacts": []}


def test_a_member_that_does_not_play_the_game_is_refused(capsys, home, tmp_path):
    folder = population_folder(tmp_path / "wrong", ["agents/m0", "agents/m1"])
    shutil.rmtree(folder / "agents" / "m1")
    arch = Architecture("mlp", obs_dim=12, action_type="discrete", n_actions=5, hidden=(4,))
    save_arena_policy(folder / "agents" / "m1", arch, init_parameters(arch, 0), GAME, name="tiny")
    assert_refused(capsys, home, folder, "hostile.m1", "Nothing was imported")


def test_a_squatted_member_name_refuses_the_import_and_is_not_adopted(capsys, home, tmp_path, monkeypatch):
    # a member's name has the shape of the names people play under: no one may submit it now
    code, doc, _ = run(capsys, "submit", gobang_agent(tmp_path / "squat"), "--game", GAME,
                       "--name", f"hostile.m1@{GAME}", "--owner", "mallory", "--json")
    assert code == 2 and "reserved for the league" in doc["error"], doc
    # a league that took such a name before the rule still holds it: the import must not adopt it
    with monkeypatch.context() as before_the_rule:
        before_the_rule.setattr("arena_league.league.versions.check_submitted_name", lambda name: None)
        code, _, err = run(capsys, "submit", gobang_agent(tmp_path / "squat"), "--game", GAME,
                           "--name", f"hostile.m1@{GAME}", "--owner", "mallory")
    assert code == 0, err
    folder = population_folder(tmp_path / "pop", ["agents/m0", "agents/m1"])
    assert_refused(capsys, home, folder, f"hostile.m1@{GAME}", "different bytes", "mallory", "Rename the member")
    # the same bytes under the member's name are the same agent: reused
    clean = population_folder(tmp_path / "clean", ["agents/m0"])
    code, doc, err = run(capsys, "population", "import", clean, "--json")
    assert code == 0, err
    code, doc, err = run(capsys, "population", "import", population_folder(tmp_path / "again", ["agents/m0"]),
                         "--name", "hostile-v2", "--json")
    assert code == 0 and doc["imported"] == "hostile-v2:1", err


def test_reserved_names_cannot_be_submitted(capsys, home, tmp_path):
    agent = gobang_agent(tmp_path / "a")
    member = json.loads((SHIPPED / "population.json").read_text())["members"][0]["name"]
    for name in (f"random@{GAME}", f"heuristic@{GAME}", "random@Snake-2T2P-v1", member):
        code, doc, _ = run(capsys, "submit", agent, "--game", GAME, "--name", name, "--json")
        assert code == 2 and "reserved" in doc["error"] and "--name" in doc["error"], doc
    assert store_files(home) == []
    # the league itself still creates them
    code, doc, err = run(capsys, "population", "import", SHIPPED, "--json")
    assert code == 0 and doc["imported"] == "base-v1:1", err
    assert member in league_state(home)["agents"]


def test_a_submission_refused_for_a_taken_name_stores_nothing(capsys, home, tmp_path):
    code, _, err = run(capsys, "submit", gobang_agent(tmp_path / "a", seed=1), "--game", GAME, "--name", "alice")
    assert code == 0, err
    before = store_files(home)
    code, doc, _ = run(capsys, "submit", gobang_agent(tmp_path / "b", seed=2), "--game", GAME, "--name", "alice",
                       "--owner", "mallory", "--json")
    assert code == 2 and "alice belongs to another submitter" in doc["error"]
    (tmp_path / "empty.onnx").write_bytes(b"")
    code, doc, _ = run(capsys, "submit", tmp_path / "empty.onnx", "--game", GAME, "--name", "carol", "--json")
    assert code == 2 and "empty" in doc["error"]
    code, doc, _ = run(capsys, "submit", gobang_agent(tmp_path / "c", seed=3), "--game", GAME, "--name=-bad",
                       "--json")
    assert code == 2 and "does not start with a letter or digit" in doc["error"]
    assert store_files(home) == before


def _fail_insert(*args, **kwargs):
    raise OperationalError("INSERT INTO agents", {}, Exception("database or disk is full"))


@pytest.mark.parametrize("where", ["agent insert", "artifact insert", "disk full"])
def test_a_store_failure_mid_write_leaves_no_file(capsys, home, tmp_path, monkeypatch, where):
    code, _, err = run(capsys, "agents", "--json")  # create the league first
    assert code == 0, err
    if where == "agent insert":
        monkeypatch.setattr(reg, "create_agent", _fail_insert)
    elif where == "artifact insert":
        monkeypatch.setattr("arena_league.registry.artifacts.insert_ignoring_conflict", _fail_insert)
    else:
        def full(source, target, max_bytes):
            target.write_bytes(b"the first bytes")
            raise OSError(28, "No space left on device")
        monkeypatch.setattr("arena_league.registry.artifacts._copy_hashing", full)
    code, doc, _ = run(capsys, "submit", gobang_agent(tmp_path / "a"), "--game", GAME, "--name", "alice", "--json")
    assert code != 0 and doc["error"]
    assert store_files(home) == []
    assert league_state(home)["agents"] == [] and league_state(home)["artifacts"] == []


def test_gc_removes_unreferenced_artifacts_and_stale_incoming_files(capsys, home, tmp_path):
    code, _, err = run(capsys, "submit", gobang_agent(tmp_path / "a"), "--game", GAME, "--name", "alice")
    assert code == 0, err
    with open_home(home) as league, league.transaction() as session:
        orphan = reg.store_artifact(session, league.home, b"not referenced by any agent", "onnx")
        kept = reg.get_agent(session, "alice").artifact
    stale = home / "artifacts" / ".incoming" / "dead.part"
    stale.write_bytes(b"half a file")
    loose = home / "artifacts" / "ab" / ("ab" + "0" * 62 + ".onnx")
    loose.parent.mkdir(parents=True, exist_ok=True)
    loose.write_bytes(b"a file without a row")
    for folder in ("abandoned", "awaited"):  # web uploads: one no job waits for, one a queued validation does
        (home / "uploads" / folder).mkdir(parents=True)
        (home / "uploads" / folder / "model.onnx").write_bytes(b"staged")
    with open_home(home) as league, league.transaction() as session:
        reg.enqueue(session, "validate", {"game_id": GAME, "agent": "nobody", "upload": "uploads/awaited/model.onnx"})

    code, doc, err = run(capsys, "gc", "--min-age", "0", "--dry-run", "--json")
    assert code == 0 and doc["dry_run"], err
    listed = {e["path"] for e in doc["artifacts"]} | {e["path"] for e in doc["incoming"]}
    assert listed == {orphan.path, "artifacts/.incoming/dead.part", loose.relative_to(home).as_posix()}
    assert [e["path"] for e in doc["uploads"]] == ["uploads/abandoned"]
    assert stale.exists() and (home / orphan.path).exists()  # a dry run removes nothing

    code, doc, err = run(capsys, "gc", "--json")  # a fresh leftover may be a write under way: kept by default
    assert code == 0 and doc["incoming"] == [] and doc["artifacts"] == [] and stale.exists(), err
    code, _, err = run(capsys, "gc", "--min-age", "0")
    assert code == 0, err
    assert not stale.exists() and not loose.exists() and not (home / orphan.path).exists()
    assert (home / kept.path).exists()
    assert not (home / "uploads" / "abandoned").exists() and (home / "uploads" / "awaited").exists()
    state = league_state(home)
    assert state["artifacts"] == [kept.sha256] and state["agents"] == ["alice"]
    code, doc, _ = run(capsys, "gc", "--min-age", "0", "--json")
    assert doc["artifacts"] == [] and doc["incoming"] == [] and doc["uploads"] == [] and doc["previews"] == [] and doc["bytes"] == 0


def test_shipped_population_imports_through_the_gate_and_rank_works(capsys, home, tmp_path):
    code, doc, err = run(capsys, "population", "import", SHIPPED, "--json")
    assert code == 0 and doc["imported"] == "base-v1:1", err
    manifest = json.loads((SHIPPED / "population.json").read_text())
    with open_home(home) as league, league.reading() as session:
        population = reg.get_population(session, "base-v1", 1, game_id=GAME)
        ratings = {m.agent.name: m.meta["rating"] for m in population.members}
    assert ratings == {m["name"]: m["metadata"]["rating"] for m in manifest["members"]}  # frozen ratings kept
    code, doc, err = run(capsys, "population", "import", SHIPPED, "--json")  # idempotent
    assert code == 0 and doc["imported"] == "base-v1:1", err
    code, _, err = run(capsys, "submit", gobang_agent(tmp_path / "a"), "--game", GAME, "--name", "alice")
    assert code == 0, err
    # the imported base-v1, named (by default a league ranks against the newest shipped, base-v2)
    code, placed, err = run(capsys, "rank", "alice", "--budget", "20", "--population", "base-v1", "--json")
    assert code == 0 and placed["base"] == "base-v1:1" and placed["base_size"] == 100, err
