"""Policy families (MLP, CNN, GRU) as batched torch modules, and populations stacked as one bundle.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) ranks a new agent against a base population of 100 agents per game, so
evaluation runs a whole population at once. Here one family with equal sizes *stacks*: the
weights of P agents live in tensors with a leading ``[P, ...]`` axis and one forward computes every
row of a batch with the weights of the agent that owns it.

Families (one agent; ``out`` is ``n_actions`` logits for discrete games, ``act_dim`` for
continuous ones, where the head ends in ``tanh`` so the action lies in [-1, 1]):

* ``mlp``: ``obs -> [Linear -> act] * len(hidden) -> Linear head``.
* ``cnn``: for observations with a grid part (``grid``: channels, height, width, and the offset
  of the grid in the flat observation, channel-major ``[C, H, W]``; see each game's manual):
  ``grid -> [Conv2d(k, stride 1, 'same' padding) -> act] * len(conv_channels) -> flatten``,
  concatenated with the rest of the observation (cells before the grid, then after it), then
  ``[Linear -> act] * len(hidden) -> Linear head``.
* ``gru``: ``obs -> [Linear -> act] * len(hidden) -> GRUCell(gru_size) -> Linear head``; the
  recurrent state is the GRU's hidden vector ``float32[N, gru_size]`` (``state_in``/``state_out``).

Parameter names (the tensors of ``weights.safetensors``) are those of the single-agent torch
modules: ``hidden.<i>.weight|bias`` (``[out, in]``), ``conv.<i>.weight|bias``
(``[out, in, k, k]``), ``gru.weight_ih|weight_hh|bias_ih|bias_hh`` (torch's ``GRUCell``, gates
``r, z, n``), ``head.weight|bias``.

Stacking: the rows of a batch are sorted by owner and laid into a padded ``[K, M, features]``
tensor (K row groups of at most M rows, one owner each; group k is member k whenever that pads
the batch moderately, so the stacked weights are used without copying them); every layer is then
one stacked matrix product (numpy's ``matmul`` on the tensors' memory: 2x faster than
``torch.baddbmm`` here) and the CNN's convolutions one grouped ``conv2d``. Measured on the shared
2-core machine, one thread, 100 agents with random owners (ms per forward and sampling):

==============================  ======  ==================  ===================
family (sizes), rows            dtype   stacked             one call per agent
==============================  ======  ==================  ===================
mlp (25-64-64-5), 800 rows      f64     1.2 - 1.4           9 - 10
mlp (25-64-64-5), 800 rows      f32     0.7 - 1.3           8 - 19
gru (25-64-gru64-5), 800 rows   f64     5.5 - 6.4           17 - 20
cnn (GoBang, 16-16 conv, fc64)  f32     24 - 34             37 - 41
cnn, same, 200 rows             f64     80 - 290            50 - 54
==============================  ======  ==================  ===================

(The first layout tried, gathering a weight matrix per row, took 92 ms for the MLP case.) The
CNN's flattened features make its first fully connected layer hold most of its weights (230 k
per agent), so a CNN population is bound by memory traffic, and torch's float64 convolution has
no fast path: give CNN populations ``compute_dtype=torch.float32`` when speed matters.

Policies compute in float64 by default: a row's float32 result can change in its last bits
with the other rows of the batch (BLAS blocking; we measured up to 4e-7), which would make a
sampled action depend, very rarely, on how seats were batched; in float64 the same rows gave
bit-identical logits in every batch we measured.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from itertools import pairwise
from typing import Any

import numpy as np
import torch
from scipy.special import ndtri
from torch import nn
from torch.nn import functional as F

from arena_league.policies.architecture import (
    Architecture,
    check_parameters,
    init_parameters,
)
from arena_league.policies.onnx_export import export_onnx
from arena_league.policies.policy import ActionSpec, Policy, legal_mask, sample_from_logits

_ACTIVATION_FN = {"tanh": torch.tanh, "relu": torch.relu}


def _tanh_in_place(x: torch.Tensor) -> torch.Tensor:
    """``tanh`` written over ``x`` by numpy, whose kernel was 3-4x faster than torch's CPU one
    for float64 on our machine (inference only: the stacked bundle holds no gradients)."""
    np.tanh(x.numpy(), out=x.numpy())
    return x


#: Activations of the stacked bundle, applied in place to fresh intermediate tensors.
_STACKED_ACTIVATION = {"tanh": _tanh_in_place, "relu": torch.relu_}
#: Uniforms are kept this far inside (0, 1) before the inverse normal CDF (a draw of exactly 0).
_U_EPS = 1e-12


# --- single-agent modules -------------------------------------------------------------------------

class FamilyNet(nn.Module):
    """One agent of any family: ``forward(obs, state=None) -> (out, state_out)``.

    ``out`` is logits (discrete) or the ``tanh`` action (continuous); ``state_out`` is None for
    feed-forward families. Plain torch layers, so the training code can optimise it directly.
    """

    def __init__(self, arch: Architecture) -> None:
        super().__init__()
        self.architecture = arch
        self._act = _ACTIVATION_FN[arch.activation]
        if arch.family == "cnn":
            assert arch.grid is not None
            channels = (arch.grid.channels, *arch.conv_channels)
            self.conv = nn.ModuleList(nn.Conv2d(c_in, c_out, arch.kernel_size, padding=arch.kernel_size // 2)
                                      for c_in, c_out in pairwise(channels))
        widths = (arch.mlp_input_dim(), *arch.hidden)
        self.hidden = nn.ModuleList(nn.Linear(a, b) for a, b in pairwise(widths))
        if arch.family == "gru":
            self.gru = nn.GRUCell(widths[-1], arch.gru_size)
        self.head = nn.Linear(arch.gru_size if arch.family == "gru" else widths[-1], arch.out_dim)
        if arch.noise != "none":
            self.log_std = nn.Parameter(torch.zeros(arch.act_dim))

    def forward(self, obs: torch.Tensor, state: torch.Tensor | None = None
                ) -> tuple[torch.Tensor, torch.Tensor | None]:
        arch = self.architecture
        x = obs
        if arch.family == "cnn":
            grid = arch.grid
            assert grid is not None
            planes = obs[:, grid.offset: grid.offset + grid.size].reshape(-1, grid.channels, grid.height, grid.width)
            for conv in self.conv:
                planes = self._act(conv(planes))
            x = torch.cat([planes.flatten(1), obs[:, : grid.offset], obs[:, grid.offset + grid.size:]], dim=1)
        for layer in self.hidden:
            x = self._act(layer(x))
        state_out = None
        if arch.family == "gru":
            if state is None:
                state = x.new_zeros(x.shape[0], arch.gru_size)
            x = state_out = self.gru(x, state)
        out = self.head(x)
        return (torch.tanh(out) if arch.action_type == "continuous" else out), state_out


def build_module(arch: Architecture, params: Mapping[str, Any] | None = None, seed: int = 0) -> FamilyNet:
    """A single-agent module with ``params`` (checked), or fresh ones from ``seed``."""
    module = FamilyNet(arch)
    module.load_state_dict(check_parameters(arch, params) if params is not None else init_parameters(arch, seed))
    return module.eval()


# --- stacked populations ----------------------------------------------------------------------------

@dataclass(frozen=True)
class RowGroups:
    """Rows of a batch laid out by owner: row ``order[j]`` goes to ``padded[slot[j], pos[j]]``.

    ``group_owner[k]`` is the agent whose weights group ``k`` uses (an agent may own several
    groups when it holds many more rows than the others).
    """

    order: torch.Tensor
    slot: torch.Tensor
    pos: torch.Tensor
    group_owner: torch.Tensor
    n_rows: int
    rows_per_group: int
    #: True when group k is member k for every member, so stacked weights are used without a copy.
    identity: bool

    @classmethod
    def of(cls, owners: torch.Tensor, n_members: int) -> RowGroups:
        n = int(owners.shape[0])
        counts = torch.bincount(owners, minlength=n_members)
        n_used = int((counts > 0).sum())
        largest = int(counts.max()) if n else 0
        order = torch.argsort(owners, stable=True)
        sorted_owners = owners[order]
        starts = torch.cumsum(counts, 0) - counts
        rank = torch.arange(n) - starts[sorted_owners]
        # Group k = member k (absent members get an empty group) when padding stays moderate:
        # the stacked weights are then used as they are, and copying them (all the weights of a
        # layer, for every call) costs more than computing a few padded rows.
        padded_rows = n_members * largest
        if padded_rows <= 2 * n + n_members or (2 * n_used >= n_members and padded_rows <= 4 * n + n_members):
            return cls(order, sorted_owners, rank, torch.arange(n_members), n, max(1, largest), True)
        # Otherwise groups for present owners only, each of at most ``cap`` rows (a crowded owner
        # gets several groups), so padding stays below about twice the batch.
        cap = largest if n_used * largest <= 2 * n + n_used else max(1, -(-n // max(n_used, 1)))
        groups_per_owner = (counts + cap - 1) // cap
        first_group = torch.cumsum(groups_per_owner, 0) - groups_per_owner
        slot = first_group[sorted_owners] + torch.div(rank, cap, rounding_mode="floor")
        # computed in numpy: torch.repeat_interleave syncs its output size and stalls on busy threads
        group_owner = torch.from_numpy(np.repeat(np.arange(n_members), groups_per_owner.numpy()))
        return cls(order, slot, rank % cap, group_owner, n, max(1, min(cap, largest)), False)

    @property
    def n_groups(self) -> int:
        return int(self.group_owner.shape[0])

    def pad(self, rows: torch.Tensor) -> torch.Tensor:
        """``[N, *F]`` rows -> ``[K, M, *F]`` groups, zero padded."""
        padded = rows.new_zeros((self.n_groups, self.rows_per_group, *rows.shape[1:]))
        padded[self.slot, self.pos] = rows[self.order]
        return padded

    def unpad(self, padded: torch.Tensor) -> torch.Tensor:
        """``[K, M, *F]`` groups -> ``[N, *F]`` rows in the batch's order."""
        rows = padded.new_empty((self.n_rows, *padded.shape[2:]))
        rows[self.order] = padded[self.slot, self.pos]
        return rows

    def weights(self, stacked: torch.Tensor) -> torch.Tensor:
        """The ``[K, ...]`` weights of each group from ``[P, ...]`` stacked weights."""
        return stacked if self.identity else stacked.index_select(0, self.group_owner)


