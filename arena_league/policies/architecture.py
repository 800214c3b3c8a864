"""A policy's architecture: its family, sizes and spaces, checked, and its seeded parameters.

An :class:`Architecture` is what an arena-policy manifest declares (family, sizes, the game's
observation and action spaces); two agents with equal architectures stack into one bundle.
:func:`check_architecture` and :func:`architecture_from_manifest` refuse inconsistent sizes with
the valid values; :func:`init_parameters` draws an agent's parameters as a pure function of
``(architecture, seed)``; :func:`check_parameters` checks given weights against an architecture.
The torch modules that run these parameters are in :mod:`arena_league.policies.families`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import nn

from arena_league.policies.errors import ManifestError
from arena_league.policies.policy import ActionSpec

__all__ = [
    "ACTION_TYPES", "ACTIVATIONS", "FAMILIES", "NOISES",
    "Architecture", "GridLayout", "architecture_from_manifest", "check_architecture", "check_parameters",
    "init_parameters",
]

FAMILIES: tuple[str, ...] = ("mlp", "cnn", "gru")
ACTIVATIONS: tuple[str, ...] = ("tanh", "relu")
ACTION_TYPES: tuple[str, ...] = ("discrete", "continuous")
#: How a continuous agent turns its ``tanh`` output ``mean`` into an action: ``"none"`` plays the
#: mean; ``"gaussian"`` plays ``clip(mean + exp(log_std) z, -1, 1)`` and ``"squashed"``
#: ``tanh(atanh(mean) + exp(log_std) z)``, z standard normal from the engine's uniforms: PPO's
#: two continuous heads (``PPOConfig.continuous_head`` "clip" and "tanh"), so a snapshot plays the
#: policy its learner trained. The noisy kinds carry a ``log_std`` parameter ``[act_dim]``.
NOISES: tuple[str, ...] = ("none", "gaussian", "squashed")

#: Orthogonal-init gains (the PPO implementation details of Huang et al., ICLR blog track 2022).
_HIDDEN_GAIN = math.sqrt(2.0)
_HEAD_GAIN = 0.01


@dataclass(frozen=True)
class GridLayout:
    """Where a grid lies in a flat observation: ``obs[offset : offset + C*H*W]`` as ``[C, H, W]``."""

    channels: int
    height: int
    width: int
    offset: int = 0

    @property
    def size(self) -> int:
        return self.channels * self.height * self.width


@dataclass(frozen=True)
class Architecture:
    """One policy family with its sizes and the game spaces it reads and writes.

    Two agents with equal architectures stack into one bundle.
    """

    family: str
    obs_dim: int
    action_type: str
    n_actions: int = 0
    act_dim: int = 0
    hidden: tuple[int, ...] = (64, 64)
    activation: str = "tanh"
    #: ``cnn`` only: the grid part of the observation.
    grid: GridLayout | None = None
    #: ``cnn`` only: output channels of each convolution.
    conv_channels: tuple[int, ...] = ()
    #: ``cnn`` only: odd kernel side of each convolution.
    kernel_size: int = 3
    #: ``gru`` only: size of the recurrent state.
    gru_size: int = 0
    #: continuous only: one of :data:`NOISES` (a learned ``log_std`` unless ``"none"``).
    noise: str = "none"

    def __post_init__(self) -> None:
        object.__setattr__(self, "hidden", tuple(int(h) for h in self.hidden))
        object.__setattr__(self, "conv_channels", tuple(int(c) for c in self.conv_channels))
        check_architecture(self)

    @property
    def out_dim(self) -> int:
        """Width of the head: logits for discrete games, the action for continuous ones."""
        return self.n_actions if self.action_type == "discrete" else self.act_dim

    @property
    def recurrent(self) -> bool:
        return self.family == "gru"

    @property
    def state_shape(self) -> tuple[int, ...]:
        """Shape of one seat's recurrent state (``()`` for feed-forward families)."""
        return (self.gru_size,) if self.recurrent else ()

    @property
    def spec(self) -> ActionSpec:
        return ActionSpec(self.action_type, self.obs_dim, self.n_actions if self.action_type == "discrete" else 0,
                          self.act_dim if self.action_type == "continuous" else 0)

    def sizes(self) -> dict[str, Any]:
        """The family's sizes as written in a manifest's ``"sizes"``."""
        sizes: dict[str, Any] = {"hidden": list(self.hidden), "activation": self.activation}
        if self.family == "cnn":
            assert self.grid is not None
            sizes.update(grid={"channels": self.grid.channels, "height": self.grid.height,
                               "width": self.grid.width, "offset": self.grid.offset},
                         conv_channels=list(self.conv_channels), kernel_size=self.kernel_size)
        if self.family == "gru":
            sizes["gru_size"] = self.gru_size
        if self.noise != "none":
            sizes["noise"] = self.noise
        return sizes

    def spaces(self) -> dict[str, Any]:
        """The game spaces as written in a manifest's ``"spaces"``."""
        spaces: dict[str, Any] = {"obs_dim": self.obs_dim, "action_type": self.action_type}
        if self.action_type == "discrete":
            spaces["n_actions"] = self.n_actions
        else:
            spaces["act_dim"] = self.act_dim
        return spaces

    def mlp_input_dim(self) -> int:
        """Width of the first fully connected layer's input."""
        if self.family == "cnn":
            assert self.grid is not None
            return self.conv_channels[-1] * self.grid.height * self.grid.width + self.obs_dim - self.grid.size
        return self.obs_dim

    def parameter_shapes(self) -> dict[str, tuple[int, ...]]:
        """Name and shape of every parameter of one agent (the safetensors layout), in forward order."""
        shapes: dict[str, tuple[int, ...]] = {}
        if self.family == "cnn":
            assert self.grid is not None
            c_in, k = self.grid.channels, self.kernel_size
            for i, c_out in enumerate(self.conv_channels):
                shapes[f"conv.{i}.weight"] = (c_out, c_in, k, k)
                shapes[f"conv.{i}.bias"] = (c_out,)
                c_in = c_out
        width = self.mlp_input_dim()
        for i, h in enumerate(self.hidden):
            shapes[f"hidden.{i}.weight"] = (h, width)
            shapes[f"hidden.{i}.bias"] = (h,)
            width = h
        if self.family == "gru":
            g = self.gru_size
            shapes.update({"gru.weight_ih": (3 * g, width), "gru.weight_hh": (3 * g, g),
                           "gru.bias_ih": (3 * g,), "gru.bias_hh": (3 * g,)})
            width = g
        shapes["head.weight"] = (self.out_dim, width)
        shapes["head.bias"] = (self.out_dim,)
        if self.noise != "none":
            shapes["log_std"] = (self.act_dim,)
        return shapes

    def n_parameters(self) -> int:
        return sum(math.prod(s) for s in self.parameter_shapes().values())


