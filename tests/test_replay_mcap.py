"""MCAP replays: one file per match that round-trips to the match result, opens in Foxglove
(a ``foxglove.SceneUpdate`` scene channel), and exports a GIF of the top-down view whose frames
name the agents, the step and the outcome. Every game records; a match that fails leaves no file."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer
from PIL import Image

import arena_league.replay.writer as replay_writer
from arena_league.envs import ArenaParallelEnv, list_games
from arena_league.envs.rendering import TEAM_COLOURS
from arena_league.matchmaking import AgentRef, play_matches, specs_for_seatings
from arena_league.policies.policy import Policy
from arena_league.replay import (
    SCENE_SCHEMA_NAME,
    ReplayError,
    ReplayRecording,
    export_gif,
    iter_messages,
    read_replay,
    replay_file_name,
    replay_frames,
    scene_update_schema,
)
from arena_league.replay.captions import BAND_COLOUR, MatchCaption

GAMES = {  # game id -> env options keeping the matches short
    "GoBang-2T1P-v1": {},
    "Crossroads-2T2P-v1": {"max_cycles": 30},
    "Soccer-2T1P-v1": {"max_cycles": 30},
    "Snake-4T1P-v1": {"max_cycles": 30},
}


def _record(game_id, env_kwargs, directory, seatings=None):
    agents = {name: AgentRef("scripted", name, game_id) for name in ("random", "heuristic")}
    from arena_league.envs import game_spec

    n_teams = game_spec(game_id).n_teams
    seatings = seatings or [tuple(["random", "heuristic"] * n_teams)[:n_teams]]
    specs = specs_for_seatings(game_id, seatings, league_seed=12, first_match_id=3)
    recorded = play_matches(specs, agents, env_kwargs=env_kwargs, recording=ReplayRecording(directory))
    plain = play_matches(specs, agents, env_kwargs=env_kwargs)
    return specs, recorded, plain


@pytest.mark.parametrize("game_id", sorted(GAMES))
def test_replay_round_trips_to_the_match_result(game_id, tmp_path):
    specs, recorded, plain = _record(game_id, GAMES[game_id], tmp_path)
    result = recorded[0]
    assert [r.without_replay() for r in recorded] == plain  # recording changes nothing
    assert result.replay_path == str(tmp_path / replay_file_name(specs[0]))
    summary = read_replay(result.replay_path)
    assert summary.result == result
    assert (summary.game_id, summary.seed, summary.seats, summary.steps) == (game_id, specs[0].seed,
                                                                             specs[0].seats, result.steps)
    assert summary.env_kwargs == GAMES[game_id]
    steps = result.steps
    counts = summary.channels
    assert counts["/observations"] == counts["/scene"] == steps + 1
    assert counts["/actions"] == counts["/rewards"] == steps
    assert counts["/match"] == counts["/result"] == 1
    assert summary.schemas["/scene"] == SCENE_SCHEMA_NAME == "foxglove.SceneUpdate"
    assert json.loads(json.dumps(summary.to_dict()))["steps"] == steps
    assert not list(tmp_path.glob("*.part"))


def test_scene_channel_is_foxglove_scene_update(tmp_path):
    _, recorded, _ = _record("Crossroads-2T2P-v1", {"max_cycles": 5}, tmp_path)
    path = recorded[0].replay_path
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        scene = next(c for c in summary.channels.values() if c.topic == "/scene")
        schema = summary.schemas[scene.schema_id]
        assert (schema.name, schema.encoding, scene.message_encoding) == ("foxglove.SceneUpdate", "jsonschema", "json")
        assert json.loads(schema.data)["title"] == "foxglove.SceneUpdate"
        assert reader.get_header().profile == "arena-league"
    required = scene_update_schema()["properties"]["entities"]["items"]["required"]
    updates = [message for _, message in iter_messages(path, ["/scene"])]
    assert len(updates) == 6
    entities = {e["id"]: e for e in updates[-1]["entities"]}
    assert {"roads", "agent/0", "agent/3", "target/2"} <= set(entities)
    for entity in entities.values():
        assert set(required) <= set(entity) and entity["frame_id"] == "arena"
    agent = entities["agent/0"]["spheres"][0]
    assert set(agent) == {"pose", "size", "color"} and 0 <= agent["color"]["a"] <= 1
    assert updates[-1]["entities"][0]["timestamp"] == {"sec": 0, "nsec": 500_000_000}
    # agents move: their scene positions follow the rules' state
    first = next(e for e in updates[0]["entities"] if e["id"] == "agent/0")["spheres"][0]["pose"]["position"]
    assert first != agent["pose"]["position"]


def test_gif_of_the_top_down_view(tmp_path):
    _, recorded, _ = _record("GoBang-2T1P-v1", {}, tmp_path)
    result = recorded[0]
    gif = tmp_path / "match.gif"
    frames = export_gif(result.replay_path, gif, fps=5)
    assert frames == result.steps + 1
    with Image.open(gif) as image:
        assert image.n_frames == frames and image.size[0] >= 240
    every = export_gif(result.replay_path, tmp_path / "sparse.gif", every=4)
    assert every == 1 + result.steps // 4 + (result.steps % 4 != 0)


def test_unreadable_replays_are_refused_with_the_reason(tmp_path):
    _, recorded, _ = _record("GoBang-2T1P-v1", {}, tmp_path)
    path = recorded[0].replay_path
    with pytest.raises(ReplayError, match="no replay"):
        read_replay(tmp_path / "missing.mcap")
    truncated = tmp_path / "truncated.mcap"
    truncated.write_bytes(Path(path).read_bytes()[:300])
    with pytest.raises(ReplayError, match="not a readable MCAP replay|not a finished"):
        read_replay(truncated)
    not_mcap = tmp_path / "notes.mcap"
    not_mcap.write_text("hello")
    with pytest.raises(ReplayError):
        read_replay(not_mcap)


@pytest.mark.parametrize("game_id", list_games())
def test_every_game_records_a_replay_that_reads_back_and_exports_a_gif(game_id, tmp_path):
    _, recorded, plain = _record(game_id, {"max_cycles": 6}, tmp_path)
    assert recorded[0].without_replay() == plain[0]
    result = (recorded[0].halves or recorded)[0]  # a pair's first half is a match of its own, recorded
    summary = read_replay(result.replay_path)
    assert summary.result == result and 1 <= summary.steps <= 6
    assert summary.channels["/scene"] == summary.steps + 1
    gif = tmp_path / f"{game_id}.gif"
    assert export_gif(result.replay_path, gif) == summary.steps + 1
    with Image.open(gif) as image:
        assert image.n_frames == summary.steps + 1
    files = [Path(h.replay_path).name for h in recorded[0].halves or recorded]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*files, gif.name])


# --- a match that fails leaves no file ---------------------------------------------------------------------
FAILING_GAME = "Sumo-2T1P-v1"  # a MuJoCo game: the kind whose failed recordings used to stay behind


class _FailingPolicy(Policy):
    """Plays like ``inner`` until its ``fail_at``-th call, which raises ``error``."""

    def __init__(self, inner: Policy, fail_at: int, error: BaseException) -> None:
        self.spec, self.name, self.inner = inner.spec, "failing", inner
        self.fail_at, self.error, self.calls = fail_at, error, 0

    def act(self, obs, uniforms, mask=None, state=None):
        self.calls += 1
        if self.calls >= self.fail_at:
            raise self.error
        return self.inner.act(obs, uniforms, mask, state)


def _fail_on_call(monkeypatch, owner, name, fail_at, error):
    """Makes ``owner.name`` raise ``error`` from its ``fail_at``-th call on."""
    original, calls = getattr(owner, name), [0]

    def failing(*args, **kwargs):
        calls[0] += 1
        if calls[0] >= fail_at:
            raise error
        return original(*args, **kwargs)

    monkeypatch.setattr(owner, name, failing)


FAILURES = {  # where the match fails -> (how to make it fail, what it raises)
    "opening the replay": (lambda mp: _fail_on_call(mp, replay_writer, "scene_update", 1, RuntimeError("scene")),
                           RuntimeError),
    "writing a step": (lambda mp: _fail_on_call(mp, Writer, "add_message", 40, OSError("disk full")), OSError),
    "a policy mid-match": (None, RuntimeError),
    "an interrupt mid-match": (None, KeyboardInterrupt),
    "the env mid-match": (lambda mp: _fail_on_call(mp, ArenaParallelEnv, "step_arrays", 9, RuntimeError("env")),
                          RuntimeError),
    "finishing the replay": (lambda mp: _fail_on_call(mp, Writer, "finish", 1, OSError("disk full")), OSError),
}


@pytest.mark.parametrize("where", sorted(FAILURES))
def test_a_match_that_fails_leaves_no_part_and_no_replay(where, tmp_path, monkeypatch):
    setup, error = FAILURES[where]
    agents = {name: AgentRef("scripted", name, FAILING_GAME).load() for name in ("random", "heuristic")}
    if setup is None:  # the policy fails at its 5th call
        raised = RuntimeError("policy") if error is RuntimeError else KeyboardInterrupt()
        agents["heuristic"] = _FailingPolicy(agents["heuristic"], 5, raised)
    else:
        setup(monkeypatch)
    # two matches in flight, so an abort has more than one recording to drop
    specs = specs_for_seatings(FAILING_GAME, [("heuristic", "random"), ("random", "heuristic")], league_seed=4)
    with pytest.raises(error):
        play_matches(specs, agents, batch_size=2, env_kwargs={"max_cycles": 12},
                     recording=ReplayRecording(tmp_path))
    assert list(tmp_path.iterdir()) == []  # neither a .part nor a partial .mcap


def test_matches_finished_before_a_failure_keep_their_whole_replays(tmp_path):
    agents = {name: AgentRef("scripted", name, FAILING_GAME).load() for name in ("random", "heuristic")}
    # one match at a time: the first ends at max_cycles (12 steps), the second fails at its 5th step
    agents["heuristic"] = _FailingPolicy(agents["heuristic"], 12 + 5, RuntimeError("policy"))
    specs = specs_for_seatings(FAILING_GAME, [("heuristic", "random"), ("random", "heuristic")], league_seed=4)
    with pytest.raises(RuntimeError):
        play_matches(specs, agents, batch_size=1, env_kwargs={"max_cycles": 12}, recording=ReplayRecording(tmp_path))
    assert [p.name for p in tmp_path.iterdir()] == [replay_file_name(specs[0])]
    assert read_replay(tmp_path / replay_file_name(specs[0])).steps == 12


# --- captions: who plays, which step, how it ended ---------------------------------------------------------
def _gif_frames(path):
    """The frames of a GIF as ``int[H, W, 3]`` arrays, and each frame's duration in ms."""
    frames, durations = [], []
    with Image.open(path) as image:
        for index in range(image.n_frames):
            image.seek(index)
            frames.append(np.asarray(image.convert("RGB")).astype(int))
            durations.append(image.info["duration"])
    return frames, durations


