"""The replay document a browser player draws: every game's recorded scene as flat top-down
shapes, the teams in their caption colours, world bounds holding every shape, frames thinned to
a maximum keeping the first and the last, the game's events; a file that is not a replay is refused."""

from __future__ import annotations

import json
import math
import re

import pytest

from arena_league.envs import game_spec, list_games
from arena_league.envs.rendering import TEAM_COLOURS
from arena_league.league import replay_document
from arena_league.league.replays import SHAPE_KINDS, shape_points
from arena_league.matchmaking import AgentRef, play_matches, specs_for_seatings
from arena_league.replay import ReplayError, ReplayRecording, iter_messages

MAX_CYCLES = 40  # short matches: the whole file runs in a few seconds

FIELDS = {  # the keys of each kind of shape
    "rect": {"kind", "x", "y", "w", "h", "yaw", "color", "z"},
    "circle": {"kind", "x", "y", "r", "color", "z"},
    "arrow": {"kind", "x", "y", "x2", "y2", "width", "head_length", "head_width", "color", "z"},
    "line": {"kind", "points", "width", "closed", "segments", "screen", "color", "z"},
    "text": {"kind", "x", "y", "text", "size", "screen", "color", "z"},
}
RGBA = re.compile(r"rgba\((\d{1,3}),(\d{1,3}),(\d{1,3}),(0|1|0?\.\d+)\)")


@pytest.fixture(scope="module")
def replays(tmp_path_factory):
    """game id -> (match result, replay path): one short match of every game, recorded."""
    directory = tmp_path_factory.mktemp("replays")
    out = {}
    for game_id in list_games():
        agents = {name: AgentRef("scripted", name, game_id) for name in ("random", "heuristic")}
        n_teams = game_spec(game_id).n_teams
        seating = tuple(["random", "heuristic"] * n_teams)[:n_teams]
        specs = specs_for_seatings(game_id, [seating], league_seed=7, first_match_id=1)
        (result,) = play_matches(specs, agents, env_kwargs={"max_cycles": MAX_CYCLES},
                                 recording=ReplayRecording(directory))
        result = (result.halves or (result,))[0]  # a game played in pairs: its first half's replay
        out[game_id] = (result, result.replay_path)
    return out


def _inside(bounds, x, y):
    xmin, ymin, xmax, ymax = bounds
    return xmin <= x <= xmax and ymin <= y <= ymax


@pytest.mark.parametrize("game_id", list_games())
def test_document_of_every_game(game_id, replays):
    result, path = replays[game_id]
    document = replay_document(path)
    assert json.loads(json.dumps(document, allow_nan=False)) == document  # plain JSON, round-trips
    assert set(document) == {"match", "teams", "bounds", "frames", "frames_kept_every", "events"}

    match = document["match"]
    assert "path" not in match
    assert (match["game_id"], match["steps"], match["seats"], match["teams"]) == (
        game_id, result.steps, list(result.seats), list(result.teams))
    assert (match["scores"], match["outcomes"]) == (list(result.scores), list(result.outcomes))

    # one frame at reset and one per step, in order
    frames = document["frames"]
    assert document["frames_kept_every"] == 1
    assert len(frames) == result.steps + 1 == match["channels"]["/scene"]
    assert [frame["step"] for frame in frames] == list(range(result.steps + 1))
    assert frames[-1]["step"] == match["steps"]

    # teams in the caption colours, with their agents seat by seat
    teams = sorted(set(result.teams))
    assert [team["team"] for team in document["teams"]] == teams
    for team in document["teams"]:
        red, green, blue = TEAM_COLOURS[team["team"] % len(TEAM_COLOURS)]
        assert team["color"] == f"#{red:02x}{green:02x}{blue:02x}"
        seats = [seat for seat, t in enumerate(result.teams) if t == team["team"]]
        assert team["seats"] == seats
        assert team["agents"] == [result.seats[seat] for seat in seats]
        assert team["score"] == result.scores[seats[0]] and team["outcome"] == result.outcomes[seats[0]]

    # shapes: the documented kinds and fields, CSS colours, drawn by height, inside the bounds
    bounds = document["bounds"]
    assert bounds[0] < bounds[2] and bounds[1] < bounds[3]
    seen = set()
    for frame in frames:
        shapes = frame["shapes"]
        assert shapes, f"step {frame['step']} draws nothing"
        assert [s["z"] for s in shapes] == sorted(s["z"] for s in shapes)
        for shape in shapes:
            seen.add(shape["kind"])
            assert set(shape) == FIELDS[shape["kind"]], shape
            colour = RGBA.fullmatch(shape["color"])
            assert colour and all(0 <= int(c) <= 255 for c in colour.groups()[:3]), shape["color"]
            assert 0 <= float(colour.group(4)) <= 1
            for x, y in shape_points(shape):
                assert _inside(bounds, x, y), (shape, bounds)
    assert seen <= set(SHAPE_KINDS)
    assert {"rect", "circle"} <= seen  # every game has a floor and round things on it

    # events as recorded
    recorded = [message for _, message in iter_messages(path, ["/events"])]
    assert document["events"] == [{"step": m["step"], "kind": m["kind"], "event": m["event"]} for m in recorded]
    assert all(1 <= event["step"] <= result.steps for event in document["events"])


