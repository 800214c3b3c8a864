"""Conformance of a game to what the league asks of it, one command a game author runs::

    python -m arena_league.envs.check NewGame-2T1P-v1 [MORE_IDS ...] [--quick] [--json] [--only api,bounds]

Every check plays the game id through the same doors the league uses (``make``, ``make_aec``, the
rules' declarations) and either passes, saying what it measured, or fails saying what is wrong and
how to fix it, e.g. ``observation cell 12 of player_0 left its bounds [-1, 1] (value 1.7) at step
40 of seed 3: widen observation_bounds() or clip in observe()``. The command prints one line per
check and exits 0 when every check passed, 1 otherwise (2 for an unknown id); ``--json`` prints one
JSON document instead. ``--quick`` runs the same checks on small budgets (seconds per game); the
test suite runs them that way over every id of the catalog (``tests/test_envs_conformance.py``).

The checks, in order (:data:`CHECKS`):

* ``api``: PettingZoo's own API tests, ``parallel_api_test`` for every action type and, for
  turn-based games, ``api_test`` of the native AEC env;
* ``determinism``: two fresh envs, and an env that played another match before, given the same
  seeds and actions, hand out bit-identical observations, rewards, ends, states, events and results;
* ``copies``: ``pickle``, ``copy.deepcopy`` and cloudpickle copies, of a fresh env, after a reset,
  mid-episode and after the episode ended, go on exactly as the original;
* ``bounds``: observation and state spaces are finite; every observation, action mask and state
  of seeded random play lies inside them, with the sizes and types the rules declare;
* ``options``: the game's declared options (``GameRules.options``, :mod:`arena_league.envs.options`)
  build at their defaults, and an unknown option is refused by name;
* ``tree``: the default social tree builds and verifies as declared (:mod:`arena_league.envs.social.verify`);
* ``heuristic``: the scripted heuristic returns legal actions of the right shape for any batch of
  seats, the same for the same observations, and plays a whole episode;
* ``render``: the top-down picture is drawn without a display;
* ``scene``: ``scene_entities`` is well formed at every step of an episode, with stable ids;
* ``controls``: ``human_controls(seat)`` works for every seat and every key, click or typed
  answer it accepts makes a legal action the env takes;
* ``throughput``: env steps per second through the PettingZoo API, failing under a floor with the
  functions the time went to.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import cProfile
import io
import json
import pickle
import pstats
import sys
import time
import traceback
import warnings
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from arena_league.envs import default_tree, example_trees, game_spec, list_games, make, make_aec
from arena_league.envs import scene as scene_parts
from arena_league.envs.controls import Controls
from arena_league.envs.env import ArenaParallelEnv

__all__ = ["CHECKS", "FULL", "QUICK", "Budget", "Check", "CheckFailure", "CheckResult", "check_game", "main",
           "run_check"]


@dataclass(frozen=True)
class Budget:
    """How much play each check spends on one game id."""

    #: Cycles of PettingZoo's API tests.
    api_cycles: int
    #: Steps of each seeded rollout (determinism, bounds, heuristic, scene).
    steps: int
    #: Seeds rolled out by the determinism and bounds checks.
    seeds: int
    #: Episode length (``max_cycles``) of the determinism and bounds rollouts, short enough that
    #: they cross episode ends and the resets after them.
    episode_cycles: int
    #: Episode length of the copies check (short, so copies are taken across episode ends).
    copy_cycles: int
    #: Paired samples of the tree verification per seat of the layout, and at least per team (a
    #: node over more teams has more pairs of children whose signs it estimates).
    samples_per_seat: int
    samples_per_team: int
    #: Seconds of stepping timed by the throughput check, per action type.
    seconds: float
    #: Env steps per second under which the throughput check fails.
    floor: float


#: The budget of the command: a few seconds to a minute per game id.
FULL = Budget(api_cycles=200, steps=300, seeds=3, episode_cycles=100, copy_cycles=12, samples_per_seat=8,
              samples_per_team=16, seconds=1.0, floor=150.0)
#: The budget of ``--quick`` and of the test suite over the whole catalog.
QUICK = Budget(api_cycles=100, steps=60, seeds=1, episode_cycles=25, copy_cycles=8, samples_per_seat=2,
               samples_per_team=4, seconds=0.2, floor=50.0)


class CheckFailure(Exception):
    """A check that failed: the message says what is wrong and how to fix it."""


@dataclass(frozen=True)
class CheckResult:
    """One check of one game id."""

    game_id: str
    check: str
    ok: bool
    #: What was measured (passed), or what is wrong and the fix (failed).
    detail: str
    seconds: float


@dataclass(frozen=True)
class Check:
    """A named check: ``run(game_id, budget)`` returns what it measured or raises :class:`CheckFailure`."""

    name: str
    meaning: str
    run: Callable[[str, Budget], str]


# --- play --------------------------------------------------------------------------------------------
def _action_types(game_id: str) -> tuple[str, ...]:
    return game_spec(game_id).rules.action_types


def _random_actions(env: ArenaParallelEnv, rng: np.random.Generator) -> dict[str, Any]:
    return {a: env.rules.random_action(i, rng) for i, a in enumerate(env.possible_agents)}


def _difference(a: Any, b: Any, where: str) -> str | None:
    """Where ``a`` and ``b`` first differ, bit for bit, through the dicts, tuples and arrays the
    PettingZoo API hands out (None when they are equal); ``where`` names ``a``."""
    if isinstance(a, dict):
        if not isinstance(b, dict) or a.keys() != b.keys():
            return f"{where} (its keys or its kind)"
        for key in a:
            found = _difference(a[key], b[key], f"{where}/{key}" if where else str(key))
            if found:
                return found
        return None
    if isinstance(a, (tuple, list)):
        if type(a) is not type(b) or len(a) != len(b):
            return f"{where} (its length or its kind)"
        for k, (x, y) in enumerate(zip(a, b, strict=True)):
            found = _difference(x, y, f"{where}[{k}]")
            if found:
                return found
        return None
    if isinstance(a, np.ndarray):
        if not isinstance(b, np.ndarray) or a.dtype != b.dtype or a.shape != b.shape:
            return f"{where} (its dtype or shape)"
        unequal = a != b
        if a.dtype.kind in "fc":
            unequal &= ~(np.isnan(a) & np.isnan(b))
        cells = np.flatnonzero(unequal)
        if len(cells):
            cell = int(cells[0])
            return f"{where} cell {cell} ({a.ravel()[cell].item()!r} vs {b.ravel()[cell].item()!r})"
        return None
    if type(a) is not type(b) or a != b:
        return f"{where} ({getattr(a, 'item', lambda: a)()!r} vs {getattr(b, 'item', lambda: b)()!r})"
    return None


def _reset_record(out: tuple) -> dict[str, Any]:
    """What a reset hands out, by name."""
    return {"observations after reset": out[0], "infos after reset": out[1]}


_STEP_PARTS = ("observations", "rewards", "terminations", "truncations", "infos")


def _step_record(env: ArenaParallelEnv, out: tuple) -> dict[str, Any]:
    """What one step hands out and leaves behind: the PettingZoo tuple, the state, the events and,
    once the episode is over, the teams' results."""
    record = dict(zip(_STEP_PARTS, out, strict=True))
    record["state"] = env.state()
    record["events"] = env.rules.events()
    record["step count"] = env.step_count
    if not env.agents:
        record["team results"] = np.asarray(env.team_result())
    return record


