"""Shipped base populations as data: the package's index agrees with checkpoints/, a population is
pulled from a mirror served over real HTTP (checked file by file, placed whole or not at all), a
folder that disagrees with the index is refused before import, and a population that is not on this
machine is named with the pull that fetches it, never replaced silently."""

from __future__ import annotations

import functools
import hashlib
import http.server
import json
import shutil
import threading
from pathlib import Path

import numpy as np
import pytest

from arena_league.cli import main
from arena_league.league import population_index
from arena_league.league.populations import shipped_member_names

GAME = "Crossroads-2T2P-v1"
NAME = "tiny-v1"
#: Bigger than one streamed chunk, so a file arrives in several reads.
BLOB_BYTES = population_index.CHUNK + 12_345


def _tiny_population(folder: Path) -> None:
    """Two scripted members (validated in no time) and a file big enough to stream in chunks."""
    members = [{"name": f"{NAME}.{agent}@{GAME}", "kind": "scripted", "artifact": None, "format": "scripted",
                "metadata": {"rating": rating, "rating_lower": rating - 50, "rating_upper": rating + 50},
                "agent_metadata": {"scripted": agent}}
               for agent, rating in (("random", 800.0), ("heuristic", 1200.0))]
    (folder / "agents").mkdir(parents=True)
    (folder / "population.json").write_text(json.dumps({"name": NAME, "version": 1, "game_id": GAME, "frozen": True,
                                                        "provenance": {}, "members": members}))
    (folder / "README.md").write_text("# tiny-v1\n\nTwo scripted members.\n")
    (folder / "agents" / "blob.bin").write_bytes(np.random.default_rng(0).bytes(BLOB_BYTES))


@pytest.fixture
def mirror(tmp_path, monkeypatch):
    """A mirror (a copy of checkpoints/ holding one tiny population), the package's index naming
    only it, no checkout populations, an empty cache and a fresh league."""
    root = tmp_path / "mirror"
    _tiny_population(root / GAME / NAME)
    index = tmp_path / "population_index.json"
    population_index.write_index(root, index)
    monkeypatch.setattr(population_index, "INDEX_PATH", index)
    monkeypatch.setattr(population_index, "CHECKOUT_POPULATIONS", tmp_path / "no-checkout")
    monkeypatch.setenv("ARENA_LEAGUE_POPULATIONS", str(tmp_path / "cache"))
    monkeypatch.setenv("ARENA_LEAGUE_HOME", str(tmp_path / "home"))
    monkeypatch.delenv("ARENA_LEAGUE_POPULATION_MIRROR", raising=False)
    monkeypatch.delenv("ARENA_LEAGUE_DB", raising=False)
    return root


