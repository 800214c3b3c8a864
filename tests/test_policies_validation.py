"""Submission validation: the example submissions pass; broken agents are rejected with the reason
and a log, stage by stage (read, load, probe, validation match against copies of itself)."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import onnx
import pytest
import torch
from onnx import TensorProto, helper, numpy_helper

from arena_league.policies import (
    Architecture,
    GridLayout,
    OnnxPolicy,
    PolicyOutputError,
    export_onnx,
    init_parameters,
    load_agent,
    save_arena_policy,
    validate_submission,
)

GAME = "Crossroads-2T2P-v1"
SUBMISSIONS = Path(__file__).resolve().parents[1] / "submissions"


def _onnx(tmp_path: Path, nodes, initializers, obs_dim: int = 25, out: str = "logits", out_dim: int = 5,
          batch: int | str = "N") -> Path:
    """A hand-built ONNX agent (onnx helper API): input obs, one output."""
    graph = helper.make_graph(nodes, "probe", [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [batch, obs_dim])],
                              [helper.make_tensor_value_info(out, TensorProto.FLOAT, [batch, out_dim])],
                              [numpy_helper.from_array(v, k) for k, v in initializers.items()])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8)
    path = tmp_path / "agent.onnx"
    onnx.save_model(model, str(path))
    return path


def _linear(tmp_path: Path, weight: np.ndarray, **kwargs) -> Path:
    nodes = [helper.make_node("Gemm", ["obs", "W", "b"], [kwargs.get("out", "logits")], transB=1)]
    return _onnx(tmp_path, nodes, {"W": weight.astype(np.float32), "b": np.zeros(weight.shape[0], np.float32)},
                 **kwargs)


@pytest.mark.parametrize("example", ["crossroads-2t2p-mlp.onnx", "crossroads-2t2p-mlp"])
def test_the_example_submissions_pass(example):
    result = validate_submission(SUBMISSIONS / example, GAME)
    assert result.ok, result.log
    assert result.reason is None and result.spec.obs_dim == 25 and result.spec.n_actions == 5
    assert result.match["seats"] == 4 and result.match["steps"] > 0
    for stage in ("[read]", "[load]", "[probe]", "[match]", "[result] accepted"):
        assert stage in result.log
    assert (SUBMISSIONS / "crossroads-2t2p-mlp.onnx").stat().st_size < 16 * 1024


def test_an_onnx_that_outputs_nan_is_rejected_with_the_reason(tmp_path):
    path = _linear(tmp_path, np.full((5, 25), np.nan))
    result = validate_submission(path, GAME)
    assert not result.ok
    assert result.reason.startswith("outputs NaN on probe observations (random normal)")
    assert "[load]" in result.log and "[result] rejected: outputs NaN" in result.log
    assert result.digest is not None and result.spec is not None
    with pytest.raises(PolicyOutputError, match="NaN or infinite logits"):
        load_agent(path, GAME).policy.act(np.zeros((3, 25), np.float32), np.zeros((3, 1)))


def test_a_pickle_and_a_wrong_input_size_are_rejected_with_the_reason(tmp_path):
    pickled = tmp_path / "agent.onnx"
    pickled.write_bytes(pickle.dumps({"w": 1}))
    result = validate_submission(pickled, GAME)
    assert not result.ok and "pickle" in result.reason and "[read]" not in result.log
    assert "[result] rejected" in result.log
    wrong = _linear(tmp_path, np.zeros((5, 12)), obs_dim=12)
    result = validate_submission(wrong, GAME)
    assert not result.ok and "obs has 12 features" in result.reason and "float32[N, 25]" in result.reason


def test_an_unknown_game_is_the_callers_error():
    with pytest.raises(ValueError, match="unknown game id 'Crossroads-2T2P-v9'"):
        validate_submission(SUBMISSIONS / "crossroads-2t2p-mlp.onnx", "Crossroads-2T2P-v9")


def test_an_agent_whose_rows_depend_on_each_other_is_rejected(tmp_path):
    weight = np.random.default_rng(0).standard_normal((5, 25)).astype(np.float32)
    nodes = [helper.make_node("ReduceMean", ["obs"], ["mean"], axes=[0], keepdims=1),
             helper.make_node("Sub", ["obs", "mean"], ["centred"]),
             helper.make_node("Gemm", ["centred", "W", "b"], ["logits"], transB=1)]
    path = _onnx(tmp_path, nodes, {"W": weight, "b": np.zeros(5, np.float32)})
    result = validate_submission(path, GAME)
    assert not result.ok and "depends on the other rows of the batch" in result.reason


def test_continuous_actions_out_of_range_are_rejected(tmp_path):
    path = _linear(tmp_path, np.full((2, 25), 3.0), out="action", out_dim=2)
    result = validate_submission(path, GAME, action_type="continuous")
    assert not result.ok and "action out of range" in result.reason and "tanh" in result.reason


def test_a_fixed_batch_of_one_is_accepted_and_run_row_by_row(tmp_path):
    path = _linear(tmp_path, np.random.default_rng(1).standard_normal((5, 25)), batch=1)
    loaded = load_agent(path, GAME)
    assert isinstance(loaded.policy, OnnxPolicy) and loaded.policy.name.startswith("onnx-batch1:")
    obs = np.random.default_rng(2).standard_normal((7, 25)).astype(np.float32)
    logits, _ = loaded.policy.forward(obs)
    weight = onnx.numpy_helper.to_array(onnx.load(str(path)).graph.initializer[0])
    np.testing.assert_allclose(logits, obs @ weight.T, rtol=1e-5, atol=1e-5)
    result = validate_submission(path, GAME)
    assert result.ok and "fixed batch 1" in result.log


@pytest.mark.parametrize("game_id, arch", [
    ("GoBang-2T1P-v1", Architecture("cnn", 455, "discrete", n_actions=225, hidden=(16,),
                                    grid=GridLayout(2, 15, 15, 0), conv_channels=(4,))),
    ("Soccer-2T1P-v1", Architecture("gru", 19, "continuous", act_dim=2, hidden=(16,), gru_size=8)),
])
def test_families_pass_validation_as_onnx_and_as_folders(tmp_path, game_id, arch):
    params = init_parameters(arch, 0)
    threads = torch.get_num_threads()
    onnx_path = tmp_path / "agent.onnx"
    export_onnx(arch, params, onnx_path, game_id=game_id)
    folder = save_arena_policy(tmp_path / "agent", arch, params, game_id)
    for source in (onnx_path, folder):
        result = validate_submission(source, game_id)
        assert result.ok, result.log
        assert result.spec.recurrent == arch.recurrent
    assert torch.get_num_threads() == threads  # validation runs on one thread, then restores the setting
