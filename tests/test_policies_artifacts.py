"""Agent artifacts (the bad inputs that concern them): code-carrying formats refused whatever
the file is called, size limits checked before reading, truncated files, wrong spaces, unknown
families, and content addresses that survive packing."""

from __future__ import annotations

import builtins
import hashlib
import json
import os
import pathlib
import pickle

import numpy as np
import pytest
import torch

from arena_league.policies import (
    Architecture,
    ArtifactError,
    ArtifactLimits,
    ArtifactTooLargeError,
    CorruptArtifactError,
    ManifestError,
    OnnxPolicy,
    SpaceMismatchError,
    TorchPolicy,
    UnsafeArtifactError,
    artifact_digest,
    export_onnx,
    init_parameters,
    load_agent,
    pack_artifact,
    read_artifact,
    save_arena_policy,
    unpack_artifact,
    write_artifact,
)
from arena_league.policies.threads import torch_threads

GAME = "Crossroads-2T2P-v1"
CROSSROADS = Architecture("mlp", obs_dim=25, action_type="discrete", n_actions=5, hidden=(16,))


@pytest.fixture(autouse=True)
def one_torch_thread():
    with torch_threads(1):
        yield


@pytest.fixture
def onnx_file(tmp_path) -> pathlib.Path:
    path = tmp_path / "agent.onnx"
    export_onnx(CROSSROADS, init_parameters(CROSSROADS, 1), path, game_id=GAME)
    return path


# --- formats that can carry code ------------------------------------------------------------------

@pytest.mark.parametrize("protocol", [0, 1, 2, 4, 5])
def test_a_pickle_renamed_onnx_is_refused_as_a_pickle(tmp_path, protocol):
    path = tmp_path / "agent.onnx"
    path.write_bytes(pickle.dumps({"weights": [1.0, 2.0], "bias": None}, protocol=protocol))
    with pytest.raises(UnsafeArtifactError, match=r"pickle.*never loaded.*ONNX"):
        read_artifact(path)


def test_a_torchscript_file_renamed_onnx_is_refused_as_torchscript(tmp_path):
    path = tmp_path / "agent.onnx"
    torch.jit.save(torch.jit.script(torch.nn.Linear(25, 5)), str(path))
    with pytest.raises(UnsafeArtifactError, match=r"TorchScript.*carries code.*ONNX"):
        read_artifact(path)
    with pytest.raises(UnsafeArtifactError, match="TorchScript"):
        load_agent(path, GAME)


def test_a_torch_checkpoint_and_a_pt2_archive_are_refused(tmp_path):
    checkpoint = tmp_path / "policy.bin"
    torch.save(torch.nn.Linear(25, 5).state_dict(), checkpoint)
    with pytest.raises(UnsafeArtifactError, match=r"torch\.save: a pickle inside a zip"):
        read_artifact(checkpoint)
    exported = tmp_path / "policy.onnx"
    program = torch.export.export(torch.nn.Linear(25, 5), (torch.zeros(1, 25),))
    torch.export.save(program, str(exported))
    with pytest.raises(UnsafeArtifactError, match=r"\.pt2"):
        read_artifact(exported)


def test_a_pickle_posing_as_the_weights_of_a_policy_folder_is_refused(tmp_path):
    folder = save_arena_policy(tmp_path / "agent", CROSSROADS, init_parameters(CROSSROADS, 0), GAME)
    (folder / "weights.safetensors").write_bytes(pickle.dumps(init_parameters(CROSSROADS, 0)))
    with pytest.raises(UnsafeArtifactError, match=r"weights\.safetensors is a Python pickle"):
        read_artifact(folder)


# --- sizes and damage -----------------------------------------------------------------------------

