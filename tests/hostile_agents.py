"""ONNX agents an attacker would submit: a linear policy that also hangs, allocates, fails or
outputs NaN, on every call or only when the batch has more than ``above`` rows (so that a
validation with small batches accepts it). Each is a valid ONNX model of the league's I/O
convention, built with ``onnx.helper``; none carries code."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from arena_league.policies import game_action_spec

#: Iterations of the hanging Loop: at a microsecond each, about 30 years.
FOREVER = 10**15


def _const(name: str, value, dtype=None) -> onnx.NodeProto:
    array = np.asarray(value, dtype=dtype)
    return helper.make_node("Constant", [], [name], value=numpy_helper.from_array(array, name + "_value"))


def _triggered(above: int | None, exactly: int | None = None) -> list[onnx.NodeProto]:
    """Nodes computing ``over`` (bool) and ``on`` (int64 scalar, 0 or 1): on when the batch has more
    than ``above`` rows, or exactly ``exactly`` rows (always, when both are None)."""
    test = "Greater" if exactly is None else "Equal"
    threshold = exactly if exactly is not None else -1 if above is None else above
    return [
        helper.make_node("Shape", ["obs"], ["obs_shape"]),
        _const("zero_index", 0, np.int64),
        helper.make_node("Gather", ["obs_shape", "zero_index"], ["rows"], axis=0),
        _const("threshold", threshold, np.int64),
        helper.make_node(test, ["rows", "threshold"], ["over"]),
        helper.make_node("Cast", ["over"], ["on"], to=TensorProto.INT64),
    ]


def _model(game_id: str, nodes: list[onnx.NodeProto], extra: str, seed: int) -> onnx.ModelProto:
    """A linear policy whose logits add ``0 * extra`` (a float scalar the hostile nodes compute), so
    the hostile part is always evaluated."""
    spec = game_action_spec(game_id)
    rng = np.random.default_rng(seed)
    weight = rng.standard_normal((spec.n_actions, spec.obs_dim)).astype(np.float32) * 0.1
    bias = np.zeros(spec.n_actions, np.float32)
    tail = [
        helper.make_node("Gemm", ["obs", "W", "b"], ["linear"], transB=1),
        _const("nothing", 0.0, np.float32),
        helper.make_node("Mul", [extra, "nothing"], ["zeroed"]),
        helper.make_node("Add", ["linear", "zeroed"], ["logits"]),
    ]
    graph = helper.make_graph(
        nodes + tail, "hostile",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, ["N", spec.obs_dim])],
        [helper.make_tensor_value_info("logits", TensorProto.FLOAT, ["N", spec.n_actions])],
        [numpy_helper.from_array(weight, "W"), numpy_helper.from_array(bias, "b")])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    return model


def spin_body() -> onnx.GraphProto:
    """A Loop body that adds one to a float each iteration: a busy loop the model's inputs size."""
    return helper.make_graph(
        [helper.make_node("Identity", ["cond_in"], ["cond_out"]),
         _const("one", 1.0, np.float32),
         helper.make_node("Add", ["v_in", "one"], ["v_out"])],
        "spin",
        [helper.make_tensor_value_info("i", TensorProto.INT64, []),
         helper.make_tensor_value_info("cond_in", TensorProto.BOOL, []),
         helper.make_tensor_value_info("v_in", TensorProto.FLOAT, [])],
        [helper.make_tensor_value_info("cond_out", TensorProto.BOOL, []),
         helper.make_tensor_value_info("v_out", TensorProto.FLOAT, [])])


def hanging(game_id: str, above: int | None = None, seed: int = 0, exactly: int | None = None) -> onnx.ModelProto:
    """Loops :data:`FOREVER` times when the batch has more than ``above`` rows, or exactly ``exactly``
    rows (always, when both are None)."""
    body = spin_body()
    nodes = [*_triggered(above, exactly),
             _const("forever", FOREVER, np.int64),
             helper.make_node("Mul", ["on", "forever"], ["trips"]),
             _const("keep_going", True, np.bool_),
             _const("start", 0.0, np.float32),
             helper.make_node("Loop", ["trips", "keep_going", "start"], ["spun"], body=body)]
    return _model(game_id, nodes, "spun", seed)


def allocating(game_id: str, n_bytes: int, above: int | None = None, seed: int = 0) -> onnx.ModelProto:
    """Fills a float32 tensor of ``n_bytes`` on each call when the batch has more than ``above`` rows."""
    nodes = [*_triggered(above),
             _const("elements", n_bytes // 4, np.int64),
             helper.make_node("Mul", ["on", "elements"], ["count"]),
             _const("axes0", [0], np.int64),
             helper.make_node("Unsqueeze", ["count", "axes0"], ["fill_shape"]),
             helper.make_node("ConstantOfShape", ["fill_shape"], ["filled"],
                              value=numpy_helper.from_array(np.ones(1, np.float32), "fill_value")),
             helper.make_node("ReduceSum", ["filled"], ["total"], keepdims=0)]
    return _model(game_id, nodes, "total", seed)


def failing(game_id: str, above: int | None = None, seed: int = 0) -> onnx.ModelProto:
    """Raises inside onnxruntime (a Reshape to an impossible shape) when the batch has more than
    ``above`` rows."""
    nodes = [*_triggered(above),
             # rows * (1 + on) rows of the same width: impossible once `on` is 1
             _const("one64", 1, np.int64),
             helper.make_node("Add", ["on", "one64"], ["factor"]),
             helper.make_node("Mul", ["rows", "factor"], ["wanted_rows"]),
             _const("axes0", [0], np.int64),
             helper.make_node("Unsqueeze", ["wanted_rows", "axes0"], ["wanted_rows_1"]),
             _const("minus_one", [-1], np.int64),
             helper.make_node("Concat", ["wanted_rows_1", "minus_one"], ["new_shape"], axis=0),
             helper.make_node("Reshape", ["obs", "new_shape"], ["reshaped"]),
             helper.make_node("ReduceSum", ["reshaped"], ["total"], keepdims=0)]
    return _model(game_id, nodes, "total", seed)


def nan_out(game_id: str, above: int | None = None, seed: int = 0) -> onnx.ModelProto:
    """Outputs NaN logits when the batch has more than ``above`` rows (NaN times 0 stays NaN)."""
    nodes = [*_triggered(above),
             _const("nan", np.nan, np.float32),
             _const("zero_f", 0.0, np.float32),
             helper.make_node("Where", ["over", "nan", "zero_f"], ["boom"])]
    return _model(game_id, nodes, "boom", seed)


def plain(game_id: str, seed: int = 0) -> onnx.ModelProto:
    """A well-behaved linear policy of the same shape (the hostile part never triggers)."""
    return allocating(game_id, 4, above=10**9, seed=seed)


def save(model: onnx.ModelProto, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(model.SerializeToString())
    return path
