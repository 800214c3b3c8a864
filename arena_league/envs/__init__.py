"""The game suite: ``make(game_id, ...)`` gives a PettingZoo ParallelEnv whose rewards come from a
configurable social tree; ``make_aec`` gives turn-based games their native AEC env. Both work with
the PettingZoo ecosystem's tools: they pickle and copy (SuperSuit's vector envs), observations lie
in finite spaces, games with illegal actions observe PettingZoo's ``{"observation", "action_mask"}``
dicts, and ``render_mode="human"`` opens a window (see :mod:`arena_league.envs.env`).

Ids follow Arena's ``<Game>-<x>T<y>P-v<N>`` (x teams of y players): see :func:`list_games`.
"""

from __future__ import annotations

from typing import Any

from arena_league.envs.catalog import GameSpec, game_spec, list_games
from arena_league.envs.core import GameRules, Measures
from arena_league.envs.env import ArenaParallelEnv
from arena_league.envs.options import Option
from arena_league.envs.social.tree import SocialTree, TreeSpecError

__all__ = [
    "ArenaParallelEnv",
    "GameRules",
    "GameSpec",
    "Measures",
    "SocialTree",
    "TreeSpecError",
    "build_tree",
    "check_tree",
    "default_tree",
    "example_trees",
    "game_options",
    "game_spec",
    "list_games",
    "make",
    "make_aec",
    "make_rules",
    "reward_catalog",
]

ACTION_TYPES = ("discrete", "continuous")


def game_options(game_id: str) -> tuple[Option, ...]:
    """The keyword options ``make(game_id, ...)`` takes, as its rules declare them (empty for a game
    that checks its own); :func:`~arena_league.envs.options.options_catalog` and
    :func:`~arena_league.envs.options.options_manual` give them as records and as text."""
    return game_spec(game_id).rules.options


def make_rules(game_id: str, action_type: str | None = None, **game_kwargs: Any) -> GameRules:
    """The rules of one match of ``game_id`` (no rewards, no PettingZoo); ``game_kwargs`` are its
    options (:func:`game_options`), which its rules check."""
    spec = game_spec(game_id)
    offered = spec.rules.action_types
    if action_type is None:
        action_type = offered[0]
    if action_type not in offered:
        valid = " or ".join(repr(a) for a in offered)
        if action_type in ACTION_TYPES:
            raise ValueError(f"{game_id} has no {action_type} action variant; valid: {valid}")
        raise ValueError(f"unknown action_type {action_type!r}; valid for {game_id}: {valid}")
    return spec.rules(spec.n_teams, spec.players_per_team, action_type, **game_kwargs)


def default_tree(game_id: str) -> dict:
    """The default social tree spec of ``game_id`` (mirroring the Arena paper's table)."""
    spec = game_spec(game_id)
    return spec.rules.default_tree(spec.n_teams, spec.players_per_team)


def example_trees(game_id: str) -> dict[str, dict]:
    """Named social trees of ``game_id`` worth starting from besides its default (the paper's
    Crossroads case study for Crossroads-2T2P-v1), by name."""
    spec = game_spec(game_id)
    return spec.rules.example_trees(spec.n_teams, spec.players_per_team)


def reward_catalog(game_id: str) -> dict[str, list[dict[str, Any]]]:
    """Per scheme, the reward functions a social tree of ``game_id`` may use (those whose measures
    the game emits): name, one-line description, parameters with their defaults, measures read."""
    from arena_league.envs.social.rewards import REWARD_FUNCTIONS

    provided = frozenset(game_spec(game_id).rules.measures_provided)
    return {scheme: [{"name": fn.name, "doc": fn.doc, "params": dict(fn.defaults),
                      "needs": sorted(set(fn.needs) | set(fn.needs_previous))}
                     for fn in sorted(table.values(), key=lambda f: f.name)
                     if set(fn.needs) | set(fn.needs_previous) <= provided]
            for scheme, table in REWARD_FUNCTIONS.items()}


def check_tree(game_id: str, tree: Any) -> list[dict[str, Any]]:
    """Build ``tree`` for ``game_id`` and return its nodes described (path, scheme, reward, scale,
    agents, board); raises :class:`TreeSpecError` naming the node and the fix."""
    rules = make_rules(game_id)
    return build_tree(game_id, tree, rules).describe()


def build_tree(game_id: str, tree: Any, rules: GameRules) -> SocialTree:
    names = [f"player_{i}" for i in range(rules.n_agents)]
    return SocialTree.build(default_tree(game_id) if tree is None else tree, names, rules.team_of,
                            frozenset(rules.measures_provided), game=game_id)


def make(game_id: str, tree: Any = None, action_type: str | None = None, render_mode: str | None = None,
         max_cycles: int | None = None, state_in_obs: bool = False, **game_kwargs: Any) -> ArenaParallelEnv:
    """A PettingZoo ParallelEnv of ``game_id``.

    Args:
        game_id: an id from :func:`list_games`, e.g. ``"Crossroads-2T2P-v1"``.
        tree: a social tree spec (dict, YAML/JSON file path, or JSON string); ``None`` for the default.
        action_type: ``"discrete"`` or ``"continuous"`` where the game offers it (default: its first).
        render_mode: ``None``, ``"rgb_array"`` (a top-down picture from ``render()``, headless) or
            ``"human"`` (that picture in a pygame window, drawn on every reset and step; it needs a
            display, or ``SDL_VIDEODRIVER`` set, and fails here with the alternatives otherwise).
        max_cycles: episode length cap (default: the game's own).
        state_in_obs: append the global state ``env.state()`` to every observation.
        **game_kwargs: the game's options (:func:`game_options`; ``arena-league games`` lists them); an
            unknown name or a bad value raises ValueError naming the option, what it accepts and its default.
    """
    rules = make_rules(game_id, action_type, **game_kwargs)
    social_tree = build_tree(game_id, tree, rules)
    cycles = rules.default_max_cycles if max_cycles is None else max_cycles
    return ArenaParallelEnv(game_id, rules, social_tree, cycles, render_mode, state_in_obs)


def make_aec(game_id: str, **kwargs: Any):
    """The native AEC env of a turn-based game (same arguments as :func:`make`)."""
    from arena_league.envs.aec import ArenaAECEnv

    spec = game_spec(game_id)
    if not spec.rules.turn_based:
        turn_based = [g for g in list_games() if game_spec(g).rules.turn_based]
        raise ValueError(f"{game_id} is played simultaneously, so it has no native AEC env; use make(). "
                         f"Turn-based games: {', '.join(turn_based)}")
    return ArenaAECEnv(make(game_id, **kwargs))