def _forbid_reading(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the file was opened for reading")

    monkeypatch.setattr(builtins, "open", refuse)
    monkeypatch.setattr(pathlib.Path, "open", refuse)


def test_a_2_gb_file_is_refused_before_it_is_read(tmp_path, monkeypatch):
    path = tmp_path / "huge.onnx"
    with open(path, "wb") as handle:
        handle.truncate(2 * 1024**3)  # sparse: no 2 GB written
    _forbid_reading(monkeypatch)
    with pytest.raises(ArtifactTooLargeError, match=r"2147483648 bytes \(2 GiB\), over the limit of 256 MiB.*not read"):
        read_artifact(path)
    with pytest.raises(ArtifactTooLargeError):
        artifact_digest(path)


def test_an_oversized_weights_file_in_a_folder_is_refused_before_it_is_read(tmp_path, monkeypatch):
    folder = save_arena_policy(tmp_path / "agent", CROSSROADS, init_parameters(CROSSROADS, 0), GAME)
    os.truncate(folder / "weights.safetensors", 2 * 1024**3)
    _forbid_reading(monkeypatch)
    with pytest.raises(ArtifactTooLargeError, match="weights.safetensors"):
        read_artifact(folder)


def test_the_limits_are_configurable(onnx_file):
    with pytest.raises(ArtifactTooLargeError, match=r"2442 bytes \(2.38 KiB\), over the limit of 1000 bytes"):
        read_artifact(onnx_file, ArtifactLimits(max_onnx_bytes=1000))


@pytest.mark.parametrize("fraction", [0.1, 0.5, 0.9, 0.99])
def test_a_truncated_onnx_file_gets_a_clear_error(tmp_path, onnx_file, fraction):
    data = onnx_file.read_bytes()
    cut = tmp_path / "cut.onnx"
    cut.write_bytes(data[: int(len(data) * fraction)])
    with pytest.raises(CorruptArtifactError, match=r"(truncated|not a complete|not a valid).*re-export"):
        load_agent(cut, GAME)


def test_an_empty_file_and_a_truncated_weights_file_get_clear_errors(tmp_path):
    empty = tmp_path / "empty.onnx"
    empty.write_bytes(b"")
    with pytest.raises(CorruptArtifactError, match="empty"):
        read_artifact(empty)
    folder = save_arena_policy(tmp_path / "agent", CROSSROADS, init_parameters(CROSSROADS, 0), GAME)
    weights = folder / "weights.safetensors"
    weights.write_bytes(weights.read_bytes()[:-100])
    with pytest.raises(CorruptArtifactError, match=r"weights\.safetensors is truncated"):
        load_agent(folder, GAME)


# --- spaces and manifests -------------------------------------------------------------------------

def test_an_onnx_with_the_wrong_input_size_names_both_sizes(tmp_path):
    wrong = Architecture("mlp", obs_dim=12, action_type="discrete", n_actions=5, hidden=(8,))
    path = tmp_path / "wrong.onnx"
    export_onnx(wrong, init_parameters(wrong, 0), path)
    with pytest.raises(SpaceMismatchError, match=r"obs has 12 features.*expects input obs float32\[N, 25\]"):
        load_agent(path, GAME)


def test_an_onnx_with_the_wrong_outputs_names_the_expected_ones(tmp_path):
    six = Architecture("mlp", obs_dim=25, action_type="discrete", n_actions=6, hidden=(8,))
    path = tmp_path / "six.onnx"
    export_onnx(six, init_parameters(six, 0), path)
    with pytest.raises(SpaceMismatchError, match=r"logits has 6 actions.*logits float32\[N, 5\]"):
        load_agent(path, GAME)
    continuous = Architecture("mlp", obs_dim=25, action_type="continuous", act_dim=2, hidden=(8,))
    export_onnx(continuous, init_parameters(continuous, 0), path)
    with pytest.raises(SpaceMismatchError, match=r"outputs action .*expects .*output logits"):
        load_agent(path, GAME, action_type="discrete")
    assert load_agent(path, GAME).info.action_type == "continuous"  # Crossroads offers both variants


def test_an_onnx_exported_for_another_game_is_refused(tmp_path, onnx_file):
    with pytest.raises(SpaceMismatchError, match="exported for Crossroads-2T2P-v1, not Crossroads-2T1P-v1"):
        load_agent(onnx_file, "Crossroads-2T1P-v1")


def test_an_unknown_family_in_a_manifest_is_refused_with_the_known_ones(tmp_path):
    folder = save_arena_policy(tmp_path / "agent", CROSSROADS, init_parameters(CROSSROADS, 0), GAME)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["family"] = "transformer"
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ManifestError, match=r"unknown policy family 'transformer'.*mlp, cnn, gru"):
        read_artifact(folder)


