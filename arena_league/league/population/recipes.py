"""How each game's base population is trained unless the caller says otherwise: the recipes, as data.

Each recipe says in one line what it is for; why a game's recipe is what it is (the builds tried,
their figures) is told in ``docs/population-build-notes.md``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "DEFAULT_FLOOR_MARGIN",
    "DEFAULT_SCHEMES",
    "RECIPES",
    "TEAM_SCHEMES",
    "TOP_RUN_SEEDS",
    "Recipe",
    "default_schemes",
    "recipe_for",
]

#: Schemes of every build; team games add :data:`TEAM_SCHEMES`.
DEFAULT_SCHEMES: tuple[str, ...] = ("sp", "pbt", "dppo")
#: Added for games whose teams have several players (a centralised critic, MAPPO-style).
TEAM_SCHEMES: tuple[str, ...] = ("cc",)
#: Members are rated at least this far above the random agent (Elo) unless a recipe says otherwise.
DEFAULT_FLOOR_MARGIN = 50.0
#: Top run ``r`` of a build seeded ``seed`` trains with seed ``seed + TOP_RUN_SEEDS + r``.
TOP_RUN_SEEDS = 1000


@dataclass(frozen=True)
class Recipe:
    """How a game's base population is trained unless the caller says otherwise."""

    description: str
    """What the recipe makes, in one line."""
    steps: int
    """Env steps of each scheme's run from scratch."""
    snapshots: int
    """Snapshots per run (every ``steps // snapshots`` env steps)."""
    hidden: tuple[int, ...]
    """Hidden widths of the MLP actors: small, so that a member weighs tens of KB."""
    common: Mapping[str, Any] = field(default_factory=dict)
    """Overrides of :func:`arena_league.training.run_scheme` for every scheme."""
    per_scheme: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    """Overrides for one scheme (``{"pbt": {"population_size": 4}}``)."""
    warm_runs: int = 0
    """Runs of each scheme, beyond the ``runs_per_scheme`` from scratch, whose learners first
    imitate the game's heuristic (:mod:`arena_league.training.imitation`): they give the strong
    end of the population, the runs from scratch the weak end and the middle."""
    warm_start: Mapping[str, Any] | Sequence[Mapping[str, Any]] = field(default_factory=dict)
    """:class:`~arena_league.training.imitation.WarmStart` fields of those runs; a list gives the
    ``r``-th warm-started run of each scheme entry ``r`` (cycling): a ladder of imitation budgets,
    from clumsy copies of the heuristic to faithful ones."""
    warm_steps: int | None = None
    """RL env steps of a warm-started run (default ``steps``)."""
    warm_overrides: Mapping[str, Any] = field(default_factory=dict)
    """Overrides of the warm-started runs only (``{"hidden": (128, 128)}``: a wider actor copies
    the heuristic more closely)."""
    scheme_steps: Mapping[str, int] = field(default_factory=dict)
    """Env steps of one scheme's runs from scratch where they differ from ``steps`` (``{"sp": 1_000_000}``:
    a learner that first has to find the goal against a fixed opponent needs longer)."""
    floor_margin: float = DEFAULT_FLOOR_MARGIN
    """Members are rated at least this far above the random agent (Elo) while enough candidates are."""
    top_runs: Sequence[Mapping[str, Any]] = ()
    """Runs for the top of the population, each with its own options: ``{"scheme": "sp", "steps":
    1_000_000, "warm_start": {...}, "fixed_opponents": ("scripted:heuristic",), ...}``. A learner
    that copies the heuristic and then trains against it for long learns to beat it: the headroom
    above the heuristic that the ladder below lacks."""
    early_snapshots: int = 0
    """Extra snapshots of every run before its first regular one, log-spaced: before training (the
    initial or warm-started actors), then at 1/2, 1/4, ... of the interval, for games whose
    learners change fastest in their first iterations (a falling ant learns to stand at once)."""

    def overrides(self, scheme: str) -> dict[str, Any]:
        return {"hidden": tuple(self.hidden), **dict(self.common), **dict(self.per_scheme.get(scheme, {}))}


def playing_the_heuristic(steps: int, hidden: tuple[int, ...] = (128, 128)) -> tuple[dict[str, Any], ...]:
    """Two top runs: copies of the heuristic that then play it alone for ``steps`` env steps."""
    return tuple({"scheme": "sp", "steps": steps, "hidden": hidden,
                  "warm_start": {"steps": 100_000, "rounds": 5, "epochs": 6},
                  "fixed_opponents": ("scripted:heuristic",), "fixed_share": 1.0, "anneal_lr": False}
                 for _ in range(2))


