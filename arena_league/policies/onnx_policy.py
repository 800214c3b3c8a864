"""ONNX agents: checking a model's inputs and outputs against a game, and running it batched.

Arena (Song et al., AAAI 2020) evaluates agents that people train anywhere; the league takes them
as ONNX graphs in one I/O convention: input ``obs`` ``float32[N, obs_dim]``; output
``logits`` ``float32[N, n_actions]`` (discrete) or ``action`` ``float32[N, act_dim]`` in [-1, 1]
(continuous); recurrent agents add ``state_in`` / ``state_out`` ``float32[N, ...]`` of one shape.
A continuous agent that samples adds the output ``log_std`` ``float32[N, act_dim]``: it then plays
``clip(action + exp(log_std) z, -1, 1)``, or ``tanh(atanh(action) + exp(log_std) z)`` when its
metadata says ``arena_league.noise: squashed``, with z standard normal from the match's own draws.
Other outputs (a value head, say) are allowed and not computed.

:class:`OnnxPolicy` runs the graph with onnxruntime on the CPU, one intra-op thread by default
and sequential execution, so the same observations always give the same outputs. The batch
dimension should be dynamic; a model exported with a fixed batch B is run on chunks of B rows
(padded), which for B = 1 means one call per row, and its name says so (``onnx-batch1:<sha>``).

A model given as bytes is self-contained: a tensor naming an external data file anywhere in it
(subgraphs, functions and sparse tensors included) is refused, since onnxruntime would look that
file up relative to the process's current directory. Reading an ``.onnx`` file with
:func:`~arena_league.policies.artifacts.read_artifact` folds the data file beside it in first.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import onnx
import onnxruntime as ort
from google.protobuf.message import DecodeError
from onnxruntime.capi import onnxruntime_pybind11_state as _ort_state

from arena_league.policies.architecture import NOISES
from arena_league.policies.errors import CorruptArtifactError, SpaceMismatchError
from arena_league.policies.families import noisy_actions
from arena_league.policies.onnx_export import META_GAME, META_NOISE
from arena_league.policies.policy import ActionSpec, Policy, legal_mask, sample_from_logits

_FLOAT = onnx.TensorProto.FLOAT
#: onnxruntime's exception types (they derive from Exception directly).
_ORT_ERRORS: tuple[type[BaseException], ...] = (RuntimeError, ValueError, *(
    getattr(_ort_state, name) for name in ("Fail", "InvalidGraph", "InvalidArgument", "NotImplemented",
                                           "RuntimeException", "InvalidProtobuf", "NoSuchFile", "EPFail")
    if hasattr(_ort_state, name)))
_OUT_NAME = {"discrete": "logits", "continuous": "action"}
#: torch's export of one self-contained ONNX file (no external data file).
ONE_FILE_EXPORT = 'torch.onnx.export(model, (obs,), "model.onnx", dynamo=True, external_data=False)'
#: How a torch user gets an ONNX agent the league takes, named in every external-data refusal.
EXTERNAL_DATA_FIX = ("submit the .onnx file itself with its .onnx.data beside it in the same folder, as "
                     'torch.onnx.export(model, (obs,), "model.onnx", dynamo=True) writes them, and the league folds '
                     f"the data in; or export one self-contained file: {ONE_FILE_EXPORT}")


class PolicyOutputError(RuntimeError):
    """A policy produced NaN or infinite outputs during play (the agent, not the engine, is at fault)."""


@dataclass(frozen=True)
class OnnxSignature:
    """What an ONNX agent reads and writes, as read from its graph."""

    obs_dim: int | None  # None when the feature dimension is symbolic
    output: str  # "logits" | "action"
    out_dim: int | None
    #: ``None`` for a dynamic batch dimension, else the fixed batch size.
    batch: int | None
    state_shape: tuple[int, ...] = ()
    #: One of ``families.NOISES``: ``"none"`` unless a continuous model outputs ``log_std``.
    noise: str = "none"

    @property
    def recurrent(self) -> bool:
        return bool(self.state_shape)

    @property
    def action_type(self) -> str:
        return "discrete" if self.output == "logits" else "continuous"


def parse_onnx(data: bytes, source: str = "the ONNX file") -> onnx.ModelProto:
    """Parse and check an ONNX model; a truncated or corrupt file raises :class:`CorruptArtifactError`."""
    fix = "re-export the model (torch.onnx.export or arena_league.policies.export_onnx) and submit the whole file"
    try:
        model = onnx.load_model_from_string(data)
    except (DecodeError, ValueError, RuntimeError) as error:
        raise CorruptArtifactError(f"{source} is not a readable ONNX model (truncated or corrupt: {error}); {fix}"
                                   ) from None
    if not model.HasField("graph") or not model.graph.output or not model.opset_import:
        raise CorruptArtifactError(f"{source} is not a complete ONNX model (no graph, outputs or opset: the file is "
                                   f"truncated or not ONNX); {fix}")
    for place in model_tensors(model):
        if uses_external_data(place.tensor):
            raise CorruptArtifactError(f"{source}: {place.where} keeps its data in an external file "
                                       f"({external_location(place.tensor)!r}), which the model's bytes alone do "
                                       f"not carry; {EXTERNAL_DATA_FIX}")
    try:
        onnx.checker.check_model(model)
    except (onnx.checker.ValidationError, ValueError, RuntimeError) as error:
        message = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise CorruptArtifactError(f"{source} is not a valid ONNX model ({message}); {fix}") from None
    return model


class TensorPlace(NamedTuple):
    """A tensor of a model and where it sits."""

    tensor: onnx.TensorProto
    #: For messages: ``initializer 'w'``, ``If node 'choose' attribute 'then_branch' > initializer 'w'``.
    where: str
    #: True for the main graph's dense initializers and its nodes' tensor attributes; False inside a
    #: subgraph (an ``If``/``Loop``/``Scan`` body), a function, a training graph or a sparse tensor.
    main: bool


def model_tensors(model: onnx.ModelProto) -> Iterator[TensorPlace]:
    """Every tensor a model holds, its subgraphs, functions and training graphs walked recursively."""
    yield from _graph_tensors(model.graph, "", True)
    for function in model.functions:
        for node in function.node:
            yield from _node_tensors(node, f"function {function.name!r} > ", False)
    for index, info in enumerate(model.training_info):
        for name in ("initialization", "algorithm"):
            if info.HasField(name):
                yield from _graph_tensors(getattr(info, name), f"training_info[{index}].{name} > ", False)


def _graph_tensors(graph: onnx.GraphProto, prefix: str, main: bool) -> Iterator[TensorPlace]:
    for tensor in graph.initializer:
        yield TensorPlace(tensor, f"{prefix}initializer {tensor.name!r}", main)
    for sparse in graph.sparse_initializer:
        yield from _sparse_tensors(sparse, f"{prefix}sparse initializer {sparse.values.name!r}")
    for node in graph.node:
        yield from _node_tensors(node, prefix, main)


def _node_tensors(node: onnx.NodeProto, prefix: str, main: bool) -> Iterator[TensorPlace]:
    for attribute in node.attribute:
        node_name = f" {node.name!r}" if node.name else ""
        where = f"{prefix}{node.op_type} node{node_name} attribute {attribute.name!r}"
        if attribute.HasField("t"):
            yield TensorPlace(attribute.t, where, main)
        for tensor in attribute.tensors:
            yield TensorPlace(tensor, where, main)
        if attribute.HasField("sparse_tensor"):
            yield from _sparse_tensors(attribute.sparse_tensor, where)
        for sparse in attribute.sparse_tensors:
            yield from _sparse_tensors(sparse, where)
        if attribute.HasField("g"):
            yield from _graph_tensors(attribute.g, f"{where} > ", False)
        for graph in attribute.graphs:
            yield from _graph_tensors(graph, f"{where} > ", False)


def _sparse_tensors(sparse: onnx.SparseTensorProto, where: str) -> Iterator[TensorPlace]:
    yield TensorPlace(sparse.values, f"{where} (values)", False)
    yield TensorPlace(sparse.indices, f"{where} (indices)", False)


def uses_external_data(tensor: onnx.TensorProto) -> bool:
    """Whether a tensor points at an external data file (or carries external-data entries at all)."""
    return tensor.data_location == onnx.TensorProto.EXTERNAL or len(tensor.external_data) > 0


def external_location(tensor: onnx.TensorProto) -> str:
    """The ``location`` a tensor's external data names ("" when it names none)."""
    return next((entry.value for entry in tensor.external_data if entry.key == "location"), "")


