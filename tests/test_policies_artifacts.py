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
import onnx
import pytest
import torch
from onnx import external_data_helper, helper, numpy_helper

from arena_league.cli import main
from arena_league.policies import (
    AgentArtifact,
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


# --- ONNX external data ---------------------------------------------------------------------------

WEIGHT = np.random.default_rng(3).standard_normal((25, 5)).astype(np.float32)
BIAS = np.linspace(-1.0, 1.0, 5, dtype=np.float32)


def _linear_model(weight_name: str = "W") -> onnx.ModelProto:
    """A Crossroads agent: logits = obs @ W + B, inline tensors."""
    graph = helper.make_graph(
        [helper.make_node("MatMul", ["obs", weight_name], ["h"]), helper.make_node("Add", ["h", "B"], ["logits"])],
        "linear", [helper.make_tensor_value_info("obs", onnx.TensorProto.FLOAT, ["N", 25])],
        [helper.make_tensor_value_info("logits", onnx.TensorProto.FLOAT, ["N", 5])],
        [numpy_helper.from_array(WEIGHT, weight_name), numpy_helper.from_array(BIAS, "B")])
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8)


def _externalize(tensor: onnx.TensorProto, location: str, offset: int | None = None, length: int | None = None
                 ) -> None:
    external_data_helper.set_external_data(tensor, location, offset, length)
    tensor.ClearField("raw_data")


def _external_onnx(folder: pathlib.Path, location: str = "model.onnx.data", *, offset: int | None = None,
                   length: int | None = None, data: bytes | None = None) -> pathlib.Path:
    """``folder/model.onnx`` keeping W in ``location``; ``data`` (default: W's bytes) is written to
    ``folder/model.onnx.data`` unless it is ``b""``."""
    folder.mkdir(parents=True, exist_ok=True)
    model = _linear_model()
    _externalize(model.graph.initializer[0], location, offset, length)
    data = WEIGHT.tobytes() if data is None else data
    if data:
        (folder / "model.onnx.data").write_bytes(data)
    path = folder / "model.onnx"
    path.write_bytes(model.SerializeToString())
    return path


def _if_branch_onnx(folder: pathlib.Path, location: str = "w.bin") -> pathlib.Path:
    """An agent whose ``If`` then-branch keeps its weight in ``location`` (written beside it)."""
    folder.mkdir(parents=True, exist_ok=True)
    then_weight = numpy_helper.from_array(WEIGHT, "W_then")
    _externalize(then_weight, location, 0, WEIGHT.nbytes)
    (folder / location).write_bytes(WEIGHT.tobytes())
    out = helper.make_tensor_value_info
    then_branch = helper.make_graph([helper.make_node("MatMul", ["obs", "W_then"], ["then_out"])], "then", [],
                                    [out("then_out", onnx.TensorProto.FLOAT, ["N", 5])], [then_weight])
    else_branch = helper.make_graph([helper.make_node("MatMul", ["obs", "W_else"], ["else_out"])], "else", [],
                                    [out("else_out", onnx.TensorProto.FLOAT, ["N", 5])],
                                    [numpy_helper.from_array(WEIGHT, "W_else")])
    graph = helper.make_graph(
        [helper.make_node("If", ["cond"], ["logits"], then_branch=then_branch, else_branch=else_branch)], "if",
        [out("obs", onnx.TensorProto.FLOAT, ["N", 25])], [out("logits", onnx.TensorProto.FLOAT, ["N", 5])],
        [numpy_helper.from_array(np.array(True), "cond")])
    path = folder / "model.onnx"
    path.write_bytes(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)],
                                       ir_version=8).SerializeToString())
    return path


def _spy_on_files(monkeypatch) -> list[tuple[str, str]]:
    """``(operation, path)`` of every file opened (``open``) or looked at (``stat``) from now on."""
    touched: list[tuple[str, str]] = []

    def spy(real, operation):
        def call(path, *args, **kwargs):
            touched.append((operation, os.fspath(path)))
            return real(path, *args, **kwargs)
        return call

    for module, name, operation in ((os, "open", "open"), (builtins, "open", "open"), (pathlib.Path, "open", "open"),
                                    (os, "lstat", "stat"), (os, "stat", "stat")):
        monkeypatch.setattr(module, name, spy(getattr(module, name), operation))
    return touched