def _near(pixels, colour, tolerance=40):
    """How many pixels lie within ``tolerance`` (summed over channels) of ``colour``."""
    return int((np.abs(pixels - np.asarray(colour)).sum(-1) < tolerance).sum())


@pytest.fixture(scope="module")
def captioned_gifs(tmp_path_factory):
    """GoBang GIFs with three outcomes: team 0 wins, team 1 wins, a draw (cut at 4 steps)."""
    directory = tmp_path_factory.mktemp("captions")
    game = "GoBang-2T1P-v1"
    agents = {name: AgentRef("scripted", name, game) for name in ("random", "heuristic")}
    specs = specs_for_seatings(game, [("heuristic", "random"), ("random", "heuristic")], league_seed=12)
    results = play_matches(specs, agents, recording=ReplayRecording(directory / "full"))
    results += play_matches(specs[:1], agents, env_kwargs={"max_cycles": 4},
                            recording=ReplayRecording(directory / "cut"))
    gifs = {}
    for outcome, result in zip(("team 0 wins", "team 1 wins", "draw"), results):
        summary = read_replay(result.replay_path)
        picture = next(replay_frames(result.replay_path))
        caption = MatchCaption(picture.shape[1], game, summary.seats, summary.teams, summary.steps, summary.scores,
                               summary.outcomes)
        assert caption.outcome_text.startswith(outcome + "  scores")  # the matches ended as this test needs
        gif = directory / f"{outcome}.gif"
        export_gif(result.replay_path, gif, fps=10)
        frames, durations = _gif_frames(gif)
        gifs[outcome] = (result, caption, picture, frames, durations)
    return gifs