def test_shapes_follow_the_scene(replays):
    """Spot checks against what the games draw: a rect's yaw, arrows pointing the way the agent
    faces, closed loops and segment lists, labels, the agents in their team colours."""
    sumo = replay_document(replays["Sumo-2T1P-v1"][1])
    ring = [s for s in sumo["frames"][0]["shapes"] if s["kind"] == "line" and s["closed"]]
    assert ring and all(math.isclose(math.hypot(x, y), 2.0, abs_tol=1e-3) for x, y in ring[0]["points"])
    arrows = [s for s in sumo["frames"][-1]["shapes"] if s["kind"] == "arrow"]
    assert len(arrows) == 2 and all(math.hypot(a["x2"] - a["x"], a["y2"] - a["y"]) > 0 for a in arrows)

    gobang = replay_document(replays["GoBang-2T1P-v1"][1])
    grid = [s for s in gobang["frames"][0]["shapes"] if s["kind"] == "line"]
    assert len(grid) == 1 and grid[0]["segments"] and len(grid[0]["points"]) % 2 == 0

    soccer = replay_document(replays["Soccer-2T1P-v1"][1])
    labels = [s for s in soccer["frames"][-1]["shapes"] if s["kind"] == "text"]
    assert labels and labels[0]["screen"] and ":" in labels[0]["text"]

    crossroads = replay_document(replays["Crossroads-2T2P-v1"][1])
    colours = {s["color"] for s in crossroads["frames"][0]["shapes"] if s["kind"] == "circle"}
    for team in crossroads["teams"]:
        red, green, blue = (int(team["color"][i:i + 2], 16) for i in (1, 3, 5))
        assert f"rgba({red},{green},{blue},1)" in colours


@pytest.mark.parametrize("max_frames", [2, 3, 7, 10, 40, 41, 1000])
def test_max_frames_thins_keeping_the_first_and_last(max_frames, replays):
    result, path = replays["Crossroads-2T1P-v1"]
    assert result.steps == MAX_CYCLES  # 41 scene messages
    document = replay_document(path, max_frames=max_frames)
    steps = [frame["step"] for frame in document["frames"]]
    every = document["frames_kept_every"]
    assert len(steps) <= max_frames
    assert steps[0] == 0 and steps[-1] == result.steps
    if max_frames >= result.steps + 1:
        assert every == 1 and steps == list(range(result.steps + 1))
    else:
        assert every > 1
        assert steps[:-1] == list(range(0, result.steps, every))  # every k-th, then the last
        assert steps[-1] - steps[-2] <= every
    full = replay_document(path)
    by_step = {frame["step"]: frame for frame in full["frames"]}
    assert all(frame == by_step[frame["step"]] for frame in document["frames"])


def test_max_frames_below_two_is_refused(replays):
    with pytest.raises(ValueError, match="max_frames"):
        replay_document(replays["Crossroads-2T1P-v1"][1], max_frames=1)


def test_a_file_that_is_not_a_replay_is_refused(tmp_path, replays):
    text = tmp_path / "notes.mcap"
    text.write_text("not a replay\n")
    with pytest.raises(ReplayError, match="not a readable MCAP replay"):
        replay_document(text)
    with pytest.raises(ReplayError, match="no replay"):
        replay_document(tmp_path / "missing.mcap")
    truncated = tmp_path / "truncated.mcap"
    with open(replays["Soccer-2T1P-v1"][1], "rb") as stream:
        truncated.write_bytes(stream.read()[:400])
    with pytest.raises(ReplayError):
        replay_document(truncated)