def _play(env: ArenaParallelEnv, steps: int, seed: int, reseed: bool) -> Iterator[dict[str, Any]]:
    """``steps`` steps of random legal actions drawn from a generator seeded ``seed``, as records
    of what the env handed out. An episode's end is followed by a reset seeded ``seed + episode``
    (``reseed``) or drawn from the env's own seed sequence. Envs played from one point with one
    seed must give the same records."""
    rng = np.random.default_rng(seed)
    episode = 0
    for _ in range(steps):
        if not env.agents:
            episode += 1
            yield _reset_record(env.reset(seed=seed + episode) if reseed else env.reset())
        else:
            yield _step_record(env, env.step(_random_actions(env, rng)))


def _where(game_id: str, action_type: str) -> str:
    return f"{game_id} (action_type={action_type!r})" if len(_action_types(game_id)) > 1 else game_id


# --- api ---------------------------------------------------------------------------------------------
def _assertion_site(error: BaseException, in_libraries: bool = True) -> str:
    """The file, line and source of the innermost frame of ``error``; with ``in_libraries`` false,
    of the innermost frame outside installed packages and this module (the game's own code)."""
    frames = traceback.extract_tb(error.__traceback__)
    if not in_libraries:
        frames = [f for f in frames if "site-packages" not in f.filename and f.filename != __file__] or frames
    if not frames:
        return "unknown place"
    last = frames[-1]
    return f"{last.filename.rsplit('site-packages/', 1)[-1]}:{last.lineno} `{(last.line or '').strip()}`"


@contextlib.contextmanager
def _quiet_masked_warnings() -> Iterator[None]:
    # PettingZoo's API tests always warn about the classic dict observations of masked games
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Observation (space for each agent probably|is not a NumPy array)")
        warnings.filterwarnings("ignore", message="Agent's (minimum|maximum) observation space value is")
        yield


def check_api(game_id: str, budget: Budget) -> str:
    from pettingzoo.test import api_test, parallel_api_test

    done = []
    for action_type in _action_types(game_id):
        try:
            with _quiet_masked_warnings(), contextlib.redirect_stdout(io.StringIO()):
                parallel_api_test(make(game_id, action_type=action_type), num_cycles=budget.api_cycles)
        except AssertionError as error:
            raise CheckFailure(
                f"PettingZoo's parallel_api_test failed on {_where(game_id, action_type)}: {error or 'assertion'} "
                f"at {_assertion_site(error)}: the env wraps the rules, so make obs_dim, n_actions and act_dim "
                "match what observe() and the heuristic use, and keep observe() inside observation_bounds()") from None
        done.append(f"parallel_api_test {action_type}")
    if game_spec(game_id).rules.turn_based:
        try:
            with _quiet_masked_warnings(), contextlib.redirect_stdout(io.StringIO()):
                api_test(make_aec(game_id), num_cycles=budget.api_cycles)
        except AssertionError as error:
            raise CheckFailure(
                f"PettingZoo's api_test of the native AEC env failed: {error or 'assertion'} at "
                f"{_assertion_site(error)}: current_player() must name a seat still playing, and action_mask() "
                "must mark at least one legal action for it until the match ends") from None
        done.append("api_test (AEC)")
    return f"{', '.join(done)}, {budget.api_cycles} cycles each"


# --- determinism -------------------------------------------------------------------------------------
_DETERMINISM_FIX = ("draw every random number from self.rng, made in reset(seed) from the seed, and let reset() "
                    "rebuild every piece of match state (a module-level cache, a set's order or a leftover of the "
                    "previous match makes two runs differ)")