def check_architecture(arch: Architecture) -> None:
    """Raise :class:`ManifestError` naming the first inconsistent size, with the valid values."""
    def positive(name: str, value: Any) -> None:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ManifestError(f"{arch.family} policy: {name} must be a positive integer, not {value!r}")

    if arch.family not in FAMILIES:
        raise ManifestError(f"unknown policy family {arch.family!r}; known families: {', '.join(FAMILIES)}")
    if arch.action_type not in ACTION_TYPES:
        raise ManifestError(f"unknown action_type {arch.action_type!r}; valid: {', '.join(ACTION_TYPES)}")
    if arch.activation not in ACTIVATIONS:
        raise ManifestError(f"unknown activation {arch.activation!r}; valid: {', '.join(ACTIVATIONS)}")
    positive("obs_dim", arch.obs_dim)
    positive("n_actions" if arch.action_type == "discrete" else "act_dim", arch.out_dim)
    for h in arch.hidden:
        positive("every hidden size", h)
    if arch.family == "cnn":
        if arch.grid is None or not arch.conv_channels:
            raise ManifestError("cnn policy: give 'grid' (channels, height, width, offset of the grid in the "
                                "observation) and at least one entry in 'conv_channels'")
        for name in ("channels", "height", "width"):
            positive(f"grid {name}", getattr(arch.grid, name))
        if arch.grid.offset < 0 or arch.grid.offset + arch.grid.size > arch.obs_dim:
            raise ManifestError(f"cnn policy: the grid [{arch.grid.channels}, {arch.grid.height}, {arch.grid.width}] "
                                f"at offset {arch.grid.offset} needs {arch.grid.offset + arch.grid.size} observation "
                                f"cells, but obs_dim is {arch.obs_dim}")
        for c in arch.conv_channels:
            positive("every conv channel count", c)
        positive("kernel_size", arch.kernel_size)
        if arch.kernel_size % 2 == 0:
            raise ManifestError(f"cnn policy: kernel_size must be odd ('same' padding), not {arch.kernel_size}")
    elif arch.grid is not None or arch.conv_channels:
        raise ManifestError(f"{arch.family} policy: 'grid' and 'conv_channels' belong to the cnn family only")
    if arch.family == "gru":
        positive("gru_size", arch.gru_size)
    elif arch.gru_size:
        raise ManifestError(f"{arch.family} policy: 'gru_size' belongs to the gru family only")
    if arch.noise not in NOISES:
        raise ManifestError(f"unknown noise {arch.noise!r}; valid: {', '.join(NOISES)}")
    if arch.noise != "none" and arch.action_type != "continuous":
        raise ManifestError(f"noise {arch.noise!r} belongs to continuous agents; a discrete agent samples its "
                            "logits (leave 'noise' out)")


