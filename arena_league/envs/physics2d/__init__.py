"""The one 2D engine under the pymunk games (Crossroads, Soccer, AirHockey, FightForFood, Tennis,
BlowBlow, BattleCity, Fighter): a game is a declaration over it, not a copy of it.

- :mod:`~arena_league.envs.physics2d.world`: the field as data (:class:`Field` of :class:`Walls`
  and :class:`Bodies` with their :class:`Material`), and the :class:`World` that builds each match's
  pymunk space, keeps every body's state and the game's named slots in one work vector, and steps
  the physics;
- :mod:`~arena_league.envs.physics2d.link`: the batch transfers between pymunk and numpy, and the
  physics step, straight through pymunk's C handles where they are reachable;
- :mod:`~arena_league.envs.physics2d.cells`: observation and state layouts as named runs of cells,
  with their bounds and meanings;
- :mod:`~arena_league.envs.physics2d.rules`: :class:`Physics2DRules`, the base of a game's rules
  (options, pickling by replay, clipping), seat frames and compass moves;
- :mod:`~arena_league.envs.physics2d.contacts`: each body's contact impulses summed over a step;
- :mod:`~arena_league.envs.physics2d.gather`: observations gathered as scaled differences of cells
  (where a matrix product would cost more);
- :mod:`~arena_league.envs.physics2d.picture`: walls and bodies drawn as declared, for the
  top-down picture and the replay scene;
- :mod:`~arena_league.envs.physics2d.geometry`: outlines and walls (a field with chamfered corners
  and goal boxes, walls whose inner faces follow an outline);
- :mod:`~arena_league.envs.physics2d.shots`: shells fired by seats across a tiled map of static
  boxes, some of which shells break (BattleCity, Fighter): the tiles, the shells' exact straight
  paths, reloading, a shooter's heading, actions and fire key;
- :mod:`~arena_league.envs.physics2d.ballgames`: what the two-team ball games on a goal field
  (Soccer, AirHockey) share: their rules' common part, observation, measures, state, default tree,
  scripted approach, picture and replay scene.
"""

from arena_league.envs.physics2d.cells import CellLayout, Run
from arena_league.envs.physics2d.link import (
    DIRECT_AVAILABLE,
    SPARE_CELLS,
    BodyFields,
    SpaceLink,
    body_cells,
    space_link,
)
from arena_league.envs.physics2d.rules import (
    COMPASS_MOVE_NAMES,
    COMPASS_MOVES,
    Physics2DRules,
    SeatThrust,
    mirror_signs,
    team_ranks,
    team_turns,
)
from arena_league.envs.physics2d.world import ONE, Bodies, Field, Material, Walls, World

__all__ = [
    "COMPASS_MOVES",
    "COMPASS_MOVE_NAMES",
    "DIRECT_AVAILABLE",
    "ONE",
    "SPARE_CELLS",
    "Bodies",
    "BodyFields",
    "CellLayout",
    "Field",
    "Material",
    "Physics2DRules",
    "Run",
    "SeatThrust",
    "SpaceLink",
    "Walls",
    "World",
    "body_cells",
    "mirror_signs",
    "space_link",
    "team_ranks",
    "team_turns",
]