def _dims(value: onnx.ValueInfoProto) -> tuple[int, list[int | str | None]] | None:
    """(element type, dims) of a tensor value; a dim is an int, a symbolic name, or None."""
    tensor = value.type.tensor_type
    if not value.type.HasField("tensor_type"):
        return None
    if not tensor.HasField("shape"):
        return tensor.elem_type, []
    dims: list[int | str | None] = []
    for d in tensor.shape.dim:
        dims.append(d.dim_value if d.HasField("dim_value") else (d.dim_param or None))
    return tensor.elem_type, dims


def _shape_text(value: onnx.ValueInfoProto) -> str:
    info = _dims(value)
    if info is None:
        return "a non-tensor value"
    elem, dims = info
    try:
        kind = onnx.helper.tensor_dtype_to_np_dtype(elem).name
    except (KeyError, TypeError, ValueError):
        kind = onnx.TensorProto.DataType.Name(elem).lower() if elem in onnx.TensorProto.DataType.values() else "unknown"
    return f"{kind}[{', '.join('N' if d is None else str(d) for d in dims)}]"


def onnx_signature(model: onnx.ModelProto, spec: ActionSpec, game_id: str, source: str = "the ONNX model"
                   ) -> OnnxSignature:
    """Check the model's inputs and outputs against ``spec`` (the module's I/O convention).

    Raises :class:`SpaceMismatchError` naming the wrong names or sizes and the expected ones.
    """
    graph = model.graph
    initializers = {t.name for t in graph.initializer}
    inputs = {v.name: v for v in graph.input if v.name not in initializers}
    outputs = {v.name: v for v in graph.output}
    out_name = _OUT_NAME[spec.action_type]
    out_dim = spec.n_actions if spec.action_type == "discrete" else spec.act_dim
    expected = (f"{game_id} ({spec.action_type} actions) expects input obs float32[N, {spec.obs_dim}] and output "
                f"{out_name} float32[N, {out_dim}]")
    for prop in model.metadata_props:
        if prop.key == META_GAME and prop.value != game_id:
            value = prop.value
            raise SpaceMismatchError(f"{source} was exported for {value}, not {game_id}; submit it for {value} or "
                                     f"export an agent trained on {game_id}")
    unknown = sorted(set(inputs) - {"obs", "state_in"})
    if "obs" not in inputs or unknown:
        found = ", ".join(f"{n} {_shape_text(v)}" for n, v in inputs.items()) or "none"
        raise SpaceMismatchError(f"{source} has inputs {found}; {expected} (recurrent agents add state_in / "
                                 "state_out). Rename the inputs when exporting (input_names=['obs'])")
    obs = _dims(inputs["obs"])
    if obs is None or obs[0] != _FLOAT or len(obs[1]) != 2:
        raise SpaceMismatchError(f"{source}: input obs is {_shape_text(inputs['obs'])}; {expected}")
    batch_dim, obs_dim = obs[1]
    if isinstance(obs_dim, int) and obs_dim != spec.obs_dim:
        raise SpaceMismatchError(f"{source}: input obs has {obs_dim} features (float32[N, {obs_dim}]), but {expected}; "
                                 f"re-export the agent for {game_id}'s observation (layout in the game's manual)")
    if out_name not in outputs:
        other = _OUT_NAME["continuous" if spec.action_type == "discrete" else "discrete"]
        found = ", ".join(f"{n} {_shape_text(v)}" for n, v in outputs.items())
        hint = (f" ({other} is the output of {'continuous' if other == 'action' else 'discrete'} agents)"
                if other in outputs else "")
        raise SpaceMismatchError(f"{source} has outputs {found}{hint}; {expected}. Name the output {out_name!r} "
                                 f"when exporting (output_names=['{out_name}'])")
    out = _dims(outputs[out_name])
    if out is None or out[0] != _FLOAT or len(out[1]) not in (0, 2):
        raise SpaceMismatchError(f"{source}: output {out_name} is {_shape_text(outputs[out_name])}; {expected}")
    got_out = out[1][1] if len(out[1]) == 2 else None
    if isinstance(got_out, int) and got_out != out_dim:
        what = "actions" if spec.action_type == "discrete" else "action components"
        raise SpaceMismatchError(f"{source}: output {out_name} has {got_out} {what} (float32[N, {got_out}]), but "
                                 f"{expected}; re-export the agent for {game_id}")
    state_shape: tuple[int, ...] = ()
    if "state_in" in inputs or "state_out" in outputs:
        if "state_in" not in inputs or "state_out" not in outputs:
            raise SpaceMismatchError(f"{source}: a recurrent agent has both an input state_in and an output "
                                     "state_out of the same shape float32[N, ...]; one of them is missing")
        state_in, state_out = _dims(inputs["state_in"]), _dims(outputs["state_out"])
        if (state_in is None or state_in[0] != _FLOAT or len(state_in[1]) < 2
                or not all(isinstance(d, int) and d > 0 for d in state_in[1][1:])):
            raise SpaceMismatchError(f"{source}: state_in is {_shape_text(inputs['state_in'])}; it must be "
                                     "float32[N, ...] with fixed sizes after the batch dimension")
        state_shape = tuple(int(d) for d in state_in[1][1:])  # type: ignore[arg-type]
        if state_out is not None and state_out[1] and list(state_out[1][1:]) != list(state_shape):
            raise SpaceMismatchError(f"{source}: state_out is {_shape_text(outputs['state_out'])} but state_in is "
                                     f"{_shape_text(inputs['state_in'])}; they must have the same shape")
    batch = batch_dim if isinstance(batch_dim, int) and batch_dim > 0 else None
    return OnnxSignature(obs_dim if isinstance(obs_dim, int) else None, out_name,
                         got_out if isinstance(got_out, int) else None, batch, state_shape,
                         _noise(model, outputs, spec, source))