def architecture_from_manifest(family: Any, sizes: Any, spaces: Mapping[str, Any]) -> Architecture:
    """Build an :class:`Architecture` from a manifest's ``family``, ``sizes`` and ``spaces``."""
    if family not in FAMILIES:
        raise ManifestError(f"unknown policy family {family!r} in manifest.json; known families: "
                            f"{', '.join(FAMILIES)} (save your policy as one of them, or export it to ONNX)")
    if not isinstance(sizes, Mapping):
        raise ManifestError(f"manifest 'sizes' must be an object such as {{\"hidden\": [64, 64]}}, not {sizes!r}")
    allowed = {"hidden", "activation", "noise"} | {"cnn": {"grid", "conv_channels", "kernel_size"},
                                          "gru": {"gru_size"}}.get(family, set())
    unknown = sorted(set(sizes) - allowed)
    if unknown:
        raise ManifestError(f"unknown size(s) {', '.join(map(repr, unknown))} for the {family} family; "
                            f"valid: {', '.join(sorted(allowed))}")
    kwargs: dict[str, Any] = {}
    try:
        if "hidden" in sizes:
            kwargs["hidden"] = tuple(_as_int(h, "hidden") for h in _as_list(sizes["hidden"], "hidden"))
        if "activation" in sizes:
            kwargs["activation"] = sizes["activation"]
        if "noise" in sizes:
            kwargs["noise"] = sizes["noise"]
        if family == "cnn":
            grid = sizes.get("grid")
            if not isinstance(grid, Mapping) or set(grid) - {"channels", "height", "width", "offset"} or \
                    not {"channels", "height", "width"} <= set(grid):
                raise ManifestError("cnn manifest: 'grid' must be {\"channels\": C, \"height\": H, \"width\": W, "
                                    f"\"offset\": O}} (the grid's place in the flat observation), not {grid!r}")
            kwargs["grid"] = GridLayout(*(_as_int(grid[k], f"grid {k}") for k in ("channels", "height", "width")),
                                        offset=_as_int(grid.get("offset", 0), "grid offset"))
            kwargs["conv_channels"] = tuple(_as_int(c, "conv_channels")
                                            for c in _as_list(sizes.get("conv_channels", []), "conv_channels"))
            kwargs["kernel_size"] = _as_int(sizes.get("kernel_size", 3), "kernel_size")
        if family == "gru":
            kwargs["gru_size"] = _as_int(sizes.get("gru_size", 0), "gru_size")
        action_type = spaces.get("action_type")
        out_key = "n_actions" if action_type == "discrete" else "act_dim"
        if out_key not in spaces:
            raise ManifestError(f"manifest 'spaces' needs 'obs_dim', 'action_type' and, for "
                                f"{action_type or 'discrete'} actions, {out_key!r}; got {dict(spaces)!r}")
        return Architecture(family=family, obs_dim=_as_int(spaces.get("obs_dim"), "obs_dim"),
                            action_type=action_type, **{out_key: _as_int(spaces[out_key], out_key)}, **kwargs)
    except (TypeError, KeyError) as error:
        raise ManifestError(f"manifest sizes or spaces are malformed ({error}); see an example with "
                            "`arena_league.policies.save_arena_policy`") from None


