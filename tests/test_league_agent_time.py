"""Agent time per call size, per match and per job: the red team's agent that is slow only at batch
sizes validation never tried, an agent a little slow on every step, and a job past its wall-time
bound. Each agent is an ONNX graph built with ``onnx.helper`` (a linear policy plus a Loop or a
Reshape whose work depends on the batch's rows), small and deterministic."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hostile_agents import _const, _model, plain, save, spin_body
from onnx import TensorProto, helper

from arena_league import registry as reg
from arena_league.envs import game_spec
from arena_league.league import ensure_scripted_agents, evaluate, open_home, rank, register_game, set_setting
from arena_league.matchmaking import AgentRef, MatchSpec, play_matches
from arena_league.policies import SandboxLimits, largest_batch
from arena_league.policies.validation import validate_submission

GAME = "Crossroads-2T2P-v1"
#: Loop iterations of a "slow" forward: about 0.2 s on the machine these tests were written on
#: (a few microseconds each); the tests count forfeits and matches, never seconds.
SLOW_TRIPS = 40_000


def _rows() -> list:
    """Nodes computing ``rows`` (int64 scalar): the batch's rows."""
    return [helper.make_node("Shape", ["obs"], ["obs_shape"]), _const("zero_index", 0, np.int64),
            helper.make_node("Gather", ["obs_shape", "zero_index"], ["rows"], axis=0)]


def _spin(trips: int, on: str) -> list:
    """A Loop of ``trips`` iterations when ``on`` (int64 scalar, 0 or 1) is 1; its output ``spun``."""
    body = spin_body()
    return [_const("trips_each", trips, np.int64), helper.make_node("Mul", [on, "trips_each"], ["trips"]),
            _const("keep_going", True, np.bool_), _const("start", 0.0, np.float32),
            helper.make_node("Loop", ["trips", "keep_going", "start"], ["spun"], body=body)]


def slow_between_sizes(game_id: str, trips: int = SLOW_TRIPS * 25):
    """The red team's agent: fast at 1 row, at the validation match's rows (one per seat) and from
    32 rows up (the probes, real play and the largest batch), and seconds a forward at every other
    size."""
    seats = game_spec(game_id).n_teams * game_spec(game_id).players_per_team
    nodes = [*_rows(), _const("small", 32, np.int64), helper.make_node("Less", ["rows", "small"], ["below"]),
             _const("probed", [1, seats], np.int64), helper.make_node("Equal", ["rows", "probed"], ["hits"]),
             helper.make_node("Cast", ["hits"], ["hits64"], to=TensorProto.INT64),
             helper.make_node("ReduceMax", ["hits64"], ["tried"], keepdims=0),
             helper.make_node("Cast", ["below"], ["below64"], to=TensorProto.INT64),
             helper.make_node("Sub", ["below64", "tried"], ["difference"]),
             _const("nothing64", 0, np.int64), helper.make_node("Max", ["difference", "nothing64"], ["on"]),
             *_spin(trips, "on")]
    return _model(game_id, nodes, "spun", 0)


def slow_always(game_id: str, trips: int = SLOW_TRIPS):
    """An agent a little slow on every call (well under the budget per call)."""
    return _model(game_id, [_const("on", 1, np.int64), *_spin(trips, "on")], "spun", 0)


def failing_off_ladder(game_id: str):
    """An agent that fails (a Reshape to an impossible shape) at every size validation does not time."""
    largest = largest_batch(game_id)
    ladder = [*(1 << k for k in range(largest.bit_length()) if 1 << k < largest), largest]
    nodes = [*_rows(), _const("ladder", ladder, np.int64), helper.make_node("Equal", ["rows", "ladder"], ["hits"]),
             helper.make_node("Cast", ["hits"], ["hits64"], to=TensorProto.INT64),
             helper.make_node("ReduceMax", ["hits64"], ["timed"], keepdims=0),
             _const("two64", 2, np.int64), helper.make_node("Sub", ["two64", "timed"], ["factor"]),
             helper.make_node("Mul", ["rows", "factor"], ["wanted_rows"]), _const("axes0", [0], np.int64),
             helper.make_node("Unsqueeze", ["wanted_rows", "axes0"], ["wanted_rows_1"]),
             _const("minus_one", [-1], np.int64),
             helper.make_node("Concat", ["wanted_rows_1", "minus_one"], ["new_shape"], axis=0),
             helper.make_node("Reshape", ["obs", "new_shape"], ["reshaped"]),
             helper.make_node("ReduceSum", ["reshaped"], ["total"], keepdims=0)]
    return _model(game_id, nodes, "total", 0)