def check_determinism(game_id: str, budget: Budget) -> str:
    compared = 0
    for action_type in _action_types(game_id):
        for k in range(budget.seeds):
            seed = 3 + 7 * k
            first, second, used = (make(game_id, action_type=action_type, max_cycles=budget.episode_cycles)
                                   for _ in range(3))
            # the third env plays part of another match first: nothing of it may reach the next one
            used.reset(seed=seed + 1000)
            rng = np.random.default_rng(seed + 1000)
            for _ in range(min(20, budget.steps)):
                if used.agents:
                    used.step(_random_actions(used, rng))
            resets = [_reset_record(env.reset(seed=seed)) for env in (first, second, used)]
            for name, other in (("two fresh envs", resets[1]), ("a fresh env and one that played before", resets[2])):
                found = _difference(resets[0], other, "")
                if found:
                    raise CheckFailure(f"{found} differs after reset(seed={seed}) between {name} of "
                                       f"{_where(game_id, action_type)}: {_DETERMINISM_FIX}")
            plays = [_play(env, budget.steps, seed, reseed=True) for env in (first, second, used)]
            for step, (reference, fresh, played) in enumerate(zip(*plays, strict=True)):
                for name, other in (("two fresh envs", fresh), ("a fresh env and one that played before", played)):
                    found = _difference(reference, other, "")
                    if found:
                        raise CheckFailure(f"{found} differs at step {step} of seed {seed} between {name} of "
                                           f"{_where(game_id, action_type)}: {_DETERMINISM_FIX}")
                compared += 1
    return f"{compared} steps bit-identical across fresh and used envs ({budget.seeds} seeds per action type)"


# --- copies ------------------------------------------------------------------------------------------
def _copiers() -> dict[str, Callable[[Any], Any]]:
    import cloudpickle

    return {"pickle": lambda env: pickle.loads(pickle.dumps(env)), "deepcopy": copy.deepcopy,
            "cloudpickle": lambda env: cloudpickle.loads(cloudpickle.dumps(env))}


_COPY_FIX = ("rules must pickle into rules that go on exactly as the original: keep no lambdas, open files or "
             "handles in attributes, and for physics whose solver state cannot be read (pymunk) mix in "
             "core.ReplayedMatch and record every call that changes the match")


def _copy(copier: Callable[[Any], Any], env: ArenaParallelEnv, name: str, where: str) -> ArenaParallelEnv:
    try:
        return copier(env)
    except Exception as error:  # any error of a copy is the rules' to fix, reported as such
        raise CheckFailure(f"a {name} copy of {where} raised {type(error).__name__}: {error}: {_COPY_FIX}") from None


def _same_play(expected: list[dict[str, Any]], duplicate: ArenaParallelEnv, what: str) -> None:
    """Refuse a copy whose play differs from the records ``expected`` of the original's."""
    for step, (a, b) in enumerate(zip(expected, _play(duplicate, len(expected), seed=4, reseed=False),
                                      strict=True)):
        found = _difference(a, b, "")
        if found:
            raise CheckFailure(f"{what}: {found} differs {step} steps after the copy: {_COPY_FIX}")


