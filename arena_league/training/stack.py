"""Learners stacked: the learners of one run act and update as one batched computation.

A run holds several PPO learners (D-PPO's per-seat learners, PBT's members; one for PPO, SP, CC
and CF). Each learner stays the owner of its weights, optimiser state and hyper-parameters (a
:class:`~arena_league.training.ppo.Learner`, what snapshots, PBT's exploit step and the warm start
read and write); a :class:`LearnerStack` copies them into tensors with a leading learner axis
``[L, ...]``, so that:

* **acting** (:meth:`LearnerStack.act`) is one stacked actor forward and one stacked critic forward
  per rollout step over every learner's rows, in numpy float32 (small matrices: numpy's per-call
  cost is a fraction of torch's), the rows grouped by learner into ``[L, M, features]``;
* **updating** (:meth:`LearnerStack.update`) runs every learner's PPO epochs together: per
  minibatch one stacked forward, one backward and one Adam step over the stacked tensors, with
  each learner's own minibatch rows (drawn from its own generator), its own advantage
  normalisation, loss terms, gradient-norm clip, step size and Adam moments. The learners'
  parameters do not interact, so a learner's result does not depend on which learners it was
  stacked with (``tests/test_training_stack.py`` trains the same seeds stacked and one by one).
  The backward is written out: the MLP's by :func:`_mlp_grad` (one autograd node for the whole
  network), and for categorical policies the whole loss's, which leaves no graph to build.

* **frozen snapshots** (SP's and CC's opponent pools) play through the same numpy forward
  (:class:`SnapshotPool`).

``tanh`` runs in numpy (forward) with its derivative ``1 - y^2`` (backward): on this machine's
torch build the CPU kernel took 130 us for a 1024 x 64 block, numpy 10 us.

Stacked learners share their actor's architecture (family ``mlp``), their critic's input width
and the settings that shape an update (epochs, minibatches, clipping of the value loss, advantage
normalisation, Adam's epsilon, the continuous head); learners that differ in those, and recurrent
or convolutional actors, are updated one by one by :func:`~arena_league.training.ppo.ppo_update`
(:func:`stacks_of` groups them).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from arena_league.policies.architecture import Architecture
from arena_league.policies.policy import Policy, legal_mask, sample_from_logits
from arena_league.training.ppo import (
    _ILLEGAL_LOGIT,
    _SQUASH_EPS,
    ActResult,
    Batch,
    Learner,
    UpdateStats,
)

__all__ = ["LearnerStack", "RowLayout", "SnapshotPool", "snapshot_pool", "stackable", "stacks_of"]

_BETA1, _BETA2 = 0.9, 0.999  # torch.optim.Adam's defaults, which every Learner's optimiser uses
_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)


def _mlp_run(theta: torch.Tensor, x: torch.Tensor, layers: tuple, activation: str
             ) -> tuple[torch.Tensor, list[torch.Tensor]]:
    """A stacked MLP ``x [L, M, in] -> [L, M, out]`` whose weights are columns of the flat ``theta
    [L, P]`` (``layers``: each layer's weight column, bias column, in and out); returns the output
    and each layer's input, which :func:`_mlp_grad` reads. ``tanh`` runs in numpy, in place."""
    L = theta.shape[0]
    inputs = [x]
    last = len(layers) - 1
    for i, (w, b, din, dout) in enumerate(layers):
        x = torch.bmm(x, theta[:, w: w + din * dout].view(L, din, dout)).add_(theta[:, None, b: b + dout])
        if i < last:
            if activation == "tanh":
                np.tanh(x.numpy(), out=x.numpy())
            else:
                x.clamp_(min=0.0)
            inputs.append(x)
    return x, inputs


def _mlp_grad(theta: torch.Tensor, inputs: list[torch.Tensor], grad: torch.Tensor, layers: tuple,
              activation: str) -> torch.Tensor:
    """The gradient ``[L, P]`` of a loss in ``theta`` through :func:`_mlp_run`, given the loss's
    gradient in the output (the inputs' own gradient is not needed: observations are data)."""
    L = theta.shape[0]
    grad_theta = torch.zeros_like(theta)
    grad = grad.contiguous()
    for i in range(len(layers) - 1, -1, -1):
        w, b, din, dout = layers[i]
        h = inputs[i]
        grad_theta[:, w: w + din * dout].view(L, din, dout).copy_(torch.bmm(h.transpose(1, 2), grad))
        grad_theta[:, b: b + dout] = grad.sum(1)
        if i == 0:
            break
        grad = torch.bmm(grad, theta[:, w: w + din * dout].view(L, din, dout).transpose(1, 2))
        if activation == "tanh":
            g, y = grad.numpy(), h.numpy()
            g *= 1.0 - y * y
        else:
            grad.mul_(h > 0)
    return grad_theta


class _StackedMLP(torch.autograd.Function):
    """:func:`_mlp_run` as one autograd node (instead of a few per layer), differentiated by
    :func:`_mlp_grad` into a ``[L, P]`` gradient that autograd adds to ``theta.grad``."""

    @staticmethod
    def forward(ctx, theta: torch.Tensor, x: torch.Tensor, layers: tuple, activation: str) -> torch.Tensor:
        out, inputs = _mlp_run(theta, x, layers, activation)
        ctx.save_for_backward(theta, *inputs)
        ctx.layers, ctx.activation = layers, activation
        return out

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> tuple:
        theta, *inputs = ctx.saved_tensors
        return _mlp_grad(theta, inputs, grad, ctx.layers, ctx.activation), None, None, None


def _stack_key(learner: Learner) -> tuple | None:
    """What learners must share to be stacked; None for an actor that does not stack."""
    arch, config = learner.architecture, learner.config
    if arch.family != "mlp":
        return None
    critic = learner.critic
    critic_width = 0 if critic is None else int(critic.hidden[0].in_features if critic.hidden else
                                                  critic.head.in_features)
    return (arch, critic_width, config.critic_hidden if critic is not None else (), config.num_minibatches,
            config.update_epochs, config.norm_adv, config.clip_vloss, config.adam_eps, config.continuous_head,
            learner.value_norm is not None, type(learner))


def stackable(learners: Sequence[Learner]) -> bool:
    """Whether ``learners`` can act and update as one stack."""
    keys = [_stack_key(lr) for lr in learners]
    return bool(keys) and keys[0] is not None and all(k == keys[0] for k in keys)


def stacks_of(codes: Sequence[int], learners: Sequence[Learner]) -> list[list[int]]:
    """The learner codes grouped into stacks (in first-seen order); an actor that does not stack,
    or one whose settings differ from every stack's, gets a group of its own."""
    groups: list[list[int]] = []
    keys: list[tuple | None] = []
    for code in codes:
        key = _stack_key(learners[code])
        for g, k in zip(groups, keys):
            if key is not None and k == key:
                g.append(code)
                break
        else:
            groups.append([code])
            keys.append(key)
    return groups


# --- parameters as stacks -----------------------------------------------------------------------------

def _layers(module: torch.nn.Module) -> list[tuple[torch.nn.Parameter, torch.nn.Parameter]]:
    """(weight ``[out, in]``, bias) of an MLP's hidden layers then its head."""
    return [(layer.weight, layer.bias) for layer in module.hidden] + [(module.head.weight, module.head.bias)]


class RowLayout:
    """Rows of a batch laid out by learner as ``[L, M, features]`` (M the most rows a learner
    holds; learners with fewer are padded with zeros), and the way back."""

    def __init__(self, members: np.ndarray, n_learners: int) -> None:
        members = np.asarray(members, dtype=np.int64)
        self.n, self.L = len(members), n_learners
        counts = np.bincount(members, minlength=n_learners)
        self.m = max(1, int(counts.max()))
        self.order = np.argsort(members, kind="stable")
        grouped = members[self.order]
        starts = np.cumsum(counts) - counts
        self.group_of, self.pos = grouped, np.arange(self.n) - starts[grouped]
        # every learner holds as many rows: a reshape of the ordered rows, no padding
        self.even = bool((counts == self.m).all())
        self.identity = self.even and bool((self.order == np.arange(self.n)).all())

    def group(self, rows: np.ndarray) -> np.ndarray:
        """``[N, F] -> [L, M, F]``."""
        if self.identity:
            return rows.reshape(self.L, self.m, -1)
        if self.even:
            return rows[self.order].reshape(self.L, self.m, -1)
        out = np.zeros((self.L, self.m, rows.shape[1]), dtype=rows.dtype)
        out[self.group_of, self.pos] = rows[self.order]
        return out

    def ungroup(self, grouped: np.ndarray) -> np.ndarray:
        """``[L, M, F] -> [N, F]`` in the rows' own order."""
        if self.identity:
            return grouped.reshape(self.n, -1)
        out = np.empty((self.n, grouped.shape[2]), dtype=grouped.dtype)
        out[self.order] = grouped.reshape(-1, grouped.shape[2]) if self.even else grouped[self.group_of, self.pos]
        return out


def _sample_categorical(logits: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None
                        ) -> tuple[np.ndarray, np.ndarray]:
    """``sample_from_logits`` (inverse CDF, one uniform per row) and the sample's log-probability
    (``_categorical_logprob``), from one softmax: the same numbers as those two functions."""
    z = logits.astype(np.float64)
    if mask is not None:
        z[~mask] = -np.inf
    z -= z.max(axis=1, keepdims=True)
    p = np.exp(z)
    total = p.sum(axis=1)
    cdf = np.cumsum(p, axis=1)
    cdf /= cdf[:, -1:]
    actions = np.minimum((cdf < uniforms[:, None]).sum(axis=1), logits.shape[1] - 1).astype(np.int64)
    return actions, z[np.arange(len(actions)), actions] - np.log(total)


@dataclass
class _Act:
    """A stacked network's float32 weights for acting: ``W [L, in, out]``, ``b [L, 1, out]``."""

    weights: list[np.ndarray]
    biases: list[np.ndarray]
    activation: str

    @classmethod
    def from_parameters(cls, members: Sequence[Mapping[str, torch.Tensor]], activation: str) -> _Act:
        """From agents' parameter dicts (the arena-policy layout: ``hidden.<i>.weight|bias``, ``head.*``)."""
        names = [f"hidden.{i}" for i in range(sum(1 for k in members[0] if k.startswith("hidden.")) // 2)] + ["head"]
        weights = [np.ascontiguousarray(np.stack([m[f"{n}.weight"].detach().numpy().T for m in members]))
                   for n in names]
        biases = [np.stack([m[f"{n}.bias"].detach().numpy()[None, :] for m in members]) for n in names]
        return cls(weights, biases, activation)

    def subset(self, members: np.ndarray) -> _Act:
        """The stack of the given members only."""
        return _Act([w[members] for w in self.weights], [b[members] for b in self.biases], self.activation)

    @classmethod
    def of(cls, modules: Sequence[torch.nn.Module], activation: str) -> _Act:
        layers = [_layers(m) for m in modules]
        weights = [np.ascontiguousarray(np.stack([ls[i][0].detach().numpy().T for ls in layers]))
                   for i in range(len(layers[0]))]
        biases = [np.stack([ls[i][1].detach().numpy()[None, :] for ls in layers]) for i in range(len(layers[0]))]
        return cls(weights, biases, activation)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """``[L, M, in] -> [L, M, out]``."""
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases)):
            x = np.matmul(x, w)
            x += b
            if i < last:
                if self.activation == "tanh":
                    np.tanh(x, out=x)
                else:
                    np.maximum(x, 0.0, out=x)
        return x


class _Flat:
    """The stack's trainable parameters as one ``[L, P]`` leaf (each learner's row its actor, its
    critic and its ``log_std``, weights transposed to ``[in, out]``), with Adam's moments and step
    counts in the same layout, so a minibatch's gradient clip and Adam step are a few operations
    over the whole stack. Read from the learners by :meth:`of`, written back by :meth:`write_back`."""

    def __init__(self, learners: Sequence[Learner], entries: list[tuple[str, tuple, bool, tuple]]) -> None:
        self.learners = list(learners)
        self.entries = entries
        L = len(learners)
        sizes = [math.prod(shape) for _, shape, _, _ in entries]
        self.offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
        P = int(self.offsets[-1])
        theta = torch.zeros(L, P)
        self.avg = torch.zeros(L, P)
        self.sq = torch.zeros(L, P)
        self.steps = torch.zeros(L, dtype=torch.float64)
        for e, (_, _shape, transpose, owners) in enumerate(entries):
            cols = slice(self.offsets[e], self.offsets[e + 1])
            for i, (learner, p) in enumerate(zip(learners, owners)):
                theta[i, cols] = self._stacked(p.detach(), transpose)
                state = learner.optimiser.state.get(p)
                if state:
                    self.avg[i, cols] = self._stacked(state["exp_avg"], transpose)
                    self.sq[i, cols] = self._stacked(state["exp_avg_sq"], transpose)
                    self.steps[i] = float(state["step"])
        self.theta = theta.requires_grad_(True)
        # per part, each layer's (weight column, bias column, in, out), as _StackedMLP reads them
        self.layouts: dict[str, tuple] = {}
        for e in range(0, len(entries) - 1, 2):
            part, (din, dout), _, _ = entries[e]
            if entries[e + 1][0] == part and part != "log_std":
                self.layouts[part] = (*self.layouts.get(part, ()), (int(self.offsets[e]), int(self.offsets[e + 1]),
                                                                    din, dout))
        self.log_std_column = next((int(self.offsets[e]) for e, entry in enumerate(entries) if entry[0] == "log_std"),
                                   None)

    @staticmethod
    def _stacked(t: torch.Tensor, transpose: bool) -> torch.Tensor:
        return (t.T if transpose else t).reshape(-1)

    @classmethod
    def of(cls, learners: Sequence[Learner], train_critic: bool) -> _Flat:
        entries: list[tuple[str, tuple, bool, tuple]] = []
        parts = [("actor", [lr.actor for lr in learners])]
        if train_critic:
            parts.append(("critic", [lr.critic for lr in learners]))
        for part, modules in parts:
            per_learner = [_layers(m) for m in modules]
            for i in range(len(per_learner[0])):
                weights = tuple(layers[i][0] for layers in per_learner)
                biases = tuple(layers[i][1] for layers in per_learner)
                out_dim, in_dim = weights[0].shape
                entries.append((part, (in_dim, out_dim), True, weights))
                entries.append((part, (1, out_dim), False, biases))
        if learners[0].log_std is not None:
            entries.append(("log_std", tuple(learners[0].log_std.shape), False, tuple(lr.log_std for lr in learners)))
        return cls(learners, entries)

    def mlp(self, part: str, x: torch.Tensor, activation: str) -> torch.Tensor:
        """The stacked actor's or critic's output for ``x [L, M, in]``, differentiable in ``theta``."""
        return _StackedMLP.apply(self.theta, x, self.layouts[part], activation)

    def log_std(self) -> torch.Tensor | None:
        """The stacked ``log_std [L, act_dim]`` (a view of ``theta``), or None for discrete actors."""
        if self.log_std_column is None:
            return None
        return self.theta[:, self.log_std_column:]

    @torch.no_grad()
    def step(self, live: torch.Tensor, max_norm: torch.Tensor, lrs: np.ndarray, eps: float) -> None:
        """Each live learner's gradient clipped to its global norm (as ``clip_grad_norm_``), then
        its Adam step (as ``torch.optim.Adam``); the others' weights and moments stay as they are."""
        grad = self.theta.grad
        norm = grad.pow(2).sum(1).sqrt()
        grad.mul_((max_norm / (norm + 1e-6)).clamp(max=1.0)[:, None])
        self.steps += live.double()
        steps = self.steps.clamp(min=1.0).numpy()
        step_size = torch.from_numpy(lrs / (1.0 - _BETA1 ** steps)).float()[:, None]
        bc2_sqrt = torch.from_numpy(np.sqrt(1.0 - _BETA2 ** steps)).float()[:, None]
        if bool(live.all()):
            self.avg.lerp_(grad, 1.0 - _BETA1)
            self.sq.mul_(_BETA2).addcmul_(grad, grad, value=1.0 - _BETA2)
            denom = (self.sq.sqrt() / bc2_sqrt).add_(eps)
            self.theta.sub_(step_size * self.avg / denom)
            return
        keep = live[:, None]
        self.avg.copy_(torch.where(keep, torch.lerp(self.avg, grad, 1.0 - _BETA1), self.avg))
        self.sq.copy_(torch.where(keep, self.sq * _BETA2 + (1.0 - _BETA2) * grad * grad, self.sq))
        denom = (self.sq.sqrt() / bc2_sqrt).add_(eps)
        self.theta.sub_(torch.where(keep, step_size * self.avg / denom, torch.zeros(())))

    @staticmethod
    def _own(block: torch.Tensor, shape: tuple, transpose: bool, p: torch.Tensor) -> torch.Tensor:
        """A learner's block of a stacked row in the layout of its own parameter ``p``."""
        block = block.view(shape)
        return (block.T if transpose else block).reshape(p.shape)

    @torch.no_grad()
    def write_back(self, lrs: np.ndarray) -> None:
        """The weights and Adam moments into each learner (its optimiser's state as torch's Adam
        keeps it, so a learner updated one by one afterwards goes on exactly)."""
        for e, (_, shape, transpose, owners) in enumerate(self.entries):
            cols = slice(self.offsets[e], self.offsets[e + 1])
            for i, (learner, p) in enumerate(zip(self.learners, owners)):
                p.copy_(self._own(self.theta[i, cols], shape, transpose, p))
                if self.steps[i] > 0:
                    learner.optimiser.state[p] = {
                        "step": torch.tensor(float(self.steps[i])),
                        "exp_avg": self._own(self.avg[i, cols], shape, transpose, p).clone(),
                        "exp_avg_sq": self._own(self.sq[i, cols], shape, transpose, p).clone()}
        for learner, lr in zip(self.learners, lrs):
            for group in learner.optimiser.param_groups:
                group["lr"] = float(lr)


# --- frozen snapshots -------------------------------------------------------------------------------------

class SnapshotPool(Policy):
    """Frozen snapshots of a learner (SP's and CC's opponent pools) as one policy: ``act(...,
    owners=)`` plays each row with its owner's weights through the stack's numpy forward, the
    owners present stacked (so a pool of 64 with a few in play computes a few), and samples as
    :class:`~arena_league.policies.families.StackedPolicy` does (inverse CDF of the row's uniform;
    a continuous snapshot plays its mean). MLP actors whose architecture adds no noise."""

    def __init__(self, arch: Architecture, members: Sequence[Mapping[str, torch.Tensor]]) -> None:
        if arch.family != "mlp" or arch.noise != "none" or not members:
            raise ValueError("a SnapshotPool holds MLP snapshots without sampling noise; use StackedPolicy")
        self.architecture = arch
        self.spec = arch.spec
        self.name = f"pool-mlp x{len(members)}"
        self.n_members = len(members)
        self._all = _Act.from_parameters(members, arch.activation)
        self._last: tuple[bytes, RowLayout, _Act] | None = None

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None, owners: np.ndarray | None = None
            ) -> tuple[np.ndarray, np.ndarray | None]:
        owners = np.zeros(len(obs), dtype=np.int64) if owners is None else np.asarray(owners, dtype=np.int64)
        if owners.shape != (len(obs),) or (owners.size and (owners.min() < 0 or owners.max() >= self.n_members)):
            raise ValueError(f"owners must be int[{len(obs)}] with values in 0..{self.n_members - 1}")
        key = owners.tobytes()
        if self._last is None or self._last[0] != key:  # seats change owners only when episodes start
            present, members = np.unique(owners, return_inverse=True)
            self._last = (key, RowLayout(members.reshape(-1), len(present)), self._all.subset(present))
        _, layout, net = self._last
        out = layout.ungroup(net(layout.group(np.asarray(obs, dtype=np.float32))))
        if self.architecture.action_type == "continuous":
            return np.tanh(out).astype(np.float32), None
        return sample_from_logits(out, uniforms, legal_mask(mask, out.shape)), None