def _as_int(value: Any, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ManifestError(f"manifest {name} must be an integer, not {value!r}")
    return value


def _as_list(value: Any, name: str) -> list:
    if not isinstance(value, list):
        raise ManifestError(f"manifest {name} must be a list of integers, not {value!r}")
    return value


# --- seeded initialisation ------------------------------------------------------------------------

def init_parameters(arch: Architecture, seed: int) -> dict[str, torch.Tensor]:
    """Fresh float32 parameters of one agent, a pure function of ``(arch, seed)``.

    Orthogonal weights (gain sqrt 2 in the body, 0.01 in the head, so a new agent starts near
    uniform play), zero biases and ``log_std``; the GRU takes torch's default uniform(+-1/sqrt(gru_size)).
    """
    generator = torch.Generator().manual_seed(int(seed))
    params: dict[str, torch.Tensor] = {}
    for name, shape in arch.parameter_shapes().items():
        tensor = torch.empty(shape, dtype=torch.float32)
        if name.startswith("gru."):
            bound = 1.0 / math.sqrt(arch.gru_size)
            nn.init.uniform_(tensor, -bound, bound, generator=generator)
        elif name.endswith(".bias") or name == "log_std":
            tensor.zero_()
        else:
            gain = _HEAD_GAIN if name.startswith("head.") else _HIDDEN_GAIN
            nn.init.orthogonal_(tensor.view(shape[0], -1), gain=gain, generator=generator)
        params[name] = tensor
    return params


def check_parameters(arch: Architecture, params: Mapping[str, Any]) -> dict[str, torch.Tensor]:
    """The parameters as float32 tensors, checked against ``arch``: every name present with its
    shape, nothing extra, every value finite. Raises :class:`ManifestError` naming the first problem."""
    expected = arch.parameter_shapes()
    missing = [n for n in expected if n not in params]
    extra = sorted(set(params) - set(expected))
    if missing or extra:
        parts = ([f"missing {', '.join(missing)}"] if missing else []) + ([f"unexpected {', '.join(extra)}"]
                                                                        if extra else [])
        raise ManifestError(f"weights do not match the {arch.family} family with sizes {arch.sizes()}: "
                            f"{'; '.join(parts)}. Expected tensors: "
                            + ", ".join(f"{n} {list(s)}" for n, s in expected.items()))
    checked: dict[str, torch.Tensor] = {}
    for name, shape in expected.items():
        tensor = torch.as_tensor(params[name])
        if not tensor.is_floating_point():
            raise ManifestError(f"weight {name} has dtype {tensor.dtype}; weights are floating point (float32)")
        if tuple(tensor.shape) != shape:
            raise ManifestError(f"weight {name} has shape {list(tensor.shape)}, but the {arch.family} family with "
                                f"sizes {arch.sizes()} and obs_dim {arch.obs_dim} needs {list(shape)}")
        tensor = tensor.detach().to(torch.float32).contiguous()
        if not torch.isfinite(tensor).all():
            raise ManifestError(f"weight {name} holds NaN or infinite values; save finite weights")
        checked[name] = tensor
    return checked