def onnx_ref(path: Path) -> AgentRef:
    return AgentRef("onnx", str(path), GAME, sandboxed=True)


def register_unvalidated(league, path: Path, name: str) -> None:
    """An active submitted agent, registered without validation (one accepted before the league
    timed every size, or whose behaviour changes in play)."""
    register_game(league, GAME)
    with league.transaction() as session:
        stored = reg.store_artifact(session, league.home, path.read_bytes(), "onnx")
        reg.create_agent(session, name, GAME, "submission", owner="mallory", artifact_sha256=stored.sha256,
                         status="active", metadata={"action_type": "discrete"})


# --- every size the engine hands a call is timed ----------------------------------------------------

def test_validation_times_every_size_a_call_is_padded_to():
    from arena_league.policies.sandbox import padded_rows, timed_batch_sizes

    largest = largest_batch(GAME)
    ladder = timed_batch_sizes(largest)
    assert ladder[0] == 1 and ladder[-1] == largest
    for rows in range(1, largest + 1):
        assert padded_rows(rows, largest) in ladder and padded_rows(rows, largest) >= rows
    assert timed_batch_sizes(192) == [1, 2, 4, 8, 16, 32, 64, 128, 192] and padded_rows(150, 192) == 192


def test_an_agent_slow_only_at_sizes_validation_never_tried_is_rejected_naming_the_size(tmp_path):
    path = save(slow_between_sizes(GAME), tmp_path / "sly.onnx")
    verdict = validate_submission(path, GAME, sandbox_limits=SandboxLimits(call_seconds=0.5))
    assert not verdict.ok, verdict.log
    # the first size it is slow at, 2 rows, stops it at the 0.5 s limit per call
    assert verdict.reason.startswith("at a batch of 2 rows it ran past its 0.5 s budget"), verdict.reason


def test_a_well_behaved_agent_is_timed_at_every_size(tmp_path):
    path = save(plain(GAME), tmp_path / "plain.onnx")
    verdict = validate_submission(path, GAME)
    assert verdict.ok, verdict.reason
    assert [rows for rows, _ in verdict.size["timed"]] == [256, 1, 2, 4, 8, 16, 32, 64, 128]
    assert "timed at every batch size the league hands a call (256, 1, 2, 4" in verdict.log


def test_the_engine_never_hands_a_submitted_agent_a_size_validation_did_not_time(tmp_path):
    """An agent that fails at every untimed size plays three matches at once (six rows a call, then
    fewer as players arrive): it never fails, because every call is padded to a timed size."""
    picky = onnx_ref(save(failing_off_ladder(GAME), tmp_path / "picky.onnx"))
    other = onnx_ref(save(plain(GAME, seed=1), tmp_path / "other.onnx"))
    specs = [MatchSpec(i, GAME, (picky.key, picky.key, other.key, other.key), 100 + i) for i in range(3)]
    results = play_matches(specs, {picky.key: picky, other.key: other}, batch_size=3)
    assert len(results) == 3
    assert [r.forfeit_of for r in results] == [{}, {}, {}]


# --- the overage bank of a match ---------------------------------------------------------------------

def _call_seconds(path: Path) -> float:
    """How long one forward of the agent at ``path`` takes on this machine (the fastest of three)."""
    import time

    import onnxruntime as ort

    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    feed = {session.get_inputs()[0].name: np.zeros((2, game_spec(GAME).rules(2, 2).obs_dim), dtype=np.float32)}
    times = []
    for _ in range(3):
        start = time.perf_counter()
        session.run(None, feed)
        times.append(time.perf_counter() - start)
    return min(times)


