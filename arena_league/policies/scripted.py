"""Built-in scripted agents for every game: ``random`` and ``heuristic``.

Arena (Song et al., AAAI 2020) anchors its rankings with simple fixed agents next to the learned
population. Both agents here are pure functions of their inputs, so they need no artifact:

* ``random``: a uniformly random *legal* action from the engine's uniforms (discrete: inverse CDF
  over the legal actions of the mask; continuous: ``2u - 1`` per component).
* ``heuristic``: the game's own deterministic scripted policy, ``RULES.heuristic(obs,
  action_type)`` (documented in each game's manual). Should it ever name an illegal action, a
  random legal one is played instead.

Some games (GoBang, Snake, FightForFood, Boomer, CaptureFlag) also offer **search** agents over their own rules
(``RULES.search``), named with their budget, ``search-wW-rR-hH-eE`` (``-e`` may be left out: 0), whose
meaning each game's manual gives (``RULES.search_budget_meaning``): in GoBang ``search-w8-r4-h30-e0.1`` searches the 8
moves the heuristic likes best, playing 4 rollouts of at most 30 more moves from each, the rollouts'
moves the heuristic's but for a random one with probability 0.1. A game whose search has been
improved keeps the first version under its old names (a population that holds one stays what it
was rated as) and names the next with a suffix, ``-v2`` (``RULES.search_versions``). Their randomness comes from the
engine's uniforms, so a match replays exactly; the budget is bounded (:data:`SEARCH_LIMITS`) so that
no descriptor can ask for an unbounded search, and a game refuses a budget it cannot search (Snake's
plays no rollouts, ``RULES.search_without_rollouts``: R must be 1) when the agent is made.

Some games (PushBox) also offer **tuned heuristics**: their heuristic with other constants
(``RULES.heuristic_options``), named with them in alphabetical order, ``heuristic-lane0.6-side0.3``;
the game's manual says what each constant does. Both kinds serve as top rungs of a base population
where training does not reach above the heuristic.

Refer to them as ``scripted:random`` / ``scripted:heuristic`` / ``scripted:search-w8-r4-h30``
(:func:`scripted_policy`); the registry stores them as the small JSON descriptor of
:func:`scripted_descriptor`.
"""

from __future__ import annotations

import json
import re
from typing import Any

import numpy as np

from arena_league.envs import game_spec, list_games
from arena_league.policies.policy import ActionSpec, Policy, legal_mask, sample_from_logits
from arena_league.policies.spaces import game_action_spec

SCRIPTED_NAMES: tuple[str, ...] = ("random", "heuristic")
#: The search agents' budgets: bounds of each field, and of the rollouts' total work
#: (``width * rollouts * horizon``, stones played per move searched).
SEARCH_LIMITS: dict[str, int] = {"width": 16, "rollouts": 16, "horizon": 40, "work": 2048}
_SEARCH_NAME = re.compile(r"search-w(\d{1,3})-r(\d{1,3})-h(\d{1,3})(?:-e(0|0\.\d{1,3}|1))?(?:-v(\d{1,2}))?")
_TUNED_NAME = re.compile(r"heuristic((?:-[a-z]{1,12}\d{1,3}(?:\.\d{1,3})?){1,8})")
_TUNED_OPTION = re.compile(r"-([a-z]+)(\d+(?:\.\d+)?)")
#: Prefix of a scripted agent's reference, e.g. ``scripted:heuristic``.
SCRIPTED_PREFIX = "scripted:"
#: The ``format`` field of a scripted agent's JSON descriptor.
SCRIPTED_FORMAT = "arena-scripted"