def _noise(model: onnx.ModelProto, outputs: dict, spec: ActionSpec, source: str) -> str:
    """How a continuous model samples: ``"none"`` without a ``log_std`` output, else its metadata's
    ``arena_league.noise`` (``"gaussian"`` when absent)."""
    if spec.action_type != "continuous" or "log_std" not in outputs:
        return "none"
    dims = _dims(outputs["log_std"])
    if dims is None or dims[0] != _FLOAT or len(dims[1]) != 2 or (isinstance(dims[1][1], int)
                                                                   and dims[1][1] != spec.act_dim):
        raise SpaceMismatchError(f"{source}: output log_std is {_shape_text(outputs['log_std'])}; a sampling agent's "
                                 f"log_std is float32[N, {spec.act_dim}] (one per action component)")
    noise = {prop.key: prop.value for prop in model.metadata_props}.get(META_NOISE, "gaussian")
    if noise not in NOISES[1:]:
        raise SpaceMismatchError(f"{source}: metadata {META_NOISE} is {noise!r}; valid: {', '.join(NOISES[1:])} "
                                 "(or leave it out for gaussian)")
    return noise


def session_options(intra_op_threads: int = 1) -> ort.SessionOptions:
    """onnxruntime options for deterministic CPU inference."""
    options = ort.SessionOptions()
    options.intra_op_num_threads = intra_op_threads
    options.inter_op_num_threads = 1
    options.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    options.log_severity_level = 4  # fatal only: a failed run comes back as an exception with its status
    return options