def test_external_data_beside_the_model_is_folded_into_one_file(tmp_path):
    path = _external_onnx(tmp_path / "agent")
    artifact = read_artifact(path)
    inline = tmp_path / "inline.onnx"
    inline.write_bytes(_linear_model().SerializeToString())
    assert artifact.content == inline.read_bytes() and artifact.digest == artifact_digest(inline)
    folded = onnx.load_model_from_string(artifact.content)
    assert not any(t.external_data or t.data_location == onnx.TensorProto.EXTERNAL for t in folded.graph.initializer)
    obs = np.random.default_rng(0).standard_normal((8, 25)).astype(np.float32)
    logits, _ = load_agent(path, GAME).policy.forward(obs)
    np.testing.assert_allclose(logits, obs @ WEIGHT + BIAS, rtol=1e-5, atol=1e-5)
    # offset into a shared file, and a length left out (to the end of the file)
    padded = _external_onnx(tmp_path / "padded", offset=64, data=bytes(64) + WEIGHT.tobytes())
    assert read_artifact(padded).digest == artifact.digest


@pytest.mark.parametrize(("location", "problem"), [
    ("ABSOLUTE", r"by the absolute path '/.*outside\.bin'"),
    ("../outside.bin", r"climbs out of the model's folder \(\.\.\)"),
    ("sub/model.onnx.data", "has a directory part"),
    ("sub/../model.onnx.data", r"climbs out of the model's folder \(\.\.\)"),
    ("..\\outside.bin", r"climbs out of the model's folder \(\.\.\)"),
])
def test_external_data_outside_the_models_folder_is_refused_and_never_read(tmp_path, monkeypatch, location,
                                                                          problem):
    outside = tmp_path / "outside.bin"
    outside.write_bytes(WEIGHT.tobytes())
    (tmp_path / "agent" / "sub").mkdir(parents=True)
    (tmp_path / "agent" / "sub" / "model.onnx.data").write_bytes(WEIGHT.tobytes())
    path = _external_onnx(tmp_path / "agent", str(outside) if location == "ABSOLUTE" else location)
    touched = _spy_on_files(monkeypatch)
    with pytest.raises(UnsafeArtifactError, match=rf"{problem}; it is never read.*torch\.onnx\.export"):
        read_artifact(path)
    assert touched and {pathlib.Path(p) for _, p in touched} == {path}  # the model alone


def test_a_missing_data_file_names_the_torch_export(tmp_path):
    path = _external_onnx(tmp_path / "agent", data=b"")
    with pytest.raises(ArtifactError, match=r"'model\.onnx\.data', but .*agent holds no such file; submit the \.onnx "
                                            r"file itself with its \.onnx\.data beside it.*external_data=False"):
        read_artifact(path)


def test_offsets_and_lengths_outside_the_data_file_are_refused(tmp_path):
    path = _external_onnx(tmp_path / "beyond", offset=WEIGHT.nbytes + 1, length=4)
    with pytest.raises(CorruptArtifactError, match=rf"reads bytes {WEIGHT.nbytes + 1} to .*that file is "
                                                   rf"{WEIGHT.nbytes} bytes.*truncated or comes from another export"):
        read_artifact(path)
    path = _external_onnx(tmp_path / "long", offset=8, length=WEIGHT.nbytes)
    with pytest.raises(CorruptArtifactError, match="but that file is"):
        read_artifact(path)
    path = _external_onnx(tmp_path / "short", length=WEIGHT.nbytes - 4)
    with pytest.raises(CorruptArtifactError, match=rf"is float\[25, 5\] \({WEIGHT.nbytes} bytes\).*"
                                                   rf"{WEIGHT.nbytes - 4} bytes long"):
        read_artifact(path)


