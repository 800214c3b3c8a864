"""Social trees and JSON a person hands in, parsed within bounds: a 416-byte "billion laughs" YAML
tree (its aliases expand to about 2 GB when printed) is refused by name, from the library and from
``arena-league verify --tree`` under a 2 GiB address-space limit; JSON and YAML nested 100,000 deep
are refused without recursion; a tree file over the size limit is refused before it is read; and a
JSON body nested 100,000 deep gets a 400 naming its depth from a real ``arena-league serve``.
"""

from __future__ import annotations

import resource
import subprocess
import sys
from pathlib import Path

import httpx
import pytest
from web_helpers import running_server

from arena_league.envs import TreeSpecError, make
from arena_league.envs.bounded import MAX_TEXT_BYTES, BoundedInputError, json_nesting, load_json, load_yaml
from arena_league.envs.social import load_tree_spec

GAME = "GoBang-2T1P-v1"
DEEP = 100_000


def billion_laughs() -> str:
    """A valid-looking tree whose ``scale`` holds nine levels of nine aliases (9**9 strings)."""
    lines = ["scheme: CP", "reward: ranking", "children: [player_0, player_1]", "scale:",
             '  - &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for previous, anchor in zip("abcdefgh", "bcdefghi", strict=True):
        lines.append(f"  - &{anchor} [" + ",".join([f"*{previous}"] * 9) + "]")
    return "\n".join(lines) + "\n"


def test_yaml_anchors_and_aliases_are_refused_naming_the_fix(tmp_path):
    laughs = tmp_path / "laughs.yaml"
    laughs.write_text(billion_laughs())
    assert laughs.stat().st_size < 600
    with pytest.raises(TreeSpecError, match=r"uses a YAML anchor or alias \(&a, line 5\).*write the nodes out"):
        load_tree_spec(laughs)
    with pytest.raises(TreeSpecError, match="anchor or alias"):
        make(GAME, tree=str(laughs))
    with pytest.raises(BoundedInputError, match=r"alias \(\*x, line 2\)"):
        load_yaml("a: 1\nb: *x\n", "doc")  # an alias with no anchor is refused the same way


def test_deep_json_and_yaml_are_refused_without_recursion(tmp_path):
    with pytest.raises(TreeSpecError, match=f"nests arrays and objects {DEEP + 1} deep, deeper than the limit of 64"):
        load_tree_spec('{"children": ' + "[" * DEEP + "]" * DEEP + "}")
    deep = tmp_path / "deep.yaml"
    deep.write_text("children: " + "[" * DEEP + "]" * DEEP + "\n")
    with pytest.raises(TreeSpecError, match="nests mappings and lists deeper than the limit of 64"):
        load_tree_spec(deep)
    block = tmp_path / "block.yaml"
    block.write_text("".join(" " * level + "- \n" for level in range(200)))
    with pytest.raises(TreeSpecError, match=r"deeper than the limit of 64 \(line 65\)"):
        load_tree_spec(block)
    deep_json = tmp_path / "deep.json"
    deep_json.write_text("[" * DEEP + "]" * DEEP)
    with pytest.raises(TreeSpecError, match=str(deep_json)):
        load_tree_spec(deep_json)


def test_a_tree_file_over_the_size_limit_is_refused_before_it_is_read(tmp_path):
    big = tmp_path / "big.yaml"
    with big.open("wb") as out:
        out.truncate(MAX_TEXT_BYTES + 1)  # sparse: refused by its size, never read
    with pytest.raises(TreeSpecError, match=f"{MAX_TEXT_BYTES + 1} bytes, over the limit of {MAX_TEXT_BYTES}"):
        load_tree_spec(big)


def test_bounded_parsing_keeps_ordinary_documents_and_counts_brackets_outside_strings(tmp_path):
    assert json_nesting('["[[[\\"[", {"a": [1]}]') == 3 and json_nesting("7") == 0
    assert load_json('{"a": "[[[[[[[["}', "doc", max_depth=1) == {"a": "[[[[[[[["}
    with pytest.raises(BoundedInputError, match="not valid JSON"):
        load_json("[1, 2", "doc")
    with pytest.raises(BoundedInputError, match=r"not valid YAML: .* \(line 2\)"):
        load_yaml("a: [1, 2\nb: {", "doc")
    tree = tmp_path / "tree.yaml"
    tree.write_text("scheme: CP\nreward: ranking\nscale: 100\nchildren: [player_0, player_1]\n")
    assert load_tree_spec(tree)["children"] == ["player_0", "player_1"]
    assert make(GAME, tree=str(tree)) is not None


def _two_gib() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))


def test_verify_refuses_the_billion_laughs_in_one_line_under_a_memory_limit(tmp_path):
    laughs = tmp_path / "laughs.yaml"
    laughs.write_text(billion_laughs())
    done = subprocess.run([sys.executable, "-m", "arena_league.cli", "verify", GAME, "--tree", str(laughs),
                           "--samples", "4"], check=False, capture_output=True, text=True, timeout=60,
                           preexec_fn=_two_gib)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2, done.stderr[-2000:]
    assert len(lines) == 1 and "uses a YAML anchor or alias" in lines[0] and "write the nodes out" in lines[0], lines
    assert "MemoryError" not in done.stderr


def test_a_deeply_nested_json_body_is_refused_naming_its_depth(tmp_path: Path):
    nested = "[" * DEEP + "]" * DEEP
    with running_server(tmp_path / "home", workers=0) as server, server.client() as client:
        answer = client.post("/api/trees/check", content='{"game": "' + GAME + '", "spec": {"children": ' + nested +
                             "}}", headers={"content-type": "application/json"})
        assert answer.status_code == 400, answer.text
        assert answer.json()["detail"] == (f"the request body nests arrays and objects {DEEP + 2} deep, deeper than "
                                           "the limit of 64; write it with less nesting")
        # the same without a content type (FastAPI parses that as JSON too), and the server is still up
        request = client.build_request("POST", "/api/trees/check", content=nested.encode())
        request.headers.pop("content-type", None)
        assert client.send(request).status_code == 400
        shallow = client.post("/api/trees/check", json={"game": GAME, "spec": {
            "scheme": "CP", "reward": "ranking", "children": ["player_0", "player_1"]}})
        assert shallow.status_code == 200 and shallow.json()["ok"], shallow.text
        assert httpx.get(f"{server.url}/api/games").status_code == 200