# --- the stack ----------------------------------------------------------------------------------------

class LearnerStack:
    """``learners`` (all :func:`stackable` together) acting and updating as one.

    The stack holds no state of its own between calls: :meth:`act` and :meth:`update` read each
    learner's weights, and :meth:`update` writes the new weights and Adam moments back.
    """

    def __init__(self, learners: Sequence[Learner]) -> None:
        if not stackable(learners):
            raise ValueError("these learners do not stack (an actor other than 'mlp', or settings that differ: "
                             "update them one by one)")
        self.learners = list(learners)
        first = self.learners[0]
        self.architecture = first.architecture
        self.config = first.config
        self.discrete = self.architecture.action_type == "discrete"
        self.has_critic = first.critic is not None
        self._actor: _Act | None = None
        self._critic: _Act | None = None
        self._log_std: np.ndarray | None = None
        self._value_std: np.ndarray | None = None
        self._value_mean: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.learners)

    # --- acting -----------------------------------------------------------------------------------
    def refresh(self) -> None:
        """Read the learners' current weights for :meth:`act` (after an update or an exploit step)."""
        activation = self.architecture.activation
        self._actor = _Act.of([lr.actor for lr in self.learners], activation)
        self._critic = _Act.of([lr.critic for lr in self.learners], activation) if self.has_critic else None
        if self.learners[0].log_std is not None:
            self._log_std = np.stack([lr.log_std.detach().numpy().copy() for lr in self.learners])
        norms = [lr.value_norm for lr in self.learners]
        self._value_std = self._value_mean = None
        if self.has_critic and all(v is not None for v in norms):
            self._value_std = np.array([v.std for v in norms])
            self._value_mean = np.array([v.mean for v in norms])

    def act(self, members: np.ndarray, obs: np.ndarray, noise: np.ndarray, mask: np.ndarray | None,
            critic_input: np.ndarray | None, layout: RowLayout | None = None) -> ActResult:
        """Sample actions for N rows, row ``i`` played by stacked learner ``members[i]`` (see
        :meth:`Learner.act <arena_league.training.ppo.Learner.act>` for the arguments; ``layout``
        is ``RowLayout(members, len(stack))``, which a caller acting for the same rows every step
        computes once)."""
        if self._actor is None:
            self.refresh()
        assert self._actor is not None
        n = len(members)
        layout = layout or RowLayout(members, len(self.learners))
        out = layout.ungroup(self._actor(layout.group(obs)))
        preds = None
        if self._critic is not None:
            preds = layout.ungroup(self._critic(layout.group(critic_input)))[:, 0]
        if self.discrete:
            actions, logprobs = _sample_categorical(out, np.asarray(noise, dtype=np.float64).reshape(n),
                                                    legal_mask(mask, out.shape))
            env_actions = actions
        else:
            mean = np.tanh(out)
            log_std = self._log_std[members]
            squash = self.config.continuous_head == "tanh"
            if squash:
                mean = np.arctanh(np.clip(mean, -1.0 + _SQUASH_EPS, 1.0 - _SQUASH_EPS))
            z = np.asarray(noise, dtype=np.float32).reshape(n, -1)
            actions = (mean + np.exp(log_std) * z).astype(np.float32)
            logprobs = (-0.5 * z * z - log_std - _LOG_SQRT_2PI).sum(-1)
            if squash:
                logprobs = logprobs - np.log(1.0 - np.tanh(actions) ** 2 + _SQUASH_EPS).sum(-1)
                env_actions = np.tanh(actions)
            else:
                env_actions = np.clip(actions, -1.0, 1.0)
        values = value_preds = np.zeros(n, dtype=np.float32)
        if preds is not None:
            value_preds = preds
            values = self._denormalize(preds, members)
        return ActResult(env_actions, actions, logprobs.astype(np.float32), values, value_preds, None)

    def _denormalize(self, preds: np.ndarray, members: np.ndarray) -> np.ndarray:
        """As each row's learner's ``denormalize`` (float64, then float32)."""
        if self._value_std is None:
            return preds.astype(np.float32)
        return (preds.astype(np.float64) * self._value_std[members] + self._value_mean[members]).astype(np.float32)

    def values(self, members: np.ndarray, critic_input: np.ndarray) -> np.ndarray:
        """Denormalised value estimates of critic input rows, row ``i`` by learner ``members[i]``."""
        if not self.has_critic:
            return np.zeros(len(members), dtype=np.float32)
        if self._critic is None:
            self.refresh()
        assert self._critic is not None
        layout = RowLayout(members, len(self.learners))
        return self._denormalize(layout.ungroup(self._critic(layout.group(critic_input)))[:, 0], members)

    # --- updating ---------------------------------------------------------------------------------
    def update(self, batches: Sequence[Batch], learning_rates: Sequence[float], *,
               value_loss: bool = True) -> list[UpdateStats]:
        """One PPO update of every learner on its batch (what :func:`~arena_league.training.ppo.ppo_update`
        does for one learner, for all of them at once); each learner draws its minibatches from
        its own ``rng`` and steps at its own ``learning_rates[i]``. Weights and Adam moments are
        written back to the learners, whose ``updates`` count goes up by one."""
        learners = self.learners
        L = len(learners)
        if len(batches) != L or len(learning_rates) != L:
            raise ValueError(f"update needs one batch and one learning rate per stacked learner ({L})")
        config = self.config
        train_critic = value_loss and self.has_critic
        # hyper-parameters per learner, shaped to broadcast over [L, rows]
        cfg = [lr.config for lr in learners]
        clip = torch.tensor([c.clip_coef for c in cfg], dtype=torch.float32)[:, None]
        ent_coef = torch.tensor([c.ent_coef for c in cfg], dtype=torch.float32)
        vf_coef = torch.tensor([c.vf_coef for c in cfg], dtype=torch.float32)
        max_norm = torch.tensor([c.max_grad_norm for c in cfg], dtype=torch.float32)
        lrs = np.asarray(learning_rates, dtype=np.float64)
        target_kl = [c.target_kl for c in cfg]
        # the samples, stacked and padded to the largest batch
        data, valid, sizes = self._stack_batches(batches, train_critic)
        flat_params = _Flat.of(self.learners, train_critic)
        sums = torch.zeros(5, L, dtype=torch.float64)  # policy, value, entropy, kl, clip fraction
        n_minibatches = np.zeros(L, dtype=np.int64)
        epochs_done = np.zeros(L, dtype=np.int64)
        running = np.ones(L, dtype=bool)  # False once a learner's KL stopped its epochs
        mb_size = np.maximum(1, -(-sizes // config.num_minibatches))
        per_epoch = -(-sizes // mb_size)
        M = int(mb_size.max())
        offsets = np.arange(L, dtype=np.int64)[:, None, None] * int(sizes.max())  # row of [l, j] in the flat batch
        for _epoch in range(config.update_epochs):
            if not running.any():
                break
            # each learner's permutation, cut into its minibatches; row j of minibatch k at [l, k, j]
            index = np.zeros((L, int(per_epoch.max()), M), dtype=np.int64)
            taken = np.zeros((L, int(per_epoch.max()), M), dtype=bool)
            for i, learner in enumerate(learners):
                if not running[i]:
                    continue
                order = learner.rng.permutation(int(sizes[i]))
                for k in range(int(per_epoch[i])):
                    rows = order[k * mb_size[i]: (k + 1) * mb_size[i]]
                    index[i, k, : len(rows)] = rows
                    taken[i, k, : len(rows)] = True
            epoch_kl = torch.zeros(L, dtype=torch.float64)
            epoch_count = np.zeros(L, dtype=np.int64)
            # the epoch's samples in minibatch order, gathered once: each minibatch is then a slice
            flat = torch.from_numpy((index + offsets).reshape(-1))
            shuffled = {name: tensor.flatten(0, 1).index_select(0, flat).unflatten(0, (L, -1))
                        for name, tensor in data.items()}
            in_epoch = torch.from_numpy(taken.reshape(L, -1))
            for k in range(int(per_epoch.max())):
                part = slice(k * M, (k + 1) * M)
                in_mb = in_epoch[:, part]
                live = torch.from_numpy(taken[:, k].any(axis=1) & running)
                mb = {name: tensor[:, part] for name, tensor in shuffled.items()}
                flat_params.theta.grad = None
                if self.discrete:  # its gradient written out by hand: a few dozen operations, no graph
                    terms = self._discrete_minibatch(mb, in_mb, live, flat_params, clip, ent_coef, vf_coef,
                                                     train_critic)
                else:
                    loss, terms = self._minibatch_loss(mb, in_mb, live, flat_params, clip, ent_coef, vf_coef,
                                                       train_critic)
                    loss.backward()
                flat_params.step(live, max_norm, lrs, config.adam_eps)
                live_np = live.numpy()
                sums += terms.double() * live
                n_minibatches += live_np
                epoch_kl += terms[3].double() * live
                epoch_count += live_np
            epochs_done += running
            for i in range(L):
                if running[i] and target_kl[i] is not None and epoch_count[i] and \
                        float(epoch_kl[i]) / epoch_count[i] > target_kl[i]:
                    running[i] = False
        flat_params.write_back(lrs)
        results = []
        explained = self._explained_variance(data, valid, flat_params) if train_critic else [float("nan")] * L
        for i, learner in enumerate(learners):
            count = max(int(n_minibatches[i]), 1)
            results.append(UpdateStats(policy_loss=float(sums[0, i]) / count, value_loss=float(sums[1, i]) / count,
                                       entropy=float(sums[2, i]) / count, approx_kl=float(sums[3, i]) / count,
                                       clip_fraction=float(sums[4, i]) / count, explained_variance=explained[i],
                                       learning_rate=float(lrs[i]), epochs=int(epochs_done[i])))
            learner.updates += 1
        self._actor = self._critic = None  # the weights changed: acting reads them afresh
        return results

    def _stack_batches(self, batches: Sequence[Batch], train_critic: bool
                       ) -> tuple[dict[str, torch.Tensor], torch.Tensor, np.ndarray]:
        """The batches as ``[L, B_max, ...]`` tensors (returns normalised by each learner's value
        statistics, updated here first as in ``ppo_update``), the valid-row mask and the sizes."""
        L = len(batches)
        sizes = np.array([len(b) for b in batches], dtype=np.int64)
        B = int(sizes.max())
        equal = bool((sizes == B).all())

        def stack(tensors: list[torch.Tensor]) -> torch.Tensor:
            if equal:
                return torch.stack(tensors)
            out = tensors[0].new_zeros((L, B, *tensors[0].shape[1:]))
            for i, t in enumerate(tensors):
                out[i, : len(t)] = t
            return out

        data: dict[str, torch.Tensor] = {
            "obs": stack([b.obs for b in batches]),
            "actions": stack([b.actions for b in batches]),
            "logprobs": stack([b.logprobs for b in batches]),
            "advantages": stack([b.advantages for b in batches]),
            "acting": stack([b.policy_mask if b.policy_mask is not None else torch.ones(len(b), dtype=torch.bool)
                             for b in batches]),
        }
        if batches[0].masks is not None:
            data["masks"] = stack([b.masks for b in batches])
        if train_critic:
            returns = []
            for learner, b in zip(self.learners, batches):
                target = b.returns
                if learner.value_norm is not None:
                    learner.value_norm.update(b.returns.numpy())
                    target = learner.value_norm.normalize(b.returns.double()).float()
                returns.append(target)
            data["returns"] = stack(returns)
            data["values"] = stack([b.values for b in batches])
            data["critic_input"] = stack([b.obs if b.critic_input is None else b.critic_input for b in batches])
        valid = torch.arange(B)[None, :] < torch.from_numpy(sizes)[:, None]
        return data, valid, sizes

    # the loss of one minibatch, summed over learners
    def _minibatch_loss(self, mb: dict[str, torch.Tensor], in_mb: torch.Tensor, live: torch.Tensor,
                        flat: _Flat, clip: torch.Tensor, ent_coef: torch.Tensor,
                        vf_coef: torch.Tensor, train_critic: bool) -> tuple[torch.Tensor, torch.Tensor]:
        """(the loss summed over the live learners, ``[5, L]`` per-learner policy loss, value loss,
        entropy, approximate KL and clip fraction)."""
        config = self.config
        acting = mb["acting"] & in_mb
        acting_f = acting.float()
        n_acting = acting_f.sum(1).clamp(min=1.0)
        activation = self.architecture.activation
        out = flat.mlp("actor", mb["obs"], activation)
        if self.discrete:
            logits = out if "masks" not in mb else out.masked_fill(~mb["masks"], _ILLEGAL_LOGIT)
            log_p = torch.log_softmax(logits, dim=2)
            entropy = -(log_p.exp() * log_p).sum(2)
            new_logprob = log_p.gather(2, mb["actions"].long().unsqueeze(2)).squeeze(2)
        else:
            log_std = flat.log_std()
            assert log_std is not None
            mean = torch.tanh(out)
            if config.continuous_head == "tanh":
                mean = torch.atanh(mean.clamp(-1.0 + _SQUASH_EPS, 1.0 - _SQUASH_EPS))
            ls = log_std[:, None, :]
            raw = mb["actions"]
            new_logprob = (-((raw - mean) ** 2) / (2.0 * torch.exp(2.0 * ls)) - ls - _LOG_SQRT_2PI).sum(-1)
            if config.continuous_head == "tanh":
                new_logprob = new_logprob - torch.log(1.0 - torch.tanh(raw).pow(2) + _SQUASH_EPS).sum(-1)
            entropy = (0.5 + _LOG_SQRT_2PI + ls).expand_as(mean).sum(-1)
        log_ratio = new_logprob - mb["logprobs"]
        ratio = log_ratio.exp()
        with torch.no_grad():
            approx_kl = (((ratio - 1) - log_ratio) * acting_f).sum(1) / n_acting
            clip_fraction = (((ratio - 1.0).abs() > clip).float() * acting_f).sum(1) / n_acting
        advantages = self._normalised_advantages(mb["advantages"], acting_f)
        surrogate = torch.max(-advantages * ratio, -advantages * ratio.clamp(1 - clip, 1 + clip))
        policy_loss = (surrogate * acting_f).sum(1) / n_acting
        entropy_loss = (entropy * acting_f).sum(1) / n_acting
        per_learner = policy_loss - ent_coef * entropy_loss
        v_loss = torch.zeros_like(policy_loss)
        if train_critic:
            rows_f = in_mb.float()
            n_rows = rows_f.sum(1).clamp(min=1.0)
            new_value = flat.mlp("critic", mb["critic_input"], activation).squeeze(2)
            target, old = mb["returns"], mb["values"]
            unclipped = (new_value - target) ** 2
            if config.clip_vloss:
                clipped = old + (new_value - old).clamp(-clip, clip)
                squared = torch.max(unclipped, (clipped - target) ** 2)
            else:
                squared = unclipped
            v_loss = 0.5 * (squared * rows_f).sum(1) / n_rows
            per_learner = per_learner + vf_coef * v_loss
        loss = (per_learner * live.float()).sum()
        terms = torch.stack([policy_loss.detach(), v_loss.detach(), entropy_loss.detach(), approx_kl, clip_fraction])
        return loss, terms

    @torch.no_grad()
    def _discrete_minibatch(self, mb: dict[str, torch.Tensor], in_mb: torch.Tensor, live: torch.Tensor,
                            flat: _Flat, clip: torch.Tensor, ent_coef: torch.Tensor, vf_coef: torch.Tensor,
                            train_critic: bool) -> torch.Tensor:
        """:meth:`_minibatch_loss` of a categorical policy, with the loss's gradient in ``theta``
        written out (set as ``flat.theta.grad``) instead of taken by autograd. The same
        derivatives as autograd's: the clipped surrogate passes the gradient of the unclipped
        ratio where it is the larger term (ties included), none where the clipped one is; the
        value loss likewise; log-softmax and entropy by their closed forms. Returns the ``[5, L]``
        terms."""
        config = self.config
        activation = self.architecture.activation
        theta = flat.theta.detach()
        acting_f = (mb["acting"] & in_mb).float()
        n_acting = acting_f.sum(1, keepdim=True).clamp(min=1.0)
        live_f = live.float()[:, None]
        out, actor_inputs = _mlp_run(theta, mb["obs"], flat.layouts["actor"], activation)
        masks = mb.get("masks")
        z = out if masks is None else out.masked_fill(~masks, _ILLEGAL_LOGIT)
        z = z - z.max(2, keepdim=True).values
        e = z.exp()
        total = e.sum(2, keepdim=True)
        p = e / total
        log_p = z - total.log()
        entropy = -(p * log_p).sum(2)
        taken = mb["actions"].long().unsqueeze(2)
        log_ratio = log_p.gather(2, taken).squeeze(2) - mb["logprobs"]
        ratio = log_ratio.exp()
        n = n_acting[:, 0]
        approx_kl = (((ratio - 1) - log_ratio) * acting_f).sum(1) / n
        clip_fraction = (((ratio - 1.0).abs() > clip).float() * acting_f).sum(1) / n
        advantages = self._normalised_advantages(mb["advantages"], acting_f)
        unclipped = -advantages * ratio
        surrogate = torch.max(unclipped, -advantages * ratio.clamp(1 - clip, 1 + clip))
        policy_loss = (surrogate * acting_f).sum(1) / n
        entropy_loss = (entropy * acting_f).sum(1) / n
        weight = acting_f * live_f / n_acting  # d loss / d (a row's surrogate)
        d_logprob = torch.where(unclipped >= surrogate, unclipped, torch.zeros(())) * weight
        d_entropy = (-ent_coef[:, None] * weight).unsqueeze(2)
        grad_z = -p * (d_logprob.unsqueeze(2) + d_entropy * (log_p + entropy.unsqueeze(2)))
        grad_z.scatter_add_(2, taken, d_logprob.unsqueeze(2))
        if masks is not None:
            grad_z.mul_(masks)
        grad = _mlp_grad(theta, actor_inputs, grad_z, flat.layouts["actor"], activation)
        v_loss = torch.zeros_like(policy_loss)
        if train_critic:
            rows_f = in_mb.float()
            n_rows = rows_f.sum(1, keepdim=True).clamp(min=1.0)
            value, critic_inputs = _mlp_run(theta, mb["critic_input"], flat.layouts["critic"], activation)
            value = value.squeeze(2)
            error = value - mb["returns"]
            squared = error * error
            slope = error  # d (squared / 2) / d value, through the larger of the two terms
            if config.clip_vloss:
                old = mb["values"]
                change = value - old
                clipped = old + change.clamp(-clip, clip) - mb["returns"]
                larger = squared >= clipped * clipped
                # inside the clip range the clipped term differs from the plain one by rounding only,
                # and passes its gradient; outside, it passes none
                slope = torch.where(larger, error, clipped * ((change >= -clip) & (change <= clip)))
                squared = torch.max(squared, clipped * clipped)
            v_loss = 0.5 * (squared * rows_f).sum(1) / n_rows[:, 0]
            d_value = vf_coef[:, None] * rows_f * live_f / n_rows * slope
            grad += _mlp_grad(theta, critic_inputs, d_value.unsqueeze(2), flat.layouts["critic"], activation)
        flat.theta.grad = grad
        return torch.stack([policy_loss, v_loss, entropy_loss, approx_kl, clip_fraction])

    def _normalised_advantages(self, advantages: torch.Tensor, acting_f: torch.Tensor) -> torch.Tensor:
        """Advantages normalised per learner over its acting rows (when it has more than one)."""
        if not self.config.norm_adv:
            return advantages
        counts = acting_f.sum(1, keepdim=True)
        mean = (advantages * acting_f).sum(1, keepdim=True) / counts.clamp(min=1.0)
        var = (((advantages - mean) ** 2) * acting_f).sum(1, keepdim=True) / (counts - 1.0).clamp(min=1.0)
        return torch.where(counts > 1, (advantages - mean) / (var.sqrt() + 1e-8), advantages)

    def _explained_variance(self, data: dict[str, torch.Tensor], valid: torch.Tensor, flat: _Flat) -> list[float]:
        with torch.no_grad():
            predicted = flat.mlp("critic", data["critic_input"], self.architecture.activation).squeeze(2)
        out = []
        for i in range(len(self.learners)):
            rows = valid[i]
            target = data["returns"][i][rows]
            variance = float(target.var()) if len(target) > 1 else 0.0
            out.append(float("nan") if variance == 0 else
                       1.0 - float((target - predicted[i][rows]).var()) / variance)
        return out


def snapshot_pool(arch: Architecture, members: Sequence[Mapping[str, torch.Tensor]]) -> Policy:
    """The policy of a pool of snapshots: a :class:`SnapshotPool` where it applies, else the
    general :class:`~arena_league.policies.families.StackedPolicy` (recurrent or convolutional
    actors)."""
    if arch.family == "mlp" and arch.noise == "none":
        return SnapshotPool(arch, members)
    from arena_league.policies.families import StackedPolicy

    return StackedPolicy(arch, members, compute_dtype=torch.float32)