def test_gif_frames_name_each_teams_agents_in_its_colour_above_the_picture(captioned_gifs):
    result, caption, picture, frames, _ = captioned_gifs["team 0 wins"]
    height = picture.shape[0]
    top, bottom = caption.top_height, caption.bottom_height
    assert top > 0 and bottom > 0
    for frame in frames:
        assert frame.shape == (top + height + bottom, picture.shape[1], 3)
        assert np.abs(frame[:top] - frames[0][:top]).max() <= 8  # the names stay put (GIF palettes aside)
    # the picture itself is whole between the bands: the caption covers none of it
    assert np.abs(frames[0][top: top + height] - picture).mean() < 2.0
    band = frames[0][:top]
    for team in set(result.teams):
        assert _near(band, TEAM_COLOURS[team]) > 50  # the team's swatch and its agents' names
    assert _near(band, BAND_COLOUR, 6) > band.shape[0] * band.shape[1] // 2  # a band, not the game's picture


def test_gif_frames_show_the_step_below_the_picture(captioned_gifs):
    result, caption, picture, frames, durations = captioned_gifs["team 0 wins"]
    below = picture.shape[0] + caption.top_height
    step_line = [frame[below: below + caption.line_height] for frame in frames]
    assert len(frames) == result.steps + 1
    for earlier, later in itertools.pairwise(step_line):
        assert np.abs(earlier - later).sum() > 0  # every frame's step number differs from the last one's
    assert durations[:-1] == [100] * (len(frames) - 1)


