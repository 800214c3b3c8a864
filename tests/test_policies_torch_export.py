"""An agent exported the way torch users export it: ``torch.onnx.export`` with its defaults (the
dynamo exporter) writes ``model.onnx`` and its weights in ``model.onnx.data`` beside it. The league
folds the data in: the agent is submitted and ranked through the command, its content address is
that of one self-contained file, and the two files moved together still read the same wherever
the process runs."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import onnx
import pytest
import torch
from torch import nn

from arena_league.cli import main
from arena_league.envs import make_rules
from arena_league.policies import AgentArtifact, CorruptArtifactError, load_agent, read_artifact
from arena_league.policies.threads import torch_threads

GAME = "GoBang-2T1P-v1"
BASE_POPULATION = Path(__file__).resolve().parents[1] / "checkpoints" / GAME / "base-v1"


class TinyAgent(nn.Module):
    """obs ``float32[N, obs_dim]`` -> logits ``float32[N, n_actions]``."""

    def __init__(self, obs_dim: int, n_actions: int, hidden: int = 16) -> None:
        super().__init__()
        self.net = nn.Sequential(nn.Linear(obs_dim, hidden), nn.Tanh(), nn.Linear(hidden, n_actions))

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.net(obs)


def export(agent: nn.Module, path: Path, **options) -> Path:
    """The export call of docs/submitting.md: torch's default exporter, the league's I/O names, a dynamic batch."""
    obs = torch.zeros(2, agent.net[0].in_features)
    torch.onnx.export(agent, (obs,), str(path), input_names=["obs"], output_names=["logits"],
                      dynamic_shapes=({0: "batch"},), **options)
    return path


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> dict[str, Path]:
    """The same agent exported by default (model.onnx + model.onnx.data) and as one file."""
    rules = make_rules(GAME)
    with torch_threads(1):
        torch.manual_seed(0)
        agent = TinyAgent(rules.obs_dim, rules.n_actions).eval()
        default = tmp_path_factory.mktemp("default")
        single = tmp_path_factory.mktemp("single")
        return {"default": export(agent, default / "model.onnx"),
                "single": export(agent, single / "model.onnx", external_data=False)}


def test_the_default_export_writes_external_data_and_reads_as_one_file(exported):
    path = exported["default"]
    assert sorted(p.name for p in path.parent.iterdir()) == ["model.onnx", "model.onnx.data"]
    written = onnx.load_model_from_string(path.read_bytes())
    assert any(t.data_location == onnx.TensorProto.EXTERNAL for t in written.graph.initializer)
    artifact = read_artifact(path)
    folded = onnx.load_model_from_string(artifact.content)
    assert not any(t.data_location == onnx.TensorProto.EXTERNAL or t.external_data for t in folded.graph.initializer)
    assert artifact.digest == hashlib.sha256(artifact.content).hexdigest()
    # torch 2.13: the same export with external_data=False is the same bytes, so the same agent
    assert [p.name for p in exported["single"].parent.iterdir()] == ["model.onnx"]
    assert artifact.content == exported["single"].read_bytes()
    assert artifact.digest == read_artifact(exported["single"]).digest


def test_the_default_export_is_submitted_and_ranked_through_the_command(exported, tmp_path, monkeypatch, capsys):
    home = tmp_path / "home"
    monkeypatch.setenv("ARENA_LEAGUE_HOME", str(home))
    monkeypatch.delenv("ARENA_LEAGUE_DB", raising=False)
    assert main(["population", "import", str(BASE_POPULATION)]) == 0
    capsys.readouterr()
    code = main(["submit", str(exported["default"]), "--game", GAME, "--name", "torch-default", "--json"])
    submitted = json.loads(capsys.readouterr().out)
    assert code == 0 and submitted["status"] == "active" and submitted["created"]
    assert submitted["digest"] == read_artifact(exported["default"]).digest
    stored = [p for p in home.rglob("*.onnx") if submitted["digest"] in p.name]
    assert len(stored) == 1 and stored[0].read_bytes() == read_artifact(exported["single"]).content
    code = main(["submit", str(exported["single"]), "--game", GAME, "--name", "torch-single", "--json"])
    again = json.loads(capsys.readouterr().out)
    assert code == 0 and again["agent"] == "torch-default" and not again["created"]  # same bytes, same agent
    code = main(["rank", "torch-default", "--population", "base-v1", "--budget", "20", "--json"])
    report = json.loads(capsys.readouterr().out)
    assert code == 0 and report["agent"] == "torch-default" and report["matches"] == 20
    assert 1 <= report["rank"] <= report["base_size"] + 1 and np.isfinite(report["rating"])


def test_the_two_files_moved_together_read_the_same_whatever_the_current_directory(exported, tmp_path,
                                                                                     monkeypatch):
    digest = read_artifact(exported["default"]).digest
    moved = tmp_path / "elsewhere" / "agent"
    moved.mkdir(parents=True)
    for name in ("model.onnx", "model.onnx.data"):
        shutil.copy(exported["default"].parent / name, moved / name)
    decoy = tmp_path / "cwd"
    decoy.mkdir()
    (decoy / "model.onnx.data").write_bytes(bytes((moved / "model.onnx.data").stat().st_size))  # zeros
    monkeypatch.chdir(decoy)
    assert read_artifact(moved / "model.onnx").digest == digest
    monkeypatch.chdir(tmp_path / "elsewhere")
    assert read_artifact(Path("agent") / "model.onnx").digest == digest
    obs = np.random.default_rng(0).standard_normal((5, make_rules(GAME).obs_dim)).astype(np.float32)
    here, _ = load_agent(moved / "model.onnx", GAME).policy.forward(obs)
    there, _ = load_agent(exported["default"], GAME).policy.forward(obs)
    np.testing.assert_array_equal(here, there)
    # the unfolded bytes alone are refused, even where a model.onnx.data lies in the current directory
    monkeypatch.chdir(moved)
    raw = AgentArtifact("onnx", {"model.onnx": (moved / "model.onnx").read_bytes()}, "model.onnx")
    with pytest.raises(CorruptArtifactError, match=r"external file \('model\.onnx\.data'\).*dynamo=True"):
        load_agent(raw, GAME)
