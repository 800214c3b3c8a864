"""Built-in scripted agents for every game: ``random`` and ``heuristic``.

Arena (Song et al., AAAI 2020) anchors its rankings with simple fixed agents next to the learned
population. Both agents here are pure functions of their inputs, so they need no artifact:

* ``random``: a uniformly random *legal* action from the engine's uniforms (discrete: inverse CDF
  over the legal actions of the mask; continuous: ``2u - 1`` per component).
* ``heuristic``: the game's own deterministic scripted policy, ``RULES.heuristic(obs,
  action_type)`` (documented in each game's manual). Should it ever name an illegal action, a
  random legal one is played instead.

Refer to them as ``scripted:random`` / ``scripted:heuristic`` (:func:`scripted_policy`); the
registry stores them as the small JSON descriptor of :func:`scripted_descriptor`.
"""

from __future__ import annotations

import json

import numpy as np

from arena_league.envs import game_spec
from arena_league.policies.policy import ActionSpec, Policy, legal_mask, sample_from_logits
from arena_league.policies.spaces import game_action_spec

SCRIPTED_NAMES: tuple[str, ...] = ("random", "heuristic")
#: Prefix of a scripted agent's reference, e.g. ``scripted:heuristic``.
SCRIPTED_PREFIX = "scripted:"
#: The ``format`` field of a scripted agent's JSON descriptor.
SCRIPTED_FORMAT = "arena-scripted"


class RandomPolicy(Policy):
    """Uniformly random legal actions drawn from the engine's uniforms."""

    name = "random"

    def __init__(self, spec: ActionSpec) -> None:
        self.spec = spec

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        n = np.shape(obs)[0]
        uniforms = np.asarray(uniforms, dtype=np.float64)
        if uniforms.ndim == 1:
            uniforms = uniforms[:, None]
        if self.spec.action_type == "continuous":
            if uniforms.shape[1] < self.spec.act_dim:
                raise ValueError(f"random policy: continuous actions need {self.spec.act_dim} uniforms per seat, "
                                 f"got {uniforms.shape[1]} (see ActionSpec.uniforms_per_seat)")
            return (2.0 * uniforms[:, : self.spec.act_dim] - 1.0).astype(np.float32), None
        logits = np.zeros((n, self.spec.n_actions))
        return sample_from_logits(logits, uniforms, legal_mask(mask, logits.shape)), None


class HeuristicPolicy(Policy):
    """The game's deterministic scripted policy (``RULES.heuristic``)."""

    name = "heuristic"

    def __init__(self, game_id: str, spec: ActionSpec) -> None:
        self.spec = spec
        self.game_id = game_id
        self._heuristic = game_spec(game_id).rules.heuristic
        self._fallback = RandomPolicy(spec)

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        obs = np.asarray(obs, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] < self.spec.obs_dim:
            raise ValueError(f"{self.game_id} heuristic reads observations float32[N, {self.spec.obs_dim}], "
                             f"got shape {obs.shape}")
        # Boards or the global state may follow the base observation; the heuristic reads the base.
        actions = self._heuristic(obs[:, : self.spec.obs_dim], self.spec.action_type)
        if self.spec.action_type == "continuous":
            return np.clip(np.asarray(actions, dtype=np.float32), -1.0, 1.0), None
        actions = np.asarray(actions, dtype=np.int64)
        mask = legal_mask(mask, (obs.shape[0], self.spec.n_actions))
        if mask is not None:
            illegal = ~mask[np.arange(len(actions)), np.clip(actions, 0, self.spec.n_actions - 1)]
            illegal |= (actions < 0) | (actions >= self.spec.n_actions)
            if illegal.any():
                fallback, _ = self._fallback.act(obs[illegal], np.asarray(uniforms)[illegal], mask[illegal])
                actions = actions.copy()
                actions[illegal] = fallback
        return actions, None


def scripted_policy(name: str, game_id: str, action_type: str | None = None) -> Policy:
    """The built-in scripted agent ``name`` (``"random"`` or ``"heuristic"``, with or without the
    ``scripted:`` prefix) for ``game_id``."""
    bare = name.removeprefix(SCRIPTED_PREFIX)
    spec = game_action_spec(game_id, action_type)
    if bare == "random":
        return RandomPolicy(spec)
    if bare == "heuristic":
        return HeuristicPolicy(game_id, spec)
    raise ValueError(f"unknown scripted agent {name!r}; built-in agents: "
                     + ", ".join(SCRIPTED_PREFIX + n for n in SCRIPTED_NAMES))


def scripted_descriptor(name: str) -> bytes:
    """The canonical JSON bytes that stand for scripted agent ``name`` in the artifact store
    (the same name always gives the same bytes, hence the same content address)."""
    bare = name.removeprefix(SCRIPTED_PREFIX)
    if bare not in SCRIPTED_NAMES:
        raise ValueError(f"unknown scripted agent {name!r}; built-in agents: "
                         + ", ".join(SCRIPTED_PREFIX + n for n in SCRIPTED_NAMES))
    return json.dumps({"format": SCRIPTED_FORMAT, "name": bare}, sort_keys=True).encode() + b"\n"