def test_the_last_frame_tells_the_outcome_and_stays_on_screen(captioned_gifs):
    outcome_areas = {}
    for outcome, (_, caption, picture, frames, durations) in captioned_gifs.items():
        below = caption.top_height + picture.shape[0] + caption.line_height
        areas = [frame[below:] for frame in frames]
        for area in areas[:-1]:  # no outcome before the match has ended
            assert _near(area, BAND_COLOUR, 6) == area.shape[0] * area.shape[1]
        assert _near(areas[-1], BAND_COLOUR, 6) < areas[-1].shape[0] * areas[-1].shape[1]
        assert durations[-1] >= 2000  # held long enough to read before the GIF loops
        outcome_areas[outcome] = areas[-1]
    # the winner is named in its team's colour
    team0, team1 = TEAM_COLOURS[0], TEAM_COLOURS[1]
    assert _near(outcome_areas["team 0 wins"], team0) > 2 * _near(outcome_areas["team 0 wins"], team1)
    assert _near(outcome_areas["team 1 wins"], team1) > 2 * _near(outcome_areas["team 1 wins"], team0)
    # a different outcome reads differently
    names = sorted(outcome_areas)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            assert np.abs(outcome_areas[a] - outcome_areas[b]).sum() > 0, (a, b)


def test_captions_can_be_left_out(tmp_path):
    _, recorded, _ = _record("GoBang-2T1P-v1", {"max_cycles": 4}, tmp_path)
    gif = tmp_path / "plain.gif"
    export_gif(recorded[0].replay_path, gif, captions=False)
    picture = next(replay_frames(recorded[0].replay_path))
    with Image.open(gif) as image:
        assert image.size == (picture.shape[1], picture.shape[0])
