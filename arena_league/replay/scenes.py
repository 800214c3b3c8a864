"""The top-down 3D scene of a match, as Foxglove ``SceneUpdate`` messages (JSON form).

Every game describes its own scene: its rules' ``scene_entities(timestamp_ns)`` returns
``foxglove.SceneEntity`` dicts built from the primitives of :mod:`arena_league.envs.scene` (each
game's manual, its module docstring, says what its scene shows). This module wraps them into one
``SceneUpdate`` per step. Entities live in the frame :data:`FRAME_ID` and keep their ids across
steps, so each update replaces the previous one in Foxglove's 3D panel.
"""

from __future__ import annotations

from typing import Any

from arena_league.envs import GameRules
from arena_league.envs.scene import FRAME_ID

__all__ = ["FRAME_ID", "scene_entities", "scene_update"]


def scene_entities(rules: GameRules, timestamp_ns: int) -> list[dict[str, Any]]:
    """The scene entities of the match ``rules`` hold now (the game's own ``scene_entities``)."""
    return list(rules.scene_entities(timestamp_ns))


def scene_update(rules: GameRules, timestamp_ns: int) -> dict[str, Any]:
    """A ``foxglove.SceneUpdate`` message (as a dict) of the match ``rules`` hold now."""
    return {"deletions": [], "entities": scene_entities(rules, timestamp_ns)}