def search_budget(name: str) -> dict[str, Any] | None:
    """The budget of search agent ``name`` (``search-w8-r4-h30-e0.1``, with or without the
    ``scripted:`` prefix): ``{"width", "rollouts", "horizon", "epsilon"}``, and ``"version"`` where the
    name asks for a later one (``-v2``); None when ``name`` is not a search agent's; raises ValueError,
    naming the bound, when a field is out of bounds."""
    found = _SEARCH_NAME.fullmatch(name.removeprefix(SCRIPTED_PREFIX))
    if found is None:
        return None
    width, rollouts, horizon = (int(found.group(k)) for k in (1, 2, 3))
    budget = {"width": width, "rollouts": rollouts, "horizon": horizon, "epsilon": float(found.group(4) or 0.0)}
    if found.group(5) is not None:
        version = int(found.group(5))
        if version < 2:
            # one name per agent: the first version is the name without a version
            raise ValueError(f"search agent {name!r}: the first version is named without -v; leave "
                             f"-v{found.group(5)} out: {found.string[: found.start(5) - 2]}")
        budget["version"] = version
    for field in ("width", "rollouts", "horizon"):
        if not 1 <= budget[field] <= SEARCH_LIMITS[field]:
            raise ValueError(f"search agent {name!r}: {field} must be from 1 to {SEARCH_LIMITS[field]}, "
                             f"not {budget[field]}")
    if width * rollouts * horizon > SEARCH_LIMITS["work"]:
        raise ValueError(f"search agent {name!r}: width x rollouts x horizon is {width * rollouts * horizon}, "
                         f"over the bound of {SEARCH_LIMITS['work']}; ask for a smaller budget")
    return budget


def heuristic_options(name: str) -> dict[str, float] | None:
    """The options of tuned heuristic ``name`` (``heuristic-lane0.6-side0.3``, with or without the
    ``scripted:`` prefix): ``{"lane": 0.6, "side": 0.3}``; None when ``name`` is not a tuned
    heuristic's. One agent has one name: options out of alphabetical order, repeated, or written
    other than plainly (``0.60``, ``00.6``) raise ValueError with the name to use. Which options
    and values a game takes its :class:`HeuristicPolicy` checks."""
    found = _TUNED_NAME.fullmatch(name.removeprefix(SCRIPTED_PREFIX))
    if found is None:
        return None
    pairs = [(key, float(text)) for key, text in _TUNED_OPTION.findall(found.group(1))]
    options = dict(pairs)
    canonical = _tuned_name(options)
    if len(options) != len(pairs) or canonical != found.string:
        raise ValueError(f"tuned heuristic {name!r}: name each option once, in alphabetical order, its value "
                         f"written plainly: {canonical}")
    return options


def _tuned_name(options: dict[str, float]) -> str:
    """The one name of the heuristic tuned with ``options``: each in alphabetical order, plainly."""
    return "heuristic" + "".join(f"-{key}{value:g}" for key, value in sorted(options.items()))


def is_scripted_name(name: Any) -> bool:
    """Whether ``name`` (without the prefix) names a built-in agent: random, heuristic, a search
    agent within its bounds or a tuned heuristic (anything but a string does not)."""
    if not isinstance(name, str):
        return False
    try:
        return name in SCRIPTED_NAMES or search_budget(name) is not None or heuristic_options(name) is not None
    except ValueError:
        return False


def _games_with(feature: str) -> str:
    """The game families whose rules offer ``feature`` (``heuristic_options``, ``search``), for an error."""
    rules = (game_spec(game_id).rules for game_id in list_games())
    return ", ".join(dict.fromkeys(r.name for r in rules if getattr(r, feature)))


def _unknown(name: str) -> ValueError:
    return ValueError(f"unknown scripted agent {name!r}; built-in agents: "
                      + ", ".join(SCRIPTED_PREFIX + n for n in SCRIPTED_NAMES)
                      + f", and, for games with a search agent, {SCRIPTED_PREFIX}search-wW-rR-hH[-eE][-vV] "
                        f"(e.g. search-w8-r4-h30-e0.1), for games with a tuned heuristic, "
                        f"{SCRIPTED_PREFIX}heuristic-<option><value>... (e.g. PushBox's heuristic-lane0.6-side0.3)")


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
    """The game's deterministic scripted policy (``RULES.heuristic``), with ``options`` a tuned one
    (``RULES.heuristic_options`` bounds them)."""

    name = "heuristic"

    def __init__(self, game_id: str, spec: ActionSpec, options: dict[str, float] | None = None) -> None:
        self.spec = spec
        self.game_id = game_id
        rules = game_spec(game_id).rules
        self.options = dict(options or {})
        if self.options:
            bounds = rules.heuristic_options
            if not bounds:
                raise ValueError(f"{game_id} has no tuned heuristic (games with one: {_games_with('heuristic_options')}); play "
                                 f"scripted:heuristic there")
            for key, value in self.options.items():
                if key not in bounds:
                    raise ValueError(f"{game_id}'s heuristic has no option {key!r}; its options: "
                                     + ", ".join(f"{k} ({lo:g} to {hi:g})" for k, (lo, hi) in sorted(bounds.items())))
                low, high = bounds[key]
                if not low <= value <= high:
                    raise ValueError(f"{game_id}'s heuristic option {key} must be from {low:g} to {high:g}, "
                                     f"not {value:g}")
            self.name = _tuned_name(self.options)
        self._heuristic = rules.heuristic
        self._fallback = RandomPolicy(spec)

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        obs = np.asarray(obs, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] < self.spec.obs_dim:
            raise ValueError(f"{self.game_id} heuristic reads observations float32[N, {self.spec.obs_dim}], "
                             f"got shape {obs.shape}")
        # Boards or the global state may follow the base observation; the heuristic reads the base.
        actions = self._heuristic(obs[:, : self.spec.obs_dim], self.spec.action_type, **self.options)
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


