"""The observation and action sizes an agent must match for one game id.

After Arena (Song et al., AAAI 2020), where one agent interface serves every game: an agent reads
the game's flattened observation ``float32[obs_dim]`` (the layout is in each game's manual) and
writes one of ``n_actions`` discrete actions or ``act_dim`` floats in [-1, 1].
"""

from __future__ import annotations

from functools import cache

from arena_league.envs import game_spec, make_rules
from arena_league.policies.policy import ActionSpec


@cache
def game_action_spec(game_id: str, action_type: str | None = None) -> ActionSpec:
    """The :class:`ActionSpec` of ``game_id`` (its default action variant when ``action_type`` is None).

    Raises ``ValueError`` for an unknown game id (listing the valid ones) or an action variant the
    game does not offer.
    """
    rules = make_rules(game_id, action_type)
    if rules.action_type == "discrete":
        return ActionSpec("discrete", rules.obs_dim, n_actions=rules.n_actions)
    return ActionSpec("continuous", rules.obs_dim, act_dim=rules.act_dim)


def action_types(game_id: str) -> tuple[str, ...]:
    """The action variants ``game_id`` offers, its default first."""
    return tuple(game_spec(game_id).rules.action_types)