class OnnxPolicy(Policy):
    """An ONNX agent, batched over seats (see the module docstring)."""

    def __init__(self, data: bytes, spec: ActionSpec, game_id: str, *, digest: str = "", greedy: bool = False,
                 intra_op_threads: int = 1, source: str = "the ONNX file", model: onnx.ModelProto | None = None
                 ) -> None:
        model = model if model is not None else parse_onnx(data, source)
        self.signature = onnx_signature(model, spec, game_id, source)
        self.spec = spec
        self.game_id = game_id
        self.greedy = greedy
        self.recurrent = self.signature.recurrent
        self.digest = digest
        try:
            self.session = ort.InferenceSession(data, session_options(intra_op_threads),
                                                providers=["CPUExecutionProvider"])
        except _ORT_ERRORS as error:
            first = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
            raise CorruptArtifactError(f"onnxruntime cannot run {source} ({first}); export with standard ONNX "
                                       "operators (opset 13 to 21) and check it with onnx.checker") from None
        self._outputs = [self.signature.output] + (["state_out"] if self.recurrent else []) + (
            ["log_std"] if self.signature.noise != "none" else [])
        batch = self.signature.batch
        prefix = "onnx" if batch is None else f"onnx-batch{batch}"
        self.name = f"{prefix}:{digest[:12]}" if digest else prefix

    def initial_state(self, n: int) -> np.ndarray | None:
        return np.zeros((n, *self.signature.state_shape), dtype=np.float32) if self.recurrent else None

    def forward(self, obs: np.ndarray, state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """Raw outputs (``logits`` or ``action``, and ``state_out``) for ``float32[N, obs_dim]``."""
        out, next_state, _ = self._forward(obs, state)
        return out, next_state

    def _forward(self, obs: np.ndarray, state: np.ndarray | None
                 ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The outputs, the next state and (sampling agents) ``log_std``."""
        obs = np.ascontiguousarray(obs, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] != self.spec.obs_dim:
            raise ValueError(f"{self.name} reads observations float32[N, {self.spec.obs_dim}], got shape {obs.shape}")
        n = obs.shape[0]
        if self.recurrent and state is None:
            state = self.initial_state(n)
        if n == 0:
            out_dim = self.spec.n_actions if self.spec.action_type == "discrete" else self.spec.act_dim
            empty = np.zeros((0, out_dim), np.float32)
            return empty, state, (empty if self.signature.noise != "none" else None)
        batch = self.signature.batch
        if batch is None:
            return self._run(obs, state)
        # A model exported with a fixed batch size: run chunks of exactly that many rows.
        outs, states, log_stds = [], [], []
        for start in range(0, n, batch):
            rows = obs[start: start + batch]
            chunk_state = state[start: start + batch] if state is not None else None
            missing = batch - rows.shape[0]
            if missing:
                rows = np.concatenate([rows, np.zeros((missing, rows.shape[1]), np.float32)])
                if chunk_state is not None:
                    chunk_state = np.concatenate([chunk_state, np.zeros((missing, *chunk_state.shape[1:]),
                                                                        np.float32)])
            out, next_state, log_std = self._run(rows, chunk_state)
            outs.append(out[: batch - missing])
            if next_state is not None:
                states.append(next_state[: batch - missing])
            if log_std is not None:
                log_stds.append(log_std[: batch - missing])
        return (np.concatenate(outs), np.concatenate(states) if self.recurrent else None,
                np.concatenate(log_stds) if log_stds else None)

    def _run(self, obs: np.ndarray, state: np.ndarray | None
             ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        feeds = {"obs": obs}
        if self.recurrent:
            feeds["state_in"] = np.ascontiguousarray(state, dtype=np.float32)
        results = self.session.run(self._outputs, feeds)
        out = np.asarray(results[0], dtype=np.float32)
        expected = (obs.shape[0], self.spec.n_actions if self.spec.action_type == "discrete" else self.spec.act_dim)
        if out.shape != expected:
            raise SpaceMismatchError(f"{self.name}: output {self.signature.output} has shape {out.shape} for "
                                     f"{obs.shape[0]} observations; expected {expected}")
        next_state = None
        if self.recurrent:
            next_state = np.asarray(results[1], dtype=np.float32)
            if next_state.shape != (obs.shape[0], *self.signature.state_shape):
                raise SpaceMismatchError(f"{self.name}: state_out has shape {next_state.shape}; expected "
                                         f"{(obs.shape[0], *self.signature.state_shape)}")
        log_std = None
        if self.signature.noise != "none":
            log_std = np.asarray(results[-1], dtype=np.float32)
            if log_std.shape != expected:
                raise SpaceMismatchError(f"{self.name}: output log_std has shape {log_std.shape} for "
                                         f"{obs.shape[0]} observations; expected {expected}")
        return out, next_state, log_std

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        out, next_state, log_std = self._forward(obs, state)
        for name, values in ((self.signature.output, out), ("log_std", log_std)):
            bad = ~np.isfinite(values).all(axis=1) if values is not None else None
            if bad is not None and bad.any():
                raise PolicyOutputError(f"{self.name} output NaN or infinite {name} for {int(bad.sum())} of "
                                        f"{len(values)} observations (first: row {int(np.argmax(bad))})")
        if self.spec.action_type == "continuous":
            # The convention is tanh-bounded; clip float round-off just past +-1.
            out = np.clip(out, -1.0, 1.0)
            if log_std is None or self.greedy:
                return out, next_state
            return noisy_actions(out, log_std, uniforms, self.signature.noise), next_state
        mask = legal_mask(mask, out.shape)
        if self.greedy:
            return np.where(mask, out, -np.inf).argmax(axis=1) if mask is not None else out.argmax(axis=1), next_state
        return sample_from_logits(out, uniforms, mask), next_state
