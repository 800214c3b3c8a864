"""Export one agent of a policy family to ONNX, in the league's I/O convention (:mod:`.onnx_policy`).

Arena (Song et al., AAAI 2020) ranks agents submitted as trained weights; the league's portable,
code-free form of an agent is an ONNX graph with one input ``obs`` ``float32[N, obs_dim]`` and one
output, ``logits`` ``float32[N, n_actions]`` (discrete) or ``action`` ``float32[N, act_dim]`` in
[-1, 1] (continuous); recurrent agents add ``state_in`` / ``state_out`` ``float32[N, gru_size]``.
``N`` is a dynamic batch dimension. A continuous agent with noise (``Architecture.noise``) adds the
output ``log_std`` ``float32[N, act_dim]`` (its learned constant, repeated per row) and, when the
noise is ``"squashed"``, says so in the metadata (``arena_league.noise``).

The graph is written node by node with the ``onnx`` helper API from the family's parameters
(the same structure as :class:`arena_league.policies.families.FamilyNet`), not traced, so the
export needs no exporter package and gives the same bytes for the same weights. Opset 17, which
every onnxruntime since 1.14 runs.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from arena_league.policies.architecture import Architecture, check_parameters

OPSET = 17
IR_VERSION = 8
#: Metadata keys written into exported models (and checked on load when present).
META_GAME = "arena_league.game"
META_FAMILY = "arena_league.family"
META_NOISE = "arena_league.noise"


class _Graph:
    """Accumulates nodes and initializers with unique names."""

    def __init__(self) -> None:
        self.nodes: list[onnx.NodeProto] = []
        self.initializers: list[onnx.TensorProto] = []
        self._count = 0

    def const(self, name: str, value: np.ndarray) -> str:
        self.initializers.append(numpy_helper.from_array(np.ascontiguousarray(value), name))
        return name

    def op(self, op_type: str, inputs: list[str], output: str | None = None, **attrs: Any) -> str:
        self._count += 1
        out = output or f"{op_type.lower()}_{self._count}"
        self.nodes.append(helper.make_node(op_type, inputs, [out], name=f"{op_type}_{self._count}", **attrs))
        return out


def build_onnx_model(arch: Architecture, params: Mapping[str, Any], game_id: str | None = None) -> onnx.ModelProto:
    """The ONNX model of one agent with parameters ``params`` (checked against ``arch``)."""
    weights = {name: tensor.numpy().astype(np.float32) for name, tensor in check_parameters(arch, params).items()}
    g = _Graph()
    act = "Tanh" if arch.activation == "tanh" else "Relu"
    x = "obs"
    if arch.family == "cnn":
        grid = arch.grid
        assert grid is not None
        end = grid.offset + grid.size

        def cells(start: int, stop: int) -> str:
            return g.op("Slice", [x, g.const(f"slice_{start}_start", np.array([start], np.int64)),
                                  g.const(f"slice_{start}_stop", np.array([stop], np.int64)),
                                  g.const(f"slice_{start}_axis", np.array([1], np.int64))])

        planes = g.op("Reshape", [cells(grid.offset, end),
                                  g.const("grid_shape", np.array([-1, grid.channels, grid.height, grid.width],
                                                                 np.int64))])
        pad = arch.kernel_size // 2
        for i in range(len(arch.conv_channels)):
            planes = g.op("Conv", [planes, g.const(f"conv.{i}.weight", weights[f"conv.{i}.weight"]),
                                   g.const(f"conv.{i}.bias", weights[f"conv.{i}.bias"])],
                          kernel_shape=[arch.kernel_size] * 2, pads=[pad] * 4, strides=[1, 1])
            planes = g.op(act, [planes])
        parts = [g.op("Flatten", [planes], axis=1)]
        if grid.offset > 0:
            parts.append(cells(0, grid.offset))
        if end < arch.obs_dim:
            parts.append(cells(end, arch.obs_dim))
        x = parts[0] if len(parts) == 1 else g.op("Concat", parts, axis=1)
    for i in range(len(arch.hidden)):
        x = g.op("Gemm", [x, g.const(f"hidden.{i}.weight", weights[f"hidden.{i}.weight"]),
                          g.const(f"hidden.{i}.bias", weights[f"hidden.{i}.bias"])], transB=1)
        x = g.op(act, [x])
    inputs = [helper.make_tensor_value_info("obs", TensorProto.FLOAT, ["N", arch.obs_dim])]
    outputs = []
    if arch.family == "gru":
        x = _gru_cell(g, x, weights, arch.gru_size)
        inputs.append(helper.make_tensor_value_info("state_in", TensorProto.FLOAT, ["N", arch.gru_size]))
        outputs.append(helper.make_tensor_value_info("state_out", TensorProto.FLOAT, ["N", arch.gru_size]))
    out_name = "logits" if arch.action_type == "discrete" else "action"
    head = g.op("Gemm", [x, g.const("head.weight", weights["head.weight"]), g.const("head.bias", weights["head.bias"])],
                None if arch.action_type == "continuous" else out_name, transB=1)
    if arch.action_type == "continuous":
        g.op("Tanh", [head], out_name)
    outputs.insert(0, helper.make_tensor_value_info(out_name, TensorProto.FLOAT, ["N", arch.out_dim]))
    if arch.noise != "none":
        g.op("Expand", [g.const("log_std.value", weights["log_std"][None]), g.op("Shape", [out_name])], "log_std")
        outputs.append(helper.make_tensor_value_info("log_std", TensorProto.FLOAT, ["N", arch.act_dim]))
    graph = helper.make_graph(g.nodes, f"arena_league_{arch.family}", inputs, outputs, g.initializers)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)],
                              producer_name="arena-league", ir_version=IR_VERSION)
    metadata = {META_FAMILY: arch.family}
    if arch.noise == "squashed":
        metadata[META_NOISE] = arch.noise
    if game_id is not None:
        metadata[META_GAME] = game_id
    helper.set_model_props(model, metadata)
    onnx.checker.check_model(model, full_check=True)
    return model


def _gru_cell(g: _Graph, x: str, weights: Mapping[str, np.ndarray], size: int) -> str:
    """torch's GRUCell (gates r, z, n; ``n = tanh(W_in x + b_in + r * (W_hn h + b_hn))``) as one
    step of ONNX's GRU operator, whose gates are ordered z, r, h and which, with
    ``linear_before_reset=1``, applies the reset gate after the recurrent product as torch does."""
    def zrn(matrix: np.ndarray) -> np.ndarray:
        r, z, n = np.split(matrix, 3, axis=0)
        return np.concatenate([z, r, n], axis=0)

    w = g.const("gru.W", zrn(weights["gru.weight_ih"])[None])
    r = g.const("gru.R", zrn(weights["gru.weight_hh"])[None])
    b = g.const("gru.B", np.concatenate([zrn(weights["gru.bias_ih"]), zrn(weights["gru.bias_hh"])])[None])
    axis0 = g.const("axis0", np.array([0], np.int64))
    sequence = g.op("Unsqueeze", [x, axis0])  # [1, N, in]: a sequence of one step
    h0 = g.op("Unsqueeze", ["state_in", axis0])  # [1, N, size]
    node = helper.make_node("GRU", [sequence, w, r, b, "", h0], ["", "gru_h"], name="GRU_cell",
                            hidden_size=size, linear_before_reset=1)
    g.nodes.append(node)
    return g.op("Squeeze", ["gru_h", axis0], "state_out")


def export_onnx(arch: Architecture, params: Mapping[str, Any], path: str | os.PathLike[str] | None = None,
                game_id: str | None = None) -> bytes:
    """Serialise one agent to ONNX bytes (and write them to ``path`` when given).

    ``game_id`` is recorded in the model's metadata (``arena_league.game``) so loading it for
    another game is refused.
    """
    data = build_onnx_model(arch, params, game_id).SerializeToString()
    if path is not None:
        with open(path, "wb") as handle:
            handle.write(data)
    return data
