"""The game set as the front ends list it, and the verification of a game's social tree."""

from __future__ import annotations

import inspect
from typing import Any

from arena_league.envs import default_tree, game_options, game_spec, list_games, make_rules
from arena_league.envs.options import options_catalog
from arena_league.envs.social.verify import VerificationReport, verify

__all__ = ["check_game", "game_ids", "game_manual", "game_rows", "option_line", "verify_social_tree"]


def game_ids() -> list[str]:
    """Every game id, in the catalog's order."""
    return list_games()


def check_game(game_id: str) -> str:
    """``game_id`` when it names a game; else ``ValueError`` naming the closest ids."""
    game_spec(game_id)
    return game_id


def game_rows() -> list[dict[str, Any]]:
    """One row per game id: layout, action types, turn order, observation size, episode length,
    summary, default social tree and the game's options (``options_catalog`` records)."""
    rows = []
    for game_id in list_games():
        spec = game_spec(game_id)
        rules = make_rules(game_id)
        rows.append({
            "game_id": game_id,
            "teams": spec.n_teams,
            "players_per_team": spec.players_per_team,
            "action_types": list(spec.rules.action_types),
            "turn_based": spec.rules.turn_based,
            "obs_dim": rules.obs_dim,
            "max_cycles": spec.rules.default_max_cycles,
            "summary": spec.rules.summary,
            "default_tree": default_tree(game_id),
            "options": options_catalog(game_options(game_id)),
        })
    return rows


def game_manual(game_id: str) -> str:
    """The game's manual: its module's docstring (rules, observation cell by cell, actions), as the
    terminal, the web game page and the docs site show it."""
    module = inspect.getmodule(game_spec(game_id).rules)
    return inspect.cleandoc(module.__doc__ or "") if module is not None else ""


def option_line(record: dict[str, Any]) -> str:
    """One option record of :func:`game_rows` in words: ``size: an integer in [2, inf], default 15
    (the board's side, in cells)``."""
    default = record["default"]
    if default is None:
        words = record.get("default_text", "computed by the game")
    elif isinstance(default, bool):
        words = "true" if default else "false"
    else:
        words = repr(default) if isinstance(default, (str, float)) else str(default)
    return f"{record['name']}: {record['accepts']}, default {words} ({record['meaning']})"


def verify_social_tree(game_id: str, **options: Any) -> VerificationReport:
    """Verify every node of ``game_id``'s social tree (its own, or ``tree=``) by paired sampling;
    see :func:`arena_league.envs.social.verify.verify` for the options."""
    return verify(game_id, **options)