class StackedFamily(nn.Module):
    """P agents of one architecture as one tensor bundle: every parameter is ``[P, *shape]``.

    ``forward(obs, owners, state=None)`` computes row ``i`` of ``obs`` with the weights of agent
    ``owners[i]`` in one batched call per layer; it equals running each agent's
    :class:`FamilyNet` on its own rows.
    """

    def __init__(self, arch: Architecture, members: Sequence[Mapping[str, Any]],
                 dtype: torch.dtype = torch.float32) -> None:
        super().__init__()
        if not members:
            raise ValueError("a stacked population needs at least one member")
        self.architecture = arch
        self.n_members = len(members)
        self._act = _STACKED_ACTIVATION[arch.activation]
        checked = [check_parameters(arch, m) for m in members]
        for name in arch.parameter_shapes():
            stacked = torch.stack([m[name] for m in checked]).to(dtype)
            # Linear weights are kept as [P, in, out] so each layer is one baddbmm.
            if (name.endswith(".weight") and stacked.dim() == 3) or name.startswith("gru.weight"):
                stacked = stacked.transpose(1, 2).contiguous()
            self.register_buffer(_buffer_name(name), stacked)

    @classmethod
    def from_seeds(cls, arch: Architecture, seeds: Sequence[int], dtype: torch.dtype = torch.float32
                   ) -> StackedFamily:
        return cls(arch, [init_parameters(arch, s) for s in seeds], dtype)

    def member_parameters(self, index: int) -> dict[str, torch.Tensor]:
        """Agent ``index``'s parameters in the single-agent layout (float32)."""
        params = {}
        for name in self.architecture.parameter_shapes():
            tensor = getattr(self, _buffer_name(name))[index]
            if (name.endswith(".weight") and tensor.dim() == 2) or name.startswith("gru.weight"):
                tensor = tensor.t()
            params[name] = tensor.to(torch.float32).contiguous().clone()
        return params

    def _param(self, name: str) -> torch.Tensor:
        return getattr(self, _buffer_name(name))

    def log_std_of(self, owners: np.ndarray) -> np.ndarray:
        """``[N, act_dim]``: the ``log_std`` of each row's owner (noisy continuous families)."""
        return self._param("log_std").numpy()[owners]

    @torch.inference_mode()
    def forward(self, obs: torch.Tensor, owners: torch.Tensor, state: torch.Tensor | None = None
                ) -> tuple[torch.Tensor, torch.Tensor | None]:
        """Outputs (and next states) of every row with its owner's weights; inference only (the
        bundle evaluates populations; train with :class:`FamilyNet`)."""
        arch = self.architecture
        dtype = self._param("head.bias").dtype
        obs = obs.to(dtype)
        owners = owners.to(torch.int64)
        if obs.shape[0] == 0:
            empty_state = obs.new_zeros((0, arch.gru_size)) if arch.recurrent else None
            return obs.new_zeros((0, arch.out_dim)), empty_state
        groups = RowGroups.of(owners, self.n_members)
        x = groups.pad(obs)  # [K, M, obs_dim]
        if arch.family == "cnn":
            x = self._conv_features(x, groups)
        for i in range(len(arch.hidden)):
            x = self._act(self._linear(x, groups, f"hidden.{i}"))
        state_out = None
        if arch.family == "gru":
            h = groups.pad(state.to(dtype)) if state is not None else x.new_zeros(x.shape[0], x.shape[1], arch.gru_size)
            x = self._gru_cell(x, h, groups)
            state_out = groups.unpad(x)
        out = groups.unpad(self._linear(x, groups, "head"))
        return (torch.tanh(out) if arch.action_type == "continuous" else out), state_out

    def _linear(self, x: torch.Tensor, groups: RowGroups, name: str) -> torch.Tensor:
        return _batched_affine(x, groups.weights(self._param(f"{name}.weight")),
                               groups.weights(self._param(f"{name}.bias")))

    def _conv_features(self, x: torch.Tensor, groups: RowGroups) -> torch.Tensor:
        """Grouped convolution: the K row groups become K channel groups of one ``conv2d``."""
        arch = self.architecture
        grid = arch.grid
        assert grid is not None
        k_groups, m_rows = x.shape[0], x.shape[1]
        planes = x[:, :, grid.offset: grid.offset + grid.size]
        planes = planes.reshape(k_groups, m_rows, grid.channels, grid.height, grid.width)
        planes = planes.transpose(0, 1).reshape(m_rows, k_groups * grid.channels, grid.height, grid.width)
        for i in range(len(arch.conv_channels)):
            weight = groups.weights(self._param(f"conv.{i}.weight"))  # [K, out, in, k, k]
            bias = groups.weights(self._param(f"conv.{i}.bias"))
            planes = self._act(F.conv2d(planes, weight.reshape(-1, *weight.shape[2:]), bias.reshape(-1),
                                        padding=arch.kernel_size // 2, groups=k_groups))
        features = planes.reshape(m_rows, k_groups, -1).transpose(0, 1)
        return torch.cat([features, x[:, :, : grid.offset], x[:, :, grid.offset + grid.size:]], dim=2)

    def _gru_cell(self, x: torch.Tensor, h: torch.Tensor, groups: RowGroups) -> torch.Tensor:
        """torch's GRUCell, batched over groups: r, z, n gates."""
        gi = _batched_affine(x, groups.weights(self._param("gru.weight_ih")), groups.weights(self._param("gru.bias_ih")))
        gh = _batched_affine(h, groups.weights(self._param("gru.weight_hh")), groups.weights(self._param("gru.bias_hh")))
        i_r, i_z, i_n = gi.chunk(3, dim=2)
        h_r, h_z, h_n = gh.chunk(3, dim=2)
        r = torch.sigmoid_(i_r + h_r)
        z = torch.sigmoid_(i_z + h_z)
        n = _tanh_in_place(torch.addcmul(i_n, r, h_n))
        return torch.lerp(n, h, z)  # (1 - z) * n + z * h


def _batched_affine(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor) -> torch.Tensor:
    """``x[k] @ weight[k] + bias[k]`` for every group k: ``[K, M, in] -> [K, M, out]``.

    numpy's stacked ``matmul`` ran 2x faster than ``torch.baddbmm`` here (float32 and float64);
    the tensors share memory with the arrays, so nothing is copied."""
    out = np.matmul(x.numpy(), weight.numpy())
    out += bias.numpy()[:, None, :]
    return torch.from_numpy(out)


def _buffer_name(name: str) -> str:
    return name.replace(".", "__")


# --- policies -------------------------------------------------------------------------------------

def _actions(values: np.ndarray, arch: Architecture, uniforms: np.ndarray, mask: np.ndarray | None,
             greedy: bool, log_std: np.ndarray | None = None) -> np.ndarray:
    if arch.action_type == "continuous":
        if greedy or log_std is None:
            return values.astype(np.float32)
        return noisy_actions(values, log_std, uniforms, arch.noise)
    mask = legal_mask(mask, values.shape)
    if greedy:
        masked = np.where(mask, values, -np.inf) if mask is not None else values
        return masked.argmax(axis=1).astype(np.int64)
    return sample_from_logits(values, uniforms, mask)


def noisy_actions(mean: np.ndarray, log_std: np.ndarray, uniforms: np.ndarray, noise: str = "gaussian"
                  ) -> np.ndarray:
    """Continuous actions drawn around ``mean`` (``[N, act_dim]`` in [-1, 1]) with standard
    deviations ``exp(log_std)`` (``[N, act_dim]`` or ``[act_dim]``), one uniform per component
    turned into a standard normal by its inverse CDF (see :data:`NOISES`). ``float32[N, act_dim]``."""
    mean = np.asarray(mean, dtype=np.float64)
    u = np.clip(np.asarray(uniforms, dtype=np.float64)[:, : mean.shape[1]], _U_EPS, 1.0 - _U_EPS)
    step = np.exp(np.asarray(log_std, dtype=np.float64)) * ndtri(u)
    if noise == "squashed":
        return np.tanh(np.arctanh(np.clip(mean, -1.0 + _U_EPS, 1.0 - _U_EPS)) + step).astype(np.float32)
    return np.clip(mean + step, -1.0, 1.0).astype(np.float32)


def _check_obs(obs: np.ndarray, spec: ActionSpec, name: str) -> np.ndarray:
    obs = np.asarray(obs, dtype=np.float32)
    if obs.ndim != 2 or obs.shape[1] != spec.obs_dim:
        raise ValueError(f"policy {name} reads observations float32[N, {spec.obs_dim}], got shape {obs.shape}; "
                         "pass the game's base observation (boards or global state appended? slice them off)")
    return obs


class TorchPolicy(Policy):
    """One agent of a torch family as a :class:`Policy`.

    Discrete: samples ``softmax(logits)`` restricted to legal actions with the engine's
    uniforms (``greedy=True``: the most likely legal action). Continuous: the ``tanh`` action, with
    the architecture's noise around it (:data:`NOISES`; ``greedy=True``: the mean).
    """

    def __init__(self, arch: Architecture, params: Mapping[str, Any] | None = None, *, seed: int = 0,
                 name: str | None = None, greedy: bool = False, compute_dtype: torch.dtype = torch.float64) -> None:
        self.architecture = arch
        self.spec = arch.spec
        self.recurrent = arch.recurrent
        self.greedy = greedy
        self.compute_dtype = compute_dtype
        self.name = name or arch.family
        self.module = build_module(arch, params, seed)
        # Built on first use: agents that are only stacked never need a copy in compute_dtype.
        self._compute: FamilyNet | None = self.module if compute_dtype == torch.float32 else None

    def parameters(self) -> dict[str, torch.Tensor]:
        """The agent's float32 parameters (the safetensors layout)."""
        return {k: v.detach().clone() for k, v in self.module.state_dict().items()}

    def export_onnx(self, path: str | None = None, game_id: str | None = None) -> bytes:
        """This agent as ONNX bytes (written to ``path`` when given); see :mod:`.onnx_export`."""
        return export_onnx(self.architecture, self.parameters(), path, game_id)

    def initial_state(self, n: int) -> np.ndarray | None:
        return np.zeros((n, *self.architecture.state_shape), dtype=np.float32) if self.recurrent else None

    def forward(self, obs: np.ndarray, state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """Raw outputs (logits or the tanh action, in ``compute_dtype``) and the next state."""
        obs = _check_obs(obs, self.spec, self.name)
        with torch.inference_mode():
            x = torch.from_numpy(obs).to(self.compute_dtype)
            h = torch.from_numpy(np.asarray(state, dtype=np.float32)).to(self.compute_dtype) \
                if self.recurrent and state is not None else None
            if self._compute is None:
                self._compute = build_module(self.architecture, self.parameters()).to(self.compute_dtype)
            out, h_out = self._compute(x, h)
        return out.numpy(), (h_out.numpy().astype(np.float32) if h_out is not None else None)

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        out, next_state = self.forward(obs, state)
        log_std = self.module.log_std.detach().numpy() if self.architecture.noise != "none" else None
        return _actions(out, self.architecture, uniforms, mask, self.greedy, log_std), next_state


class StackedPolicy(Policy):
    """P agents of one architecture as one :class:`Policy`: ``act(..., owners=)`` computes every
    row with its owner's weights in one batched forward (see :class:`StackedFamily`)."""

    def __init__(self, arch: Architecture, members: Sequence[Mapping[str, Any]], *,
                 names: Sequence[str] | None = None, greedy: bool = False,
                 compute_dtype: torch.dtype = torch.float64) -> None:
        self.architecture = arch
        self.spec = arch.spec
        self.recurrent = arch.recurrent
        self.greedy = greedy
        self.compute_dtype = compute_dtype
        self.bundle = StackedFamily(arch, members, compute_dtype)
        self.member_names = tuple(names) if names is not None else tuple(
            f"{arch.family}#{i}" for i in range(len(members)))
        if len(self.member_names) != len(members):
            raise ValueError(f"{len(self.member_names)} names for {len(members)} members")
        self.name = f"stacked-{arch.family}x{len(members)}"

    @classmethod
    def from_policies(cls, policies: Sequence[TorchPolicy]) -> StackedPolicy:
        """Stack agents of one architecture (and the same sampling settings)."""
        first = policies[0]
        for p in policies[1:]:
            if _stack_key(p) != _stack_key(first):
                raise ValueError(f"cannot stack {p.name} ({p.architecture}) with {first.name} "
                                 f"({first.architecture}): stacking needs one family with equal sizes and spaces")
        return cls(first.architecture, [p.parameters() for p in policies], names=[p.name for p in policies],
                   greedy=first.greedy, compute_dtype=first.compute_dtype)

    @classmethod
    def from_seeds(cls, arch: Architecture, seeds: Sequence[int], **kwargs: Any) -> StackedPolicy:
        return cls(arch, [init_parameters(arch, s) for s in seeds], **kwargs)

    @property
    def n_members(self) -> int:
        return self.bundle.n_members

    def member(self, index: int) -> TorchPolicy:
        """Agent ``index`` alone, as its own policy."""
        return TorchPolicy(self.architecture, self.bundle.member_parameters(index), name=self.member_names[index],
                           greedy=self.greedy, compute_dtype=self.compute_dtype)

    def export_member_onnx(self, index: int, path: str | None = None, game_id: str | None = None) -> bytes:
        """Member ``index`` as ONNX bytes (written to ``path`` when given)."""
        return self.member(index).export_onnx(path, game_id)

    def initial_state(self, n: int) -> np.ndarray | None:
        return np.zeros((n, *self.architecture.state_shape), dtype=np.float32) if self.recurrent else None

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None, owners: np.ndarray | None = None
            ) -> tuple[np.ndarray, np.ndarray | None]:
        """As :meth:`Policy.act`, plus ``owners``: ``int[N]``, the member (0..P-1) playing each row."""
        obs = _check_obs(obs, self.spec, self.name)
        if owners is None:
            if self.n_members != 1:
                raise ValueError(f"{self.name} holds {self.n_members} agents: pass owners=int[N], the member "
                                 "playing each row")
            owners = np.zeros(obs.shape[0], dtype=np.int64)
        owners = np.asarray(owners, dtype=np.int64)
        if owners.shape != (obs.shape[0],) or (owners.size and (owners.min() < 0 or owners.max() >= self.n_members)):
            raise ValueError(f"owners must be int[{obs.shape[0]}] with values in 0..{self.n_members - 1}")
        with torch.inference_mode():
            h = torch.from_numpy(np.asarray(state, dtype=np.float32)) if self.recurrent and state is not None else None
            out, h_out = self.bundle(torch.from_numpy(obs), torch.from_numpy(owners), h)
        next_state = h_out.numpy().astype(np.float32) if h_out is not None else None
        log_std = self.bundle.log_std_of(owners) if self.architecture.noise != "none" else None
        return _actions(out.numpy(), self.architecture, uniforms, mask, self.greedy, log_std), next_state


def _stack_key(policy: TorchPolicy) -> tuple:
    return policy.architecture, policy.greedy, policy.compute_dtype


@dataclass(frozen=True)
class PolicyGroup:
    """Policies the match engine runs as one: ``members`` index the list given to
    :func:`stack_policies`; ``policy`` is a :class:`StackedPolicy` when several torch agents of
    one architecture were stacked, else the member's own policy."""

    policy: Policy
    members: tuple[int, ...]
    #: True when ``policy`` is a :class:`StackedPolicy` (its ``act`` takes ``owners``).
    stacked: bool = False

    def act(self, obs: np.ndarray, uniforms: np.ndarray, owners: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """Actions for rows played by ``owners[i]`` (positions in ``members``)."""
        if self.stacked:
            assert isinstance(self.policy, StackedPolicy)
            return self.policy.act(obs, uniforms, mask, state, owners=owners)
        return self.policy.act(obs, uniforms, mask, state)


def stack_policies(policies: Sequence[Policy]) -> list[PolicyGroup]:
    """Group the torch agents among ``policies`` by architecture into stacked bundles; every
    other policy (ONNX, scripted) stays a group of its own. Groups keep first-appearance order."""
    groups: dict[Any, list[int]] = {}
    order: list[Any] = []
    for i, policy in enumerate(policies):
        key = ("torch", _stack_key(policy)) if isinstance(policy, TorchPolicy) else ("single", i)
        if key not in groups:
            groups[key] = []
            order.append(key)
        groups[key].append(i)
    result = []
    for key in order:
        members = groups[key]
        if key[0] == "torch" and len(members) > 1:
            stacked = StackedPolicy.from_policies([policies[i] for i in members])  # type: ignore[misc]
            result.append(PolicyGroup(stacked, tuple(members), True))
        else:
            result.append(PolicyGroup(policies[members[0]], tuple(members)))
    return result


def with_spaces(arch: Architecture, spec: ActionSpec) -> Architecture:
    """``arch`` with the observation and action sizes of ``spec`` (for building a family for a game)."""
    return replace(arch, obs_dim=spec.obs_dim, action_type=spec.action_type,
                   n_actions=spec.n_actions if spec.action_type == "discrete" else 0,
                   act_dim=spec.act_dim if spec.action_type == "continuous" else 0)