# Ant learners sample their torques, so a run from scratch flails like the random agent: the ladder
# comes from warm-started runs whose std floors range from the copy's own error to just above random.
ANT_GAMES = Recipe(
    description="the ant games' ladder: five copies of the heuristic, each with a higher floor of its torques' std",
    steps=60_000, snapshots=8, hidden=(64, 64), per_scheme={"pbt": {"population_size": 4}},
    early_snapshots=6, warm_runs=5,
    warm_start=tuple({"steps": 60_000, "min_log_std": floor} for floor in (-4.0, -2.3, -1.6, -1.0, -0.4)),
    warm_steps=30_000)

# A learner that only meets itself may learn to guard its goal and never score, hence the random
# opponent in half of SP's episodes.
TOP_DOWN_DUELS = Recipe(
    description="the 2D top-down duels' ladder: SP half against random, a short and a long copy of the heuristic",
    steps=150_000, snapshots=12, hidden=(64, 64),
    per_scheme={"pbt": {"population_size": 4},
                "sp": {"fixed_opponents": ("scripted:random",), "fixed_share": 0.5}},
    early_snapshots=4, warm_runs=2,
    warm_start=({"steps": 20_000}, {"steps": 100_000, "rounds": 5, "epochs": 6}),
    warm_steps=100_000, warm_overrides={"hidden": (128, 128)})