class SearchPolicy(Policy):
    """The game's search agent (``RULES.search``) at one budget; its randomness is the first of each
    seat's uniforms."""

    def __init__(self, game_id: str, spec: ActionSpec, name: str, budget: dict[str, Any]) -> None:
        search = game_spec(game_id).rules.search
        if search is None:
            raise ValueError(f"{game_id} has no search agent (games with one: {_games_with('search')}); "
                             f"play scripted:heuristic or scripted:random there")
        versions = game_spec(game_id).rules.search_versions
        if budget.get("version", 1) not in versions:
            raise ValueError(f"{game_id}'s search agent has version{'s' if len(versions) > 1 else ''} "
                             + ", ".join(map(str, versions)) + f", not {budget['version']}; "
                             + ("leave -v out" if versions == (1,) else "the first is named without -v"))
        without, rollouts = game_spec(game_id).rules.search_without_rollouts, budget["rollouts"]
        if without is not None and rollouts != 1:
            one = name.replace(f"-r{rollouts}-", "-r1-", 1)
            raise ValueError(f"{game_spec(game_id).rules.name}'s search plays no random rollouts ({without}): ask "
                             f"for R = 1, as in {one}, not R = {rollouts}")
        self.spec = spec
        self.name = name
        self.budget = budget
        self._search = search
        search(np.zeros((0, spec.obs_dim), dtype=np.float32), np.zeros(0), action_type=spec.action_type,
               **budget)  # the game checks the budget

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        uniforms = np.asarray(uniforms, dtype=np.float64)
        first = uniforms if uniforms.ndim == 1 else uniforms[:, 0]
        obs = np.asarray(obs, dtype=np.float32)[:, : self.spec.obs_dim]
        actions = self._search(obs, first, action_type=self.spec.action_type, **self.budget)
        if self.spec.action_type == "continuous":
            return np.clip(np.asarray(actions, dtype=np.float32), -1.0, 1.0), None
        return np.asarray(actions, dtype=np.int64), None


def scripted_policy(name: str, game_id: str, action_type: str | None = None) -> Policy:
    """The built-in scripted agent ``name`` (``"random"``, ``"heuristic"`` or a search agent such as
    ``"search-w8-r4-h30"``, with or without the ``scripted:`` prefix) for ``game_id``."""
    bare = name.removeprefix(SCRIPTED_PREFIX)
    spec = game_action_spec(game_id, action_type)
    if bare == "random":
        return RandomPolicy(spec)
    if bare == "heuristic":
        return HeuristicPolicy(game_id, spec)
    budget = search_budget(bare)
    if budget is not None:
        return SearchPolicy(game_id, spec, bare, budget)
    options = heuristic_options(bare)
    if options is not None:
        return HeuristicPolicy(game_id, spec, options)
    raise _unknown(name)


def scripted_descriptor(name: str) -> bytes:
    """The canonical JSON bytes that stand for scripted agent ``name`` in the artifact store
    (the same name always gives the same bytes, hence the same content address)."""
    bare = name.removeprefix(SCRIPTED_PREFIX)
    if bare not in SCRIPTED_NAMES and search_budget(bare) is None and heuristic_options(bare) is None:
        raise _unknown(name)
    return json.dumps({"format": SCRIPTED_FORMAT, "name": bare}, sort_keys=True).encode() + b"\n"