def check_copies(game_id: str, budget: Budget) -> str:
    cycles = budget.copy_cycles
    copiers = _copiers()
    for action_type in _action_types(game_id):
        where = _where(game_id, action_type)
        original = make(game_id, action_type=action_type, max_cycles=cycles)
        for name, copier in copiers.items():
            duplicate, fresh = _copy(copier, original, name, where), make(game_id, action_type=action_type,
                                                                            max_cycles=cycles)
            # unseeded first resets draw from every env's own seed sequence, seeded ones from the seed
            for seed in (None, 5):
                found = _difference(_reset_record(duplicate.reset(seed=seed)), _reset_record(fresh.reset(seed=seed)),
                                    "")
                if found:
                    raise CheckFailure(f"a {name} copy of a fresh {where} reset with seed={seed}: {found} differs "
                                       f"from a fresh env's: {_COPY_FIX}")
            _same_play(list(_play(fresh, 2 * cycles, seed=4, reseed=False)), duplicate,
                       f"a {name} copy of a fresh {where}")
        if original.agents or original.step_count:
            raise CheckFailure(f"copying a fresh {where} reset or stepped it: copies take nothing from the original "
                               "(__getstate__ must not change the env or its rules)")
        for point, lead_in in (("after reset", 0), ("mid-episode", cycles // 2), ("after the episode ended", cycles)):
            original = make(game_id, action_type=action_type, max_cycles=cycles)
            original.reset(seed=3)
            rng = np.random.default_rng(2)
            for _ in range(lead_in):
                if original.agents:
                    original.step(_random_actions(original, rng))
            duplicates = {name: _copy(copier, original, name, where) for name, copier in copiers.items()}
            expected = list(_play(original, 2 * cycles, seed=4, reseed=False))  # across episode ends
            for name, duplicate in duplicates.items():
                _same_play(expected, duplicate, f"a {name} copy of {where} {point}")
    return (f"{len(copiers)} copiers of fresh envs and at 3 points of an episode go on as the original "
            f"({2 * cycles} steps each)")


# --- bounds ------------------------------------------------------------------------------------------
def _finite_space(low: np.ndarray, high: np.ndarray, what: str, method: str) -> None:
    bad = np.flatnonzero(~(np.isfinite(low) & np.isfinite(high)))
    if len(bad):
        cell = int(bad[0])
        raise CheckFailure(f"{what} cell {cell} has unbounded space [{low[cell]}, {high[cell]}]: give every cell "
                           f"finite bounds in {method} (core.cell_bounds) from the limits the manual documents")


def _inside(vector: np.ndarray, low: np.ndarray, high: np.ndarray, what: str, at: str,
            fix: Callable[[int], str]) -> None:
    """Refuse a vector of another type or shape than its space, or a cell outside its bounds;
    ``fix(cell)`` says how to mend that cell."""
    if vector.dtype != np.float32 or vector.shape != low.shape:
        raise CheckFailure(f"{what} is {vector.dtype}{list(vector.shape)}, not float32{list(low.shape)}{at}: "
                           f"{fix(0)}")
    outside = np.flatnonzero(~((vector >= low) & (vector <= high)))
    if len(outside):
        cell = int(outside[0])
        raise CheckFailure(f"{what} cell {cell} left its bounds [{low[cell]:g}, {high[cell]:g}] "
                           f"(value {float(vector[cell]):.6g}){at}: {fix(cell)}")


def check_bounds(game_id: str, budget: Budget) -> str:
    observed = 0
    for action_type in _action_types(game_id):
        where = _where(game_id, action_type)
        for state_in_obs in (False, True):
            env = make(game_id, action_type=action_type, state_in_obs=state_in_obs, max_cycles=budget.episode_cycles)
            rules = env.rules
            masked = rules.action_type == "discrete" and rules.masks_actions
            obs_fix = "widen observation_bounds() or clip in observe()"
            state_fix = "widen state_bounds() or clip in state()"
            for agent in env.possible_agents:
                space = env.vector_observation_space(agent)
                _finite_space(space.low[: rules.obs_dim], space.high[: rules.obs_dim], f"{agent}'s observation",
                              "observation_bounds()")
            _finite_space(env.state_space.low, env.state_space.high, "the state", "state_bounds()")
            for k in range(budget.seeds):
                seed = 11 + k
                rng = np.random.default_rng(seed)
                obs, _ = env.reset(seed=seed)
                for step in range(budget.steps):
                    at = f" at step {step} of seed {seed} of {where}" + (" with state_in_obs" if state_in_obs else "")
                    raw = rules.observe()
                    if not isinstance(raw, np.ndarray) or raw.dtype != np.float32 or \
                            raw.shape != (rules.n_agents, rules.obs_dim):
                        raise CheckFailure(f"observe() returned {getattr(raw, 'dtype', type(raw))} "
                                           f"{getattr(raw, 'shape', '')}{at}, not float32[n_agents={rules.n_agents}, "
                                           f"obs_dim={rules.obs_dim}]: build it as that array")
                    state = env.state()
                    _inside(state, env.state_space.low, env.state_space.high, "the state", at,
                            lambda _, fix=state_fix: fix)
                    for agent in env.possible_agents:
                        space = env.vector_observation_space(agent)
                        vector = obs[agent]["observation"] if masked else obs[agent]
                        _inside(vector, space.low, space.high, f"{agent}'s observation", at,
                                lambda cell, dim=rules.obs_dim, fixes=(obs_fix, state_fix): fixes[cell >= dim])
                        if state_in_obs and not np.array_equal(vector[-rules.state_dim:], state):
                            raise CheckFailure(f"{agent}'s observation{at} does not end with env.state(): state() "
                                               "must return a new array of the state now, the same every call")
                        if masked:
                            mask = obs[agent]["action_mask"]
                            if mask.dtype != np.int8 or mask.shape != (rules.n_actions,) or not \
                                    np.isin(mask, (0, 1)).all():
                                raise CheckFailure(f"{agent}'s action mask{at} is not int8[{rules.n_actions}] of 0 "
                                                   "and 1: action_mask() returns bool[n_agents, n_actions]")
                    observed += 1
                    if not env.agents:
                        obs, _ = env.reset()
                        continue
                    obs, *_ = env.step(_random_actions(env, rng))
    return f"{observed} observations and states inside finite spaces, with and without state_in_obs"


# --- options -----------------------------------------------------------------------------------------
def check_options(game_id: str, budget: Budget) -> str:
    from arena_league.envs.options import Option

    options = tuple(getattr(game_spec(game_id).rules, "options", ()))
    for option in options:
        if not isinstance(option, Option):
            raise CheckFailure(f"{game_id}'s options hold {option!r}, not an arena_league.envs.options.Option: "
                               "declare each keyword option as Option(name, kind, default, meaning, ...)")
        if option.default is None:
            continue
        try:
            make(game_id, **{option.name: option.default})
        except Exception as error:  # whatever refuses the declared default is the finding
            raise CheckFailure(f"make({game_id!r}, {option.name}={option.default!r}) (the option's declared default) "
                               f"raised {type(error).__name__}: {error}: the default must be a value the game "
                               "accepts") from None
    unknown = "no_such_option_of_any_game"
    try:
        make(game_id, **{unknown: 1})
    except ValueError as error:
        if unknown not in str(error):
            raise CheckFailure(f"make({game_id!r}, {unknown}=1) was refused without naming the option ({error}): "
                               "check the keyword options with options.check_options") from None
    except Exception as error:  # another kind of refusal: the front ends report only ValueError as bad input
        raise CheckFailure(f"make({game_id!r}, {unknown}=1) raised {type(error).__name__} ({error}), not a "
                           "ValueError naming the option: check the keyword options with options.check_options"
                           ) from None
    else:
        raise CheckFailure(f"make({game_id!r}, {unknown}=1) was accepted: refuse unknown keyword options with "
                           "options.check_options(game, kwargs, options)")
    return f"{len(options)} declared options build at their defaults; an unknown option is refused by name"


# --- the social tree ---------------------------------------------------------------------------------
def check_tree(game_id: str, budget: Budget) -> str:
    from arena_league.envs.social.tree import TreeSpecError
    from arena_league.envs.social.verify import verify_env

    spec = game_spec(game_id)
    trees = {"default": default_tree(game_id), **example_trees(game_id)}
    for name, tree in trees.items():
        try:
            make(game_id, tree=tree)
        except TreeSpecError as error:
            raise CheckFailure(f"the {name} tree of {game_id} does not build: {error}") from None
    samples = max(4, budget.samples_per_seat * spec.n_agents, budget.samples_per_team * spec.n_teams)
    samples = -(-samples // spec.n_agents) * spec.n_agents  # every seat is perturbed as often
    report = verify_env(make(game_id), samples=samples, seed=0)
    wrong = [node for node in report.nodes if not node.ok]
    if wrong:
        node = wrong[0]
        if node.verified == "NL":
            why = (f"its reward ({node.reward}) never moved when a seat below it played better in "
                   f"{node.learnable_share:.0%} of {node.pairs} pairs: give it a reward that reads a measure the "
                   "seat's play changes, and check that heuristic() plays better than random actions")
        else:
            why = (f"its reward ({node.reward}) behaves as {node.verified} over {node.pairs} pairs: declare "
                   f"{node.verified!r} in default_tree() or give the node a reward of the declared scheme")
        more = f" (and {len(wrong) - 1} more nodes)" if len(wrong) > 1 else ""
        raise CheckFailure(f"default tree node {node.path} is declared {node.declared} but verified "
                           f"{node.verified}{more}: {why}; if the sample is too small, run the check without "
                           "--quick for more pairs")
    return (f"{len(trees)} trees build; the default tree's {len(report.nodes)} nodes verify as declared over "
            f"{samples} paired samples")


# --- the heuristic -----------------------------------------------------------------------------------
def _legal(rules: Any, actions: np.ndarray, seats: range | list[int], what: str) -> None:
    """Refuse actions that are out of range or, in games with illegal moves, illegal for the
    seats that act."""
    n = rules.n_agents
    if rules.action_type == "discrete":
        if actions.shape != (n,) or actions.dtype.kind not in "iu":
            raise CheckFailure(f"{what} are {actions.dtype}{list(actions.shape)}, not int64[{n}]: return one "
                               "integer action per observation row")
        out = [i for i in seats if not 0 <= int(actions[i]) < rules.n_actions]
        if out:
            raise CheckFailure(f"{what}: action {int(actions[out[0]])} of seat {out[0]} is outside "
                               f"0..{rules.n_actions - 1}")
        mask = rules.action_mask()
        if mask is not None:
            illegal = [i for i in seats if not mask[i, int(actions[i])]]
            if illegal:
                raise CheckFailure(f"{what}: action {int(actions[illegal[0]])} of seat {illegal[0]} is illegal "
                                   "(action_mask() says so): choose among the legal actions the observation shows")
        return
    if actions.shape != (n, rules.act_dim):
        raise CheckFailure(f"{what} have shape {list(actions.shape)}, not [{n}, act_dim={rules.act_dim}]: return one "
                           "action vector per observation row")
    values = np.asarray(actions, dtype=np.float64)
    bad = [i for i in seats if not (np.all(np.isfinite(values[i])) and np.all(np.abs(values[i]) <= 1.0))]
    if bad:
        raise CheckFailure(f"{what}: seat {bad[0]}'s action {values[bad[0]].tolist()} is not finite within [-1, 1]: "
                           "clip the heuristic's output to [-1, 1]")


def check_heuristic(game_id: str, budget: Budget) -> str:
    played = 0
    for action_type in _action_types(game_id):
        where = _where(game_id, action_type)
        env = make(game_id, action_type=action_type)
        rules = env.rules
        obs = env.reset_arrays(seed=5)
        for step in range(budget.steps):
            rows = obs[:, : rules.obs_dim]
            what = f"heuristic() actions at step {step} of {where}"
            try:
                actions = np.asarray(rules.heuristic(rows, action_type))
            except Exception as error:  # a heuristic that raises on some observation is the finding
                raise CheckFailure(f"heuristic() raised {type(error).__name__} ({error}) at step {step} of {where}, "
                                   f"in {_assertion_site(error, in_libraries=False)}: it takes float32[N, obs_dim] observations of any "
                                   "N seats") from None
            mover = rules.current_player()
            _legal(rules, actions, [mover] if mover is not None else range(rules.n_agents), what)
            again = np.asarray(rules.heuristic(rows.copy(), action_type))
            if not np.array_equal(actions, again):
                raise CheckFailure(f"{what} differ between two calls on the same observations: the heuristic is "
                                   "deterministic (draw no random numbers; verification's paired episodes need it)")
            if step % 10 == 0:
                for i in range(rules.n_agents):
                    alone = np.asarray(rules.heuristic(rows[i: i + 1], action_type))
                    if not np.array_equal(alone[0], actions[i]):
                        raise CheckFailure(f"{what}: seat {i}'s action differs when its observation comes alone: "
                                           "decide each row from that row only (any seat, any batch)")
            played += 1
            obs, _, terminated, truncated = env.step_arrays(actions)
            if terminated or truncated:
                obs = env.reset_arrays()
    return f"{played} steps of legal, deterministic, row-wise heuristic actions"


# --- render ------------------------------------------------------------------------------------------
def check_render(game_id: str, budget: Budget) -> str:
    env = make(game_id, render_mode="rgb_array")
    env.reset(seed=0)
    env.step(_random_actions(env, np.random.default_rng(0)))
    picture = env.render()
    fix = "render_topdown() returns a uint8[H, W, 3] picture of the whole arena, drawn without a display"
    if not isinstance(picture, np.ndarray) or picture.dtype != np.uint8 or picture.ndim != 3 or picture.shape[2] != 3:
        raise CheckFailure(f"the top-down picture is {getattr(picture, 'dtype', type(picture))}"
                           f"{list(getattr(picture, 'shape', []))}: {fix}")
    if min(picture.shape[:2]) < 64:
        raise CheckFailure(f"the top-down picture is {picture.shape[1]}x{picture.shape[0]} pixels: draw it at least "
                           "64x64 (the text view of the human controls reads it)")
    colours = len(np.unique(picture.reshape(-1, 3), axis=0))
    if colours <= 2:
        raise CheckFailure(f"the top-down picture has {colours} colours: {fix}, showing walls, seats and objects")
    if make(game_id).render() is not None:
        raise CheckFailure("render() without a render_mode drew a picture: that is the env's job; do not override it")
    return f"{picture.shape[1]}x{picture.shape[0]} picture with {colours} colours"


# --- the replay scene ----------------------------------------------------------------------------------
def _primitive_fields() -> dict[str, frozenset[str]]:
    """The fields :mod:`arena_league.envs.scene`'s builders give each primitive kind."""
    grey = (0.5, 0.5, 0.5, 1.0)
    built = {"cubes": scene_parts.cube(0, 0, 0, (1, 1, 1), grey),
             "spheres": scene_parts.sphere(0, 0, 0, (1, 1, 1), grey),
             "cylinders": scene_parts.disc(0, 0, 1, grey), "arrows": scene_parts.arrow(0, 0, 0, 0, 1, grey),
             "lines": scene_parts.lines([(0, 0, 0), (1, 0, 0)], grey, 0.1), "texts": scene_parts.text(0, 0, 0, "a")}
    return {kind: frozenset(fields) for kind, fields in built.items()}


def _colours(value: Any) -> Iterator[dict]:
    if isinstance(value, dict):
        if set(value) == {"r", "g", "b", "a"}:
            yield value
        else:
            for item in value.values():
                yield from _colours(item)
    elif isinstance(value, list):
        for item in value:
            yield from _colours(item)


def _scene_problem(entities: Any, timestamp_ns: int, ids: list[str] | None) -> str | None:
    if not isinstance(entities, list) or not entities:
        return f"scene_entities returned {type(entities).__name__} {entities!r:.60}, not a non-empty list of entities"
    try:
        again = json.loads(json.dumps(entities, allow_nan=False))
    except (TypeError, ValueError) as error:
        return f"the entities are not plain JSON ({error}): build them with arena_league.envs.scene, from floats"
    if again != entities:
        return "the entities change through JSON (tuples or numpy values): build them with arena_league.envs.scene"
    fields = set(scene_parts.entity("x", 0))
    kinds = _primitive_fields()
    sec, nsec = divmod(timestamp_ns, 1_000_000_000)
    for entity in entities:
        name = entity.get("id") if isinstance(entity, dict) else None
        if not isinstance(entity, dict) or set(entity) != fields:
            return f"entity {name!r} is not a foxglove.SceneEntity: build it with scene.entity(id, timestamp_ns, ...)"
        if entity["frame_id"] != scene_parts.FRAME_ID or entity["timestamp"] != {"sec": sec, "nsec": nsec}:
            return f"entity {name!r} is not stamped {timestamp_ns} in frame {scene_parts.FRAME_ID!r}: pass the " \
                   "timestamp_ns scene_entities was given to scene.entity"
        for kind, required in kinds.items():
            for primitive in entity[kind]:
                if not isinstance(primitive, dict) or not required <= set(primitive):
                    return f"entity {name!r} has a {kind[:-1]} without its fields: build it with scene's builders"
        for colour in _colours(entity):
            if not all(0.0 <= float(colour[c]) <= 1.0 for c in "rgba"):
                return f"entity {name!r} has a colour outside [0, 1] ({colour}): use scene.colour_of or team_colour"
    found = [entity["id"] for entity in entities]
    if len(set(found)) != len(found):
        twice = sorted({i for i in found if found.count(i) > 1})
        return f"entity ids {twice} appear twice: give every entity its own id"
    if ids is not None and found != ids:
        gone, new = sorted(set(ids) - set(found)), sorted(set(found) - set(ids))
        return (f"the entity ids changed (gone {gone}, new {new}, or reordered): keep the same ids in the same order "
                "every step, so each replay update replaces the last (hide a removed thing, e.g. at zero size)")
    return None


def check_scene(game_id: str, budget: Budget) -> str:
    env = make(game_id)
    rules = env.rules
    rng = np.random.default_rng(1)
    env.reset(seed=1)
    ids = None
    for step in range(budget.steps + 1):
        timestamp = 1_000_000_000 + step * 50_000_007  # odd nanoseconds: the stamp must pass through whole
        try:
            entities = rules.scene_entities(timestamp)
        except Exception as error:  # the replay writer would stop on it: name the step
            raise CheckFailure(f"scene_entities raised {type(error).__name__} at step {step}: {error}") from None
        problem = _scene_problem(entities, timestamp, ids)
        if problem:
            raise CheckFailure(f"the replay scene at step {step} of seed 1: {problem}")
        ids = [entity["id"] for entity in entities]
        if not env.agents:
            env.reset()
        else:
            env.step(_random_actions(env, rng))
    return f"{budget.steps + 1} scenes of {len(ids or [])} entities, well formed, ids stable"


# --- a person's controls ------------------------------------------------------------------------------
#: Typed answers some game's controls take (Enter, an action number, a cell, a direction).
SAMPLE_ANSWERS: tuple[str, ...] = ("", "1", "h8", "w", "d 3")


def _scene_points(rules: Any) -> list[tuple[float, float]]:
    """A grid of world points over the replay scene's extent, where a click may land."""
    xs, ys = [], []
    with contextlib.suppress(ValueError):
        for entity in rules.scene_entities(0):
            for kind in scene_parts.PRIMITIVE_KINDS:
                for primitive in entity.get(kind, ()):
                    if not isinstance(primitive, dict):
                        continue
                    for point in [primitive.get("pose", {}).get("position"), *primitive.get("points", ())]:
                        if point:
                            xs.append(point["x"])
                            ys.append(point["y"])
    if not xs:
        return []
    return [(float(x), float(y)) for x in np.linspace(min(xs), max(xs), 9) for y in np.linspace(min(ys), max(ys), 9)]


def _web_answers(controls: Controls, web: dict[str, Any], rules: Any) -> list[tuple[str, str]]:
    """``(how it is given, answer)`` for every answer the browser's controls may send."""
    kind = web.get("input")
    if kind == "keys":
        keys = web.get("keys")
        if not isinstance(keys, dict) or not keys:
            raise CheckFailure("web() declares keys without a 'keys' map: use controls.key_controls(keys, pace, hint)")
        answers = [(f"key {key!r}", answer) for key, answer in keys.items()]
        if web.get("release") is not None:
            answers.append(("releasing every key", web["release"]))
        answers += [(f"keys held together for {answer!r}", answer) for answer in web.get("accepts", ())]
        return answers
    if kind == "cells":
        answers = []
        for x, y in _scene_points(rules):
            answer = controls.point(x, y)
            if answer is not None:
                answers.append((f"a click at ({x:.2f}, {y:.2f})", answer))
        if not answers:
            raise CheckFailure("web() declares clicks on cells but point(x, y) answers None over the whole scene: "
                               "turn a world point into the answer parse() takes")
        return answers
    if kind == "text":
        return [(f"typing {answer!r}", answer) for answer in SAMPLE_ANSWERS]
    raise CheckFailure(f"web() declares input {kind!r}: one of 'keys', 'cells' or 'text' (see Controls.web)")


def _check_seat_controls(game_id: str, seat: int) -> int:
    env = make(game_id)
    env.reset(seed=0)
    rules = env.rules
    rng = np.random.default_rng(seat)
    while rules.current_player() not in (None, seat) and env.agents:  # turn-based: up to the seat's turn
        env.step(_random_actions(env, rng))
    try:
        controls = rules.human_controls(seat)
    except Exception as error:  # a play session would stop on it: name the seat
        raise CheckFailure(f"human_controls({seat}) raised {type(error).__name__}: {error}") from None
    if not isinstance(controls, Controls) or controls.seat != seat:
        raise CheckFailure(f"human_controls({seat}) returned {type(controls).__name__}, not Controls of seat {seat}: "
                           "subclass arena_league.envs.controls.Controls")
    # the views draw the top-down picture as text, a third of a second each: the first and last seat's suffice
    views = (("view()", controls.view), ("prompt(0)", lambda: controls.prompt(0)),
             ("final_view()", controls.final_view))
    for name, show in views if seat in (0, rules.n_agents - 1) else views[1:2]:
        words = show()
        if not isinstance(words, str) or not words.strip():
            raise CheckFailure(f"seat {seat}'s controls' {name} is empty: show the person the match and the question")
    command, problem = controls.parse("%%")
    if command is not None or not isinstance(problem, str) or not problem:
        raise CheckFailure(f"seat {seat}'s controls accepted '%%': parse() refuses nonsense with what to type instead")
    web = controls.web()
    pace = web.get("pace")
    bad_pace = pace is not None and not (isinstance(pace, (int, float)) and pace > 0)
    if bad_pace or not str(web.get("hint", "")).strip():
        raise CheckFailure(f"seat {seat}'s web() has pace {pace!r} and hint {web.get('hint')!r}: give a positive pace "
                           "(or None to wait for every answer) and a one-line hint")
    tried = 0
    for how, answer in _web_answers(controls, web, rules):
        fresh = rules.human_controls(seat)  # controls keep the last command: each answer is tried alone
        command, problem = fresh.parse(str(answer).strip().lower())
        if problem is not None:
            if web.get("input") == "keys":
                raise CheckFailure(f"seat {seat}: {how} sends {answer!r}, which parse() refuses ({problem}): map every "
                                   "key to an answer parse() takes")
            continue
        action = fresh.action(command)
        actions = np.asarray([rules.random_action(i, rng) for i in range(rules.n_agents)])
        actions[seat] = action
        _legal(rules, actions, [seat], f"seat {seat}'s action from {how} ({answer!r})")
        tried += 1
    if not tried:
        raise CheckFailure(f"seat {seat}'s controls take none of the answers the browser sends ({web.get('input')}): "
                           "make parse() accept them")
    fresh = rules.human_controls(seat)
    accepted = next(a for _, a in _web_answers(fresh, web, rules) if fresh.parse(str(a).strip().lower())[1] is None)
    action = fresh.action(fresh.parse(str(accepted).strip().lower())[0])
    try:
        env.step({**_random_actions(env, rng), f"player_{seat}": action})
    except ValueError as error:
        raise CheckFailure(f"the env refused seat {seat}'s action {action!r} from the controls: {error}") from None
    return tried


def check_controls(game_id: str, budget: Budget) -> str:
    answers = sum(_check_seat_controls(game_id, seat) for seat in range(game_spec(game_id).n_agents))
    return f"every seat's controls; {answers} browser answers make legal actions"


# --- throughput --------------------------------------------------------------------------------------
def _steps_per_second(env: ArenaParallelEnv, pool: list[dict], seconds: float) -> float:
    env.reset(seed=0)
    steps, episodes = 0, 0
    start = time.perf_counter()
    while True:
        for _ in range(32):
            env.step(pool[steps % len(pool)])
            steps += 1
            if not env.agents:
                episodes += 1
                env.reset(seed=episodes)
        elapsed = time.perf_counter() - start
        if elapsed >= seconds:
            return steps / elapsed


def _hot_path(env: ArenaParallelEnv, pool: list[dict]) -> str:
    """The three functions that took the most time of 200 profiled steps, with their share."""
    profile = cProfile.Profile()
    env.reset(seed=0)
    profile.enable()
    for step in range(200):
        env.step(pool[step % len(pool)])
        if not env.agents:
            env.reset(seed=step)
    profile.disable()
    stats = pstats.Stats(profile)
    total = max(stats.total_tt, 1e-9)  # type: ignore[attr-defined]
    rows = sorted(stats.stats.items(), key=lambda item: -item[1][2])[:3]  # type: ignore[attr-defined]
    return ", ".join(f"{function} ({file.rsplit('/', 1)[-1]}:{line}) {own / total:.0%}"
                     for (file, line, function), (_, _, own, _, _) in rows)


def check_throughput(game_id: str, budget: Budget) -> str:
    rates = []
    for action_type in _action_types(game_id):
        env = make(game_id, action_type=action_type)
        env.reset(seed=0)
        rng = np.random.default_rng(0)
        pool = [_random_actions(env, rng) for _ in range(256)]
        rate = _steps_per_second(env, pool, budget.seconds)
        if rate < budget.floor:
            raise CheckFailure(f"{_where(game_id, action_type)} ran {rate:,.0f} env steps/s, under the floor of "
                               f"{budget.floor:,.0f}: the time went to {_hot_path(env, pool)}; write that hot path "
                               "over whole arrays (numpy, no per-seat Python loop) or step the physics less often")
        rates.append(f"{rate:,.0f} {action_type}")
    return f"env steps/s: {', '.join(rates)} (floor {budget.floor:,.0f})"


# --- the command -------------------------------------------------------------------------------------
CHECKS: tuple[Check, ...] = (
    Check("api", "PettingZoo's parallel_api_test (and api_test of turn-based games' AEC env)", check_api),
    Check("determinism", "same seeds and actions give bit-identical trajectories", check_determinism),
    Check("copies", "pickle, deepcopy and cloudpickle copies go on as the original", check_copies),
    Check("bounds", "observations and states inside finite spaces", check_bounds),
    Check("options", "declared options build; unknown ones are refused", check_options),
    Check("tree", "the default social tree builds and verifies", check_tree),
    Check("heuristic", "the heuristic returns legal, deterministic actions row by row", check_heuristic),
    Check("render", "the top-down picture is drawn without a display", check_render),
    Check("scene", "the replay scene is well formed at every step", check_scene),
    Check("controls", "a person's controls of every seat make legal actions", check_controls),
    Check("throughput", "env steps per second above a floor", check_throughput),
)
_BY_NAME = {check.name: check for check in CHECKS}


def run_check(name: str, game_id: str, budget: Budget = FULL, catch: bool = True) -> CheckResult:
    """One check of one game id; whatever the game raises becomes a failure naming where (unless
    ``catch`` is false: then it propagates, with its traceback)."""
    if name not in _BY_NAME:
        raise ValueError(f"unknown check {name!r}; valid: {', '.join(_BY_NAME)}")
    game_spec(game_id)  # an unknown id raises here, listing the valid ones
    start = time.perf_counter()
    try:
        detail, ok = _BY_NAME[name].run(game_id, budget), True
    except CheckFailure as failure:
        detail, ok = str(failure), False
    except Exception as error:
        if not catch:
            raise
        site = _assertion_site(error, in_libraries=False)
        detail, ok = (f"raised {type(error).__name__}: {error} at {site}: fix the game's code there (the "
                      f"traceback: python -m arena_league.envs.check {game_id} --only {name} --raise)"), False
    return CheckResult(game_id, name, ok, detail, round(time.perf_counter() - start, 3))


def check_game(game_id: str, budget: Budget = FULL, only: tuple[str, ...] | None = None) -> list[CheckResult]:
    """Every check (or those named in ``only``) of ``game_id``."""
    return [run_check(check.name, game_id, budget) for check in CHECKS if only is None or check.name in only]


def _line(result: CheckResult, width: int) -> str:
    verdict = "ok  " if result.ok else "FAIL"
    return f"{result.game_id:<{width}}  {result.check:<11} {verdict} {result.detail} ({result.seconds:.1f} s)"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m arena_league.envs.check",
                                     description="Check that game ids meet what the league asks of a game.")
    parser.add_argument("games", nargs="*", metavar="GAME_ID", help="game ids (default: every id of the catalog)")
    parser.add_argument("--quick", action="store_true", help="small budgets: seconds per game")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.add_argument("--only", default=None, help=f"comma-separated checks to run, of {', '.join(_BY_NAME)}")
    parser.add_argument("--floor", type=float, default=None, help="env steps/s under which throughput fails")
    parser.add_argument("--raise", dest="raise_errors", action="store_true",
                        help="let a game's exception propagate with its traceback (to debug a failure)")
    args = parser.parse_args(argv)
    only = None
    if args.only:
        only = tuple(name.strip() for name in args.only.split(",") if name.strip())
        unknown = [name for name in only if name not in _BY_NAME]
        if unknown:
            print(f"unknown check {unknown[0]!r}; valid: {', '.join(_BY_NAME)}", file=sys.stderr)
            return 2
    games = args.games or list_games()
    for game_id in games:
        try:
            game_spec(game_id)
        except (ValueError, TypeError) as error:
            print(error, file=sys.stderr)
            return 2
    budget = QUICK if args.quick else FULL
    if args.floor is not None:
        budget = Budget(**{**asdict(budget), "floor": args.floor})
    width = max(len(g) for g in games)
    results = []
    start = time.perf_counter()
    for game_id in games:
        for check in CHECKS:
            if only is not None and check.name not in only:
                continue
            result = run_check(check.name, game_id, budget, catch=not args.raise_errors)
            results.append(result)
            if not args.json:
                print(_line(result, width), flush=True)
    ok = all(result.ok for result in results)
    elapsed = time.perf_counter() - start
    if args.json:
        print(json.dumps({"ok": ok, "budget": "quick" if args.quick else "full", "seconds": round(elapsed, 1),
                          "budget_sizes": asdict(budget), "results": [asdict(r) for r in results]}, indent=2))
    else:
        failed = sum(not r.ok for r in results)
        print(f"{len(results) - failed} of {len(results)} checks passed over {len(games)} game ids in {elapsed:.0f} s"
              + ("" if ok else f"; {failed} failed"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