class _BreakingHandler(http.server.SimpleHTTPRequestHandler):
    """Serves the folder, but sends only half of ``blob.bin`` (announcing all of it) and hangs up."""

    def log_message(self, format, *args):  # keep the test output quiet
        pass

    def do_GET(self):
        if not self.path.endswith("blob.bin") or not getattr(self.server, "breaking", False):
            return super().do_GET()
        self.send_response(200)
        self.send_header("Content-Length", str(BLOB_BYTES))
        self.end_headers()
        self.wfile.write(b"x" * (BLOB_BYTES // 2))
        self.wfile.flush()
        self.close_connection = True
        return None


@pytest.fixture
def server(mirror):
    """The mirror over HTTP on 127.0.0.1 (an ephemeral port); ``server.breaking = True`` cuts a transfer."""
    handler = functools.partial(_BreakingHandler, directory=str(mirror))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    httpd.url = f"http://127.0.0.1:{httpd.server_address[1]}/"
    yield httpd
    httpd.shutdown()
    httpd.server_close()
    thread.join()


def cli(capsys, *argv) -> tuple[int, dict, str, str]:
    """The command's exit code, its JSON document (or {}), its stdout and its stderr."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, json.loads(out) if out.startswith("{") else {}, out, err


def _cache_entries(tmp_path: Path) -> list[str]:
    cache = tmp_path / "cache"
    return sorted(p.relative_to(cache).as_posix() for p in cache.rglob("*")) if cache.exists() else []


def test_the_committed_index_agrees_with_checkpoints():
    """The index the package carries is the one ``population index --write`` makes from checkpoints/."""
    assert population_index.index_differences() == [], "run `arena-league population index --write`"
    index = population_index.load_index()
    # package data, kept small: about 30 KB a population (its files' sizes and SHA-256), 20 of them
    assert population_index.INDEX_PATH.stat().st_size < 1_000_000
    every = {(p["game_id"], p["name"]) for p in index["populations"]}
    on_disk = {(m.parent.parent.name, m.parent.name)
               for m in population_index.CHECKOUT_POPULATIONS.glob("*/*/population.json")}
    assert every == on_disk and len(every) >= 14


def test_the_index_reports_a_changed_population(tmp_path):
    root = tmp_path / "checkpoints"
    _tiny_population(root / GAME / NAME)
    index = population_index.write_index(root, tmp_path / "index.json")
    assert population_index.index_differences(root, index) == []
    (root / GAME / NAME / "README.md").write_text("changed\n")
    (root / GAME / "tiny-v2").mkdir()
    shutil.copy(root / GAME / NAME / "population.json", root / GAME / "tiny-v2")
    differences = population_index.index_differences(root, index)
    assert f"{GAME}/tiny-v2: in {root} but not in the index" in differences
    assert any(line.startswith(f"{GAME}/{NAME}:") and "address" in line for line in differences)


def test_shipped_member_names_come_from_the_index_without_the_files(capsys, mirror, tmp_path):
    """A package without a population's files still reserves its members' names."""
    assert f"{NAME}.random@{GAME}" in shipped_member_names()
    code, _, _, err = cli(capsys, "submit", Path(__file__).parents[1] / "submissions" / "crossroads-2t2p-mlp.onnx",
                           "--game", GAME, "--name", f"{NAME}.random@{GAME}")
    assert code == 2 and "member of a base population shipped" in err


def test_pull_places_the_population_in_the_cache_and_a_second_pull_fetches_nothing(capsys, server, tmp_path):
    code, doc, _, err = cli(capsys, "population", "list", "--game", GAME, "--json")
    assert code == 0 and doc["shipped"] == [{"game_id": GAME, "name": NAME, "members": 2, "bytes": doc["shipped"][0][
        "bytes"], "where": "not downloaded", "path": None, "imported": None}]
    code, doc, _, err = cli(capsys, "population", "pull", GAME, "--mirror", server.url, "--json")
    assert code == 0, err
    (pulled,) = doc["pulled"]
    folder = tmp_path / "cache" / GAME / NAME
    assert pulled["fetched"] and pulled["path"] == str(folder) and pulled["files"] == 3
    assert hashlib.sha256((folder / "agents" / "blob.bin").read_bytes()).digest() == \
        hashlib.sha256((tmp_path / "mirror" / GAME / NAME / "agents" / "blob.bin").read_bytes()).digest()
    before = _cache_entries(tmp_path)
    code, _, out, err = cli(capsys, "population", "pull", GAME, NAME, "--mirror", server.url)
    assert code == 0 and f"{GAME} {NAME}: already here, whole; in {folder}" in out
    assert _cache_entries(tmp_path) == before  # nothing fetched, no temporary folder left
    code, doc, _, _ = cli(capsys, "population", "list", "--game", GAME, "--json")
    assert doc["shipped"][0]["where"] == "cache" and doc["shipped"][0]["path"] == str(folder)


def test_pull_from_a_mirror_set_in_the_environment_over_file_urls(capsys, mirror, tmp_path, monkeypatch):
    monkeypatch.setenv("ARENA_LEAGUE_POPULATION_MIRROR", mirror.as_uri())
    code, doc, _, err = cli(capsys, "population", "pull", GAME, "--json")
    assert code == 0, err
    assert code == 0 and doc["pulled"][0]["fetched"] and doc["pulled"][0]["url"] == mirror.as_uri() + "/"
    code, doc, _, err = cli(capsys, "population", "pull", "--all", "--json")  # every shipped one: the tiny one
    assert code == 0 and [(p["game_id"], p["name"], p["fetched"]) for p in doc["pulled"]] == [(GAME, NAME, False)]


def test_a_tampered_file_is_refused_and_nothing_is_kept(capsys, server, mirror, tmp_path):
    blob = mirror / GAME / NAME / "agents" / "blob.bin"
    content = bytearray(blob.read_bytes())
    content[-1] ^= 1  # same size, other bytes
    blob.write_bytes(bytes(content))
    code, _, _, err = cli(capsys, "population", "pull", GAME, "--mirror", server.url)
    assert code == 2 and "SHA-256 is not the one the index names" in err and "nothing was kept" in err
    assert _cache_entries(tmp_path) == []  # not even the game's folder
    blob.write_bytes(bytes(content) + b"more")  # longer than the index says: the read stops past the size
    code, _, _, err = cli(capsys, "population", "pull", GAME, "--mirror", server.url)
    assert code == 2 and f"more than the {BLOB_BYTES} bytes" in err
    assert _cache_entries(tmp_path) == []  # not even the game's folder


def test_a_transfer_broken_off_or_a_missing_file_leaves_no_folder(capsys, server, mirror, tmp_path):
    server.breaking = True
    code, _, _, err = cli(capsys, "population", "pull", GAME, "--mirror", server.url)
    assert code == 2 and f"sent {BLOB_BYTES // 2} bytes, not the {BLOB_BYTES}" in err and "nothing was kept" in err
    assert _cache_entries(tmp_path) == []  # not even the game's folder
    server.breaking = False
    (mirror / GAME / NAME / "README.md").unlink()
    code, _, _, err = cli(capsys, "population", "pull", GAME, "--mirror", server.url)
    assert code == 2 and "HTTP 404" in err and "--mirror URL" in err
    assert _cache_entries(tmp_path) == []  # not even the game's folder


def test_bad_pulls_name_the_problem_and_the_fix(capsys, mirror, tmp_path):
    code, _, _, err = cli(capsys, "population", "pull", GAME, "tiny-v9", "--mirror", mirror.as_uri())
    assert code == 2 and "no population 'tiny-v9' is shipped" in err and "Did you mean 'tiny-v1'" in err
    code, _, _, err = cli(capsys, "population", "pull", "Crosroads-2T2P-v1")
    assert code == 2 and "Did you mean 'Crossroads-2T2P-v1'" in err
    code, _, _, err = cli(capsys, "population", "pull", GAME)
    assert code == 2 and "names no URL" in err and "--mirror URL" in err
    code, _, _, err = cli(capsys, "population", "pull", GAME, "--mirror", "http://127.0.0.1:9/")
    assert code == 2 and "cannot reach http://127.0.0.1:9/" in err
    code, _, _, err = cli(capsys, "population", "list", "--game", "Snak-2T2P-v1")
    assert code == 2 and "Did you mean 'Snake-2T2P-v1'" in err
    assert _cache_entries(tmp_path) == []  # not even the game's folder


def test_the_quickstart_names_the_pull_when_the_base_is_not_here_then_uses_the_pulled_one(capsys, mirror, tmp_path):
    code, _, _, err = cli(capsys, "quickstart", "--matches-per-pair", "1", "--budget", "4")
    assert code == 2 and f"`arena-league population pull {GAME} {NAME}`" in err and "--no-base" in err
    cli(capsys, "population", "pull", GAME, "--mirror", mirror.as_uri())
    code, doc, _, err = cli(capsys, "quickstart", "--matches-per-pair", "1", "--budget", "4", "--json")
    assert code == 0 and doc["population"] == f"{NAME}:1"
    assert doc["population_origin"] == f"{NAME}:1 of {GAME} (2 agents, from the cache {tmp_path / 'cache'})"
    assert f"base population {NAME}:1 of {GAME} (2 agents, from the cache" in err


def test_a_folder_that_disagrees_with_the_index_is_refused_before_import_and_a_pull_mends_it(capsys, mirror,
                                                                                             tmp_path):
    folder = tmp_path / "cache" / GAME / NAME
    shutil.copytree(mirror / GAME / NAME, folder)
    (folder / "README.md").write_text("edited\n")
    code, _, _, err = cli(capsys, "quickstart", "--matches-per-pair", "1", "--budget", "4")
    assert code == 2 and str(folder) in err and f"pull it again with `arena-league population pull {GAME} {NAME}`" \
        in err
    code, listed, _, _ = cli(capsys, "population", "list", "--json")
    assert listed["populations"] == [] and listed["shipped"][0]["imported"] is None  # nothing imported
    code, doc, _, _ = cli(capsys, "population", "pull", GAME, "--mirror", mirror.as_uri(), "--json")
    assert code == 0 and doc["pulled"][0]["fetched"] and (folder / "README.md").read_text().startswith("# tiny-v1")
    assert [e for e in _cache_entries(tmp_path) if e.startswith(f"{GAME}/.")] == []  # the stale copy is gone
    assert population_index.verified_population(GAME, NAME).folder == folder