def test_an_agent_a_little_slow_every_step_forfeits_once_its_bank_is_used_up(tmp_path):
    path = save(slow_always(GAME), tmp_path / "slow.onnx")
    slow = onnx_ref(path)
    other = onnx_ref(save(plain(GAME, seed=1), tmp_path / "other.onnx"))
    # The budgets follow the agent's own speed on this machine (its loop took 0.2 s a call where the
    # test was written, 0.035 s on a later machine): each call overdraws about three quarters of
    # itself, so a bank of three calls lasts a few steps, never a whole match.
    call = _call_seconds(path)
    step_seconds, overage_seconds = float(f"{call / 4:.2g}"), float(f"{3 * call:.2g}")
    limits = SandboxLimits(call_seconds=5.0, step_seconds=step_seconds, overage_seconds=overage_seconds)
    spec = MatchSpec(0, GAME, (slow.key, slow.key, other.key, other.key), 7)
    [result] = play_matches([spec], {slow.key: slow, other.key: other}, sandbox_limits=limits)
    assert set(result.forfeit_of) == {slow.key}
    reason = result.forfeit_of[slow.key]
    assert f"ran out of time in the match: its overage bank of {overage_seconds:g} s" in reason, reason
    assert f"{step_seconds:g} s a step" in reason, reason
    assert 1 <= result.steps < game_spec(GAME).rules.default_max_cycles, result.steps
    assert result.team_scores()[result.teams[0]] == 0.0  # a forfeit loses


def test_the_league_base_agents_are_not_held_to_the_bank(tmp_path):
    """Trusted agents never draw on a bank, however small: it binds submitted agents only."""
    a, b = AgentRef("scripted", "random", GAME), AgentRef("scripted", "heuristic", GAME)
    sandboxed = onnx_ref(save(plain(GAME), tmp_path / "fine.onnx"))
    specs = [MatchSpec(0, GAME, (a.key, a.key, b.key, b.key), 1),
             MatchSpec(1, GAME, (sandboxed.key, sandboxed.key, a.key, a.key), 2)]
    results = play_matches(specs, {a.key: a, b.key: b, sandboxed.key: sandboxed},
                           sandbox_limits=SandboxLimits(step_seconds=0.001, overage_seconds=0))
    assert results[0].forfeit_of == {}  # the scripted pair, though they share the sandbox's child


# --- a job's wall-time bound -------------------------------------------------------------------------

def test_an_evaluation_past_its_wall_time_reports_its_remaining_matches_as_not_played(tmp_path):
    with open_home(tmp_path / "league") as league:
        register_unvalidated(league, save(plain(GAME), tmp_path / "fine.onnx"), "fine")
        register_unvalidated(league, save(slow_always(GAME), tmp_path / "slow.onnx"), "slow")
        set_setting(league, "jobs.max_seconds", 1)
        set_setting(league, "sandbox.overage_seconds", 3600)  # the bank is not the point here
        report = evaluate(league, GAME, ["fine", "slow"], matches_per_pair=4)
        # every match of the slow agent lasts far more than a second: none is over when time is up
        assert report.played == report.stored == 0 and report.not_played == 4 and report.skipped == 0
        assert report.forfeits == {} and report.suspended == {}
        assert "wall-time bound of 1 s (the setting jobs.max_seconds) after 0 matches; 4 were not played" in (
            report.stop_reason)
        with league.reading() as session:
            assert reg.count_matches(session, GAME) == 0
            assert reg.list_agents(session, game_id=GAME, status="active")


def test_a_placement_past_its_wall_time_stops_with_the_matches_it_played(tmp_path):
    with open_home(tmp_path / "league") as league:
        base = ensure_scripted_agents(league, GAME)
        evaluate(league, GAME, base, matches_per_pair=2)  # the base's ratings, under the default bound
        register_unvalidated(league, save(slow_always(GAME), tmp_path / "slow.onnx"), "slow")
        set_setting(league, "jobs.max_seconds", 1)
        set_setting(league, "sandbox.overage_seconds", 3600)
        report = rank(league, "slow", budget=10, population="league")
        assert report.stopped == "time" and report.played == report.matches == 0 and report.forfeits == 0
        assert report.stop_reason.startswith("the job reached its wall-time bound of 1 s (the setting "
                                             "jobs.max_seconds) after 0 new matches; 10 more of its 10 were not played")
        assert report.suspended is None