def test_manifest_sizes_must_match_the_weights_and_the_game(tmp_path):
    folder = save_arena_policy(tmp_path / "agent", CROSSROADS, init_parameters(CROSSROADS, 0), GAME)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["sizes"]["hidden"] = [32]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ManifestError, match=r"hidden\.0\.weight has shape \[16, 25\].*needs \[32, 25\]"):
        load_agent(folder, GAME)
    manifest["sizes"]["hidden"], manifest["game"] = [16], "Soccer-2T2P-v1"
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(SpaceMismatchError, match="made for Soccer-2T2P-v1, not Crossroads-2T2P-v1"):
        load_agent(folder, GAME)
    manifest["game"], manifest["spaces"]["obs_dim"] = GAME, 30
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(SpaceMismatchError, match="declares obs_dim 30.*Crossroads-2T2P-v1 has obs_dim 25"):
        load_agent(folder, GAME)


def test_a_policy_folder_holds_only_its_files(tmp_path):
    folder = save_arena_policy(tmp_path / "agent", CROSSROADS, init_parameters(CROSSROADS, 0), GAME)
    (folder / "train.py").write_text("print('hello')\n")
    with pytest.raises(ArtifactError, match=r"holds the file 'train\.py'"):
        read_artifact(folder)
    (folder / "train.py").unlink()
    (folder / "README.md").symlink_to(tmp_path)
    with pytest.raises(ArtifactError, match="holds a link"):
        read_artifact(folder)


def test_scripted_references_and_unknown_games():
    assert load_agent("scripted:heuristic", GAME).policy.name == "heuristic"
    with pytest.raises(ValueError, match="built-in agents: scripted:random, scripted:heuristic"):
        read_artifact("scripted:minimax")
    with pytest.raises(ValueError, match="unknown game id 'Crossroads-9T9P-v1'"):
        load_agent("scripted:random", "Crossroads-9T9P-v1")


# --- content addresses ----------------------------------------------------------------------------

def test_a_file_is_addressed_by_the_sha256_of_its_bytes(onnx_file):
    assert artifact_digest(onnx_file) == hashlib.sha256(onnx_file.read_bytes()).hexdigest()
    loaded = load_agent(onnx_file, GAME)
    assert loaded.info.digest == loaded.artifact.digest == artifact_digest(onnx_file)
    assert loaded.policy.name == f"onnx:{loaded.info.digest[:12]}"


def test_a_folder_is_addressed_by_its_sha256sum_listing_and_survives_packing(tmp_path):
    folder = save_arena_policy(tmp_path / "agent", CROSSROADS, init_parameters(CROSSROADS, 0), GAME, name="a")
    (folder / "README.md").write_text("an agent\n")
    listing = "".join(f"{hashlib.sha256((folder / n).read_bytes()).hexdigest()}  {n}\n"
                      for n in sorted(os.listdir(folder)))
    digest = hashlib.sha256(listing.encode()).hexdigest()
    assert artifact_digest(folder) == digest
    restored = unpack_artifact(pack_artifact(read_artifact(folder)))
    assert restored.kind == "arena-policy" and restored.digest == digest
    copy = write_artifact(restored, tmp_path / "copy")
    assert artifact_digest(copy) == digest
    same_weights = save_arena_policy(tmp_path / "again", CROSSROADS, init_parameters(CROSSROADS, 0), GAME, name="a")
    (same_weights / "README.md").write_text("an agent\n")
    assert artifact_digest(same_weights) == digest  # canonical bytes: same agent, same address
    packed = pack_artifact(restored)
    with pytest.raises(CorruptArtifactError):
        unpack_artifact(packed[:-10])


def test_onnx_and_folder_of_the_same_weights_play_the_same(tmp_path):
    params = init_parameters(CROSSROADS, 5)
    params["head.weight"] = params["head.weight"] * 300  # sharp enough that sampling matters little
    export_onnx(CROSSROADS, params, tmp_path / "a.onnx", game_id=GAME)
    save_arena_policy(tmp_path / "a", CROSSROADS, params, GAME)
    onnx_policy = load_agent(tmp_path / "a.onnx", GAME).policy
    torch_policy = load_agent(tmp_path / "a", GAME).policy
    assert isinstance(onnx_policy, OnnxPolicy) and isinstance(torch_policy, TorchPolicy)
    rng = np.random.default_rng(0)
    obs = rng.standard_normal((64, 25)).astype(np.float32)
    logits_onnx, _ = onnx_policy.forward(obs)
    logits_torch, _ = torch_policy.forward(obs)
    np.testing.assert_allclose(logits_onnx, logits_torch, rtol=1e-5, atol=1e-5)
