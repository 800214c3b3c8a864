"""Shared pieces of the command's tests: a league home per test, running the command, a
small GoBang agent."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from arena_league.cli import main
from arena_league.policies import Architecture, init_parameters
from arena_league.policies.artifacts import save_arena_policy

GOBANG = "GoBang-2T1P-v1"


@pytest.fixture
def home(tmp_path, monkeypatch):
    monkeypatch.delenv("ARENA_LEAGUE_DB", raising=False)
    monkeypatch.setenv("ARENA_LEAGUE_HOME", str(tmp_path / "home"))
    return tmp_path / "home"


def run(capsys, *argv) -> tuple[int, dict, str]:
    """The command's exit code, its JSON document (or {}) and its stderr."""
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, json.loads(captured.out) if captured.out.startswith("{") else {}, captured.err


def gobang_agent(folder: Path, seed: int = 7) -> Path:
    """A small random MLP agent for GoBang-2T1P-v1, as an arena-policy folder."""
    arch = Architecture("mlp", obs_dim=455, action_type="discrete", n_actions=225, hidden=(16,))
    return save_arena_policy(folder, arch, init_parameters(arch, seed), GOBANG, name=f"mlp-{seed}")