def test_a_linked_or_special_data_file_is_refused(tmp_path, monkeypatch):
    path = _external_onnx(tmp_path / "agent", data=b"")
    (tmp_path / "real.bin").write_bytes(WEIGHT.tobytes())
    (tmp_path / "agent" / "model.onnx.data").symlink_to(tmp_path / "real.bin")
    touched = _spy_on_files(monkeypatch)
    with pytest.raises(UnsafeArtifactError, match=r"'model\.onnx\.data', which is a link and is never followed"):
        read_artifact(path)
    assert not any(p.endswith(("real.bin", "model.onnx.data")) for operation, p in touched if operation == "open")
    if hasattr(os, "mkfifo"):
        (tmp_path / "agent" / "model.onnx.data").unlink()
        os.mkfifo(tmp_path / "agent" / "model.onnx.data")  # opening it to read would block
        with pytest.raises(ArtifactError, match="which is not a regular file"):
            read_artifact(path)


def test_external_data_in_an_if_branch_is_refused_wherever_the_process_runs(tmp_path, monkeypatch):
    path = _if_branch_onnx(tmp_path / "agent")
    with pytest.raises(ArtifactError, match=r"If node attribute 'then_branch' > initializer 'W_then' keeps its "
                                            r"data in an external file \('w\.bin'\) inside a subgraph.*"
                                            r"external_data=False"):
        read_artifact(path)
    # The same bytes handed over as an artifact, run where a w.bin lies in the current directory:
    # onnxruntime would take that file as the weights; the model is refused before it is run.
    monkeypatch.chdir(tmp_path / "agent")
    raw = AgentArtifact("onnx", {"model.onnx": path.read_bytes()}, "if.onnx")
    with pytest.raises(CorruptArtifactError, match=r"then_branch' > initializer 'W_then' keeps its data in an "
                                                   r"external file \('w\.bin'\).*\.onnx\.data beside it"):
        load_agent(raw, GAME)
    with pytest.raises(CorruptArtifactError, match="external file"):
        load_agent(unpack_artifact(path.read_bytes()), GAME)


def test_the_size_limit_covers_the_model_and_its_data_together(tmp_path, monkeypatch):
    path = _external_onnx(tmp_path / "agent")
    data = path.parent / "model.onnx.data"
    together = path.stat().st_size + data.stat().st_size
    assert read_artifact(path, ArtifactLimits(max_onnx_bytes=together)).kind == "onnx"
    with pytest.raises(ArtifactTooLargeError, match=rf"\(model\.onnx\.data\) are {together} bytes together"):
        read_artifact(path, ArtifactLimits(max_onnx_bytes=together - 1))
    os.truncate(data, 300 * 1024**2)  # sparse: nothing written
    touched = _spy_on_files(monkeypatch)
    with pytest.raises(ArtifactTooLargeError, match=r"and its external data \(model\.onnx\.data\) are \d+ bytes "
                                                    r"together \(300 MiB\), over the limit of 256 MiB.*not read"):
        read_artifact(path)
    assert ("stat", str(data)) in touched
    assert not any(p.endswith("model.onnx.data") for operation, p in touched if operation == "open")


def test_submit_refuses_external_data_outside_the_folder_and_stores_nothing(tmp_path, monkeypatch, capsys):
    home = tmp_path / "home"
    monkeypatch.setenv("ARENA_LEAGUE_HOME", str(home))
    monkeypatch.delenv("ARENA_LEAGUE_DB", raising=False)
    (tmp_path / "outside.bin").write_bytes(WEIGHT.tobytes())
    path = _external_onnx(tmp_path / "agent", "../outside.bin")
    code = main(["submit", str(path), "--game", GAME, "--name", "escaper", "--json"])
    error = json.loads(capsys.readouterr().out)
    assert code == 2 and error["kind"] == "UnsafeArtifactError"
    assert "'../outside.bin', which climbs out of the model's folder" in error["error"]
    assert "external_data=False" in error["error"]
    assert not list(home.rglob("*.onnx"))  # nothing stored
    good = _external_onnx(tmp_path / "good")
    assert main(["submit", str(good), "--game", GAME, "--name", "escaper", "--json"]) == 0  # the name is free
    stored = json.loads(capsys.readouterr().out)
    assert stored["status"] == "active" and stored["digest"] == read_artifact(good).digest