#: Per game (the name before the layout): budgets sized for a 2-core machine, many snapshots per
#: run (early ones are weak, late ones strong), and small actors.
RECIPES: dict[str, Recipe] = {
    "Crossroads": Recipe(
        description="four schemes from scratch and one copy of the heuristic per scheme",
        steps=120_000, snapshots=12, hidden=(64, 64),
        per_scheme={"pbt": {"population_size": 4}, "cc": {"opponent_sampling": "80/20"}},
        warm_runs=1, warm_start={"steps": 30_000}, warm_steps=60_000),
    # SP and CC meet the random agent so that they find the goal; their longer runs climb from random
    # play to the heuristic's level.
    "Soccer": Recipe(
        description="SP and CC against random for long, and one long copy of the heuristic per scheme for the top",
        steps=120_000, snapshots=12, hidden=(64, 64),
        per_scheme={"pbt": {"population_size": 4},
                    "cc": {"opponent_sampling": "80/20", "opponent": "scripted:random"},
                    "sp": {"fixed_opponents": ("scripted:random",), "fixed_share": 0.8}},
        scheme_steps={"sp": 1_200_000, "cc": 600_000},
        early_snapshots=6, warm_runs=1, warm_start={"steps": 100_000, "rounds": 5, "epochs": 6},
        warm_steps=240_000, warm_overrides={"hidden": (128, 128)}),
    # The selection is sensitive to the floor here: 35 Elo is the one that met every criterion.
    "AirHockey": dataclasses.replace(
        TOP_DOWN_DUELS, floor_margin=35.0, top_runs=playing_the_heuristic(2_000_000),
        description="the top-down duels' ladder, two copies of the heuristic that play it for 2 M steps, floor 35"),
    # Its top is FightForFood's search agents (``scripted=``), which trained top runs never reached.
    "FightForFood": dataclasses.replace(
        TOP_DOWN_DUELS, description="the top-down duels' ladder alone; search agents make the top"),
    "Tennis": dataclasses.replace(
        TOP_DOWN_DUELS, top_runs=playing_the_heuristic(2_000_000),
        description="the top-down duels' ladder and two copies of the heuristic that play it for 2 M steps"),
    "BlowBlow": dataclasses.replace(
        TOP_DOWN_DUELS, top_runs=playing_the_heuristic(2_000_000),
        description="the top-down duels' ladder and two copies of the heuristic that play it for 2 M steps"),
    "GoBang": Recipe(
        description="three schemes from scratch with tiny actors for long",
        steps=600_000, snapshots=16, hidden=(8,), common={"learning_rate": 1e-3},
        per_scheme={"pbt": {"population_size": 4}}),
    "Sumo": dataclasses.replace(ANT_GAMES, description="the ant games' ladder"),
    # A near-random racer blocks as often as it falls, so members start 100 Elo above random.
    "RunToGoal": dataclasses.replace(
        ANT_GAMES, floor_margin=100.0,
        description="the ant games' ladder and a copy of the heuristic that races it for 2 M steps, floor 100",
        top_runs=({"scheme": "sp", "steps": 2_000_000, "warm_start": {"steps": 60_000, "min_log_std": -4.0},
                   "fixed_opponents": ("scripted:heuristic",), "fixed_share": 1.0, "learning_rate": 1e-4,
                   "anneal_lr": False, "ent_coef": 0.0},)),
    # Played in pairs, where the clumsiest copies rate about level with the random agent: members start
    # 100 Elo above it, so that it is last.
    "YouShallNotPass": dataclasses.replace(
        ANT_GAMES, floor_margin=100.0, description="the ant games' ladder, rated in pairs, floor 100"),
    # Its top is tuned heuristics (``scripted=``), not trained.
    "PushBox": dataclasses.replace(ANT_GAMES, description="the ant games' ladder (CC joins: a team game)"),
    "Snake": Recipe(
        description="four schemes from scratch and one long, wide copy of the heuristic per scheme",
        steps=80_000, snapshots=10, hidden=(64, 64),
        per_scheme={"pbt": {"population_size": 4}, "cc": {"opponent_sampling": "80/20"}},
        warm_runs=1, warm_start={"steps": 100_000, "rounds": 5, "epochs": 6}, warm_steps=40_000,
        warm_overrides={"hidden": (128, 128)}),
    # Learners that play the heuristic for 1.2 M steps, from scratch or from a copy of it, win 1 to 10%
    # of their matches against it (it holds the flag longer): tuned heuristics (``scripted=``) make the top.
    "CaptureFlag": Recipe(
        description="three schemes from scratch and one copy of the heuristic per scheme; tuned heuristics make the top",
        steps=300_000, snapshots=12, hidden=(64, 64), per_scheme={"pbt": {"population_size": 4}},
        early_snapshots=4, warm_runs=1, warm_start={"steps": 100_000, "rounds": 5, "epochs": 6},
        warm_steps=100_000, warm_overrides={"hidden": (128, 128)}),
    # SP from scratch scores 0.3 to 0.55 against the heuristic after 300,000 steps (5,000 steps/s here).
    # Actors are half as wide as elsewhere: each reads 1,339 cells, so a (64, 64) one weighs 350 KB.
    "Boomer": Recipe(
        description="three schemes from scratch, one copy of the heuristic per scheme, two that play it for 1 M steps",
        steps=300_000, snapshots=12, hidden=(32, 32), per_scheme={"pbt": {"population_size": 4}},
        early_snapshots=4, warm_runs=1, warm_start={"steps": 100_000, "rounds": 5, "epochs": 6},
        warm_steps=100_000, warm_overrides={"hidden": (64, 64)},
        top_runs=playing_the_heuristic(1_000_000, hidden=(64, 64))),
    # SP from scratch beats the random agent within 100,000 steps but scores about 0.05 against the
    # heuristic after 300,000, and a copy of the heuristic that then plays it won none of 60 matches:
    # tuned heuristics (``scripted=``) make the top.
    "BattleCity": dataclasses.replace(
        TOP_DOWN_DUELS, warm_overrides={"hidden": (64, 64)},
        description="the top-down duels' ladder with narrower copies of the heuristic; tuned heuristics make the top"),
    # SP from scratch scores about 0.65 against the random agent and none against the heuristic after
    # 300,000 steps: the copies of the heuristic give the middle, tuned heuristics (``scripted=``) the top.
    # Members from 50 Elo above the random agent spread 753 Elo, from 0 846.
    "Fighter": dataclasses.replace(
        TOP_DOWN_DUELS, warm_overrides={"hidden": (64, 64)}, floor_margin=0.0,
        description="the top-down duels' ladder with narrower copies of the heuristic, floor 0; tuned heuristics make the top"),
}
FALLBACK_RECIPE = Recipe(description="three schemes from scratch, for a game without a recipe of its own",
                         steps=200_000, snapshots=12, hidden=(32, 32), per_scheme={"pbt": {"population_size": 4}})


def recipe_for(game_id: str) -> Recipe:
    """The default recipe of ``game_id`` (:data:`RECIPES`, or a generic one)."""
    return RECIPES.get(game_id.split("-", 1)[0], FALLBACK_RECIPE)


def default_schemes(game_id: str) -> tuple[str, ...]:
    """``sp``, ``pbt`` and ``dppo``, plus ``cc`` when teams have several players."""
    from arena_league.envs import game_spec

    return DEFAULT_SCHEMES + (TEAM_SCHEMES if game_spec(game_id).players_per_team > 1 else ())
