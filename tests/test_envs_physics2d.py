"""The physics link: its direct and public paths give bit-identical games, and the numbers of the
bodies' own attributes; arrays too small for a space are refused."""

from __future__ import annotations

import sys

import numpy as np
import pymunk
import pytest

from arena_league.envs import make, physics2d
from arena_league.envs.physics2d import SPARE_CELLS, BodyFields, body_cells, space_link

PATHS = [
    pytest.param(False, id="direct", marks=pytest.mark.skipif(
        not physics2d.DIRECT_AVAILABLE, reason="pymunk's cffi handles are not reachable in this build")),
    pytest.param(True, id="public"),
]


def _rollout(game_id: str, action_type: str, game_kwargs: dict, steps: int = 300) -> tuple[list, float]:
    """Observations, rewards, terminations, state and measures of every step of a few episodes
    (heuristic play with bursts of seeded random actions), and the largest contact force seen."""
    env = make(game_id, action_type=action_type, **game_kwargs)
    rng = np.random.default_rng(3)
    episode = 0
    obs, _ = env.reset(seed=21)
    trace: list = [np.stack([obs[a] for a in env.possible_agents])]
    most_force = 0.0
    for t in range(steps):
        if not env.agents:
            episode += 1
            obs, _ = env.reset(seed=21 + episode)
            trace.append(np.stack([obs[a] for a in env.possible_agents]))
        heuristic = env.rules.heuristic(np.stack([obs[a] for a in env.possible_agents]), action_type)
        actions = {a: heuristic[i] if (t // 15 + i) % 3 else env.rules.random_action(i, rng)
                   for i, a in enumerate(env.possible_agents)}
        obs, rewards, terminations, truncations, _ = env.step(actions)
        m = env.rules.measures
        trace += [np.stack([obs[a] for a in env.possible_agents]),
                  np.array([rewards[a] for a in env.possible_agents]),
                  np.array([[terminations[a], truncations[a]] for a in env.possible_agents]),
                  env.state()]
        trace += [np.array(getattr(m, name), dtype=np.float64) for name in
                  ("force", "speed", "target_distance", "velocity_to_target", "energy", "outcome")]
        most_force = max(most_force, float(np.max(m.force)))
    return trace, most_force


@pytest.mark.parametrize("game_id, action_type, game_kwargs", [
    ("Crossroads-2T2P-v1", "discrete", {}),
    ("Crossroads-2T2P-v1", "continuous", {}),
    ("Crossroads-4T1P-v1", "discrete", {"agent_shape": "box"}),
    ("Soccer-2T2P-v1", "discrete", {}),
    ("Soccer-2T1P-v1", "continuous", {}),
    ("AirHockey-2T2P-v1", "discrete", {}),
    ("AirHockey-2T1P-v1", "continuous", {}),
    ("FightForFood-2T2P-v1", "discrete", {}),
    ("FightForFood-4T1P-v1", "continuous", {"food": 8}),
    ("Tennis-2T2P-v1", "discrete", {}),
    ("Tennis-2T1P-v1", "continuous", {"points": 3}),
    ("BlowBlow-2T2P-v1", "discrete", {}),
    ("BlowBlow-2T1P-v1", "continuous", {"platform_radius": 2.5}),
])
def test_direct_and_public_paths_give_bit_identical_trajectories(game_id, action_type, game_kwargs,
                                                                   monkeypatch):
    if not physics2d.DIRECT_AVAILABLE:
        pytest.skip("pymunk's cffi handles are not reachable in this build: only the public path runs")
    assert make(game_id, action_type=action_type, **game_kwargs).rules.world.link.direct
    direct, direct_force = _rollout(game_id, action_type, game_kwargs)
    monkeypatch.setattr(physics2d.link, "FORCE_PUBLIC_API", True)
    assert not make(game_id, action_type=action_type, **game_kwargs).rules.world.link.direct
    public, _ = _rollout(game_id, action_type, game_kwargs)  # the force is in the trace
    assert direct_force > 0.0, "the rollout should include contacts, so that arbiters are compared too"
    assert len(direct) == len(public)
    for a, b in zip(direct, public):
        assert a.dtype == b.dtype and a.shape == b.shape
        assert a.tobytes() == b.tobytes(), "both paths run the same Chipmunk code: bit-identical"


def _space() -> tuple[pymunk.Space, list[pymunk.Body]]:
    """Three overlapping discs (pushed apart by the step) resting on a static floor."""
    space = pymunk.Space()
    bodies = []
    for i in range(3):
        body = pymunk.Body(1.0, 2.0)
        body.position = (0.8 * i, 0.1 * i)
        body.angle = 0.3 * i
        body.velocity = (1.0 - i, 0.5)
        body.angular_velocity = -0.2 * i
        space.add(body, pymunk.Circle(body, 0.5))
        bodies.append(body)
    space.add(pymunk.Segment(space.static_body, (-5.0, -0.45), (5.0, -0.45), 0.05))
    return space, bodies


def _canonical(a: int, b: int, x: float, y: float) -> tuple[tuple[int, int], tuple[float, float]]:
    """An arbiter's body ids in increasing order, with its impulse (on a, from b) to match."""
    return ((a, b), (x, y)) if a < b else ((b, a), (-x, -y))


@pytest.mark.parametrize("public", PATHS)
def test_link_moves_the_same_numbers_as_the_body_attributes(public, monkeypatch):
    monkeypatch.setattr(physics2d.link, "FORCE_PUBLIC_API", public)
    space, bodies = _space()
    read = BodyFields.POSITION | BodyFields.ANGLE | BodyFields.VELOCITY | BodyFields.ANGULAR_VELOCITY
    write = BodyFields.FORCE | BodyFields.TORQUE
    n_bodies = len(bodies) + 1  # and the static body
    read_floats, write_floats = np.zeros(6 * n_bodies + SPARE_CELLS), np.zeros(3 * n_bodies)
    link = space_link(read, read_floats, write, write_floats, contacts=True)
    assert link.direct is (not public)
    link.bind(space)
    assert link.body_ids == [b.id for b in bodies] + [space.static_body.id]

    link.read_bodies()
    for body, cells in zip(bodies, read_floats.reshape(-1)[:6 * len(bodies)].reshape(-1, 6)):
        assert cells.tolist() == [*body.position, body.angle, *body.velocity, body.angular_velocity]

    write_floats[:9] = [1.0, 2.0, 0.1, 3.0, 4.0, 0.2, 5.0, 6.0, 0.3]
    link.write_bodies()
    assert [(*b.force, b.torque) for b in bodies] == [(1.0, 2.0, 0.1), (3.0, 4.0, 0.2), (5.0, 6.0, 0.3)]

    link.step(0.05)
    n_arbiters = link.read_contacts()
    ids = link.contact_ids[:2 * n_arbiters].reshape(-1, 2).tolist()
    impulses = link.contact_impulses[:2 * n_arbiters].reshape(-1, 2).tolist()
    linked = dict(_canonical(a, b, *impulse) for (a, b), impulse in zip(ids, impulses))
    seen = {}

    def record(arbiter: pymunk.Arbiter) -> None:  # seen from either body: a, b may come swapped
        key, impulse = _canonical(*(shape.body.id for shape in arbiter.shapes), *arbiter.total_impulse)
        seen[key] = impulse

    for body in bodies:
        body.each_arbiter(record)
    assert len(seen) == n_arbiters >= 3, "the discs overlap each other and the floor"
    assert linked == seen
    link.read_bodies()
    assert read_floats[:2].tolist() == list(bodies[0].position)


@pytest.mark.parametrize("public", PATHS)
def test_bind_refuses_arrays_too_small_for_the_space(public, monkeypatch):
    monkeypatch.setattr(physics2d.link, "FORCE_PUBLIC_API", public)
    space, bodies = _space()
    read = BodyFields.POSITION | BodyFields.VELOCITY
    cells = body_cells(read) * (len(bodies) + 1)
    with pytest.raises(ValueError, match="read_floats"):
        space_link(read, np.zeros(cells + SPARE_CELLS - 1)).bind(space)
    with pytest.raises(ValueError, match="write_floats"):
        space_link(read, np.zeros(cells + SPARE_CELLS), BodyFields.FORCE, np.zeros(cells // 2 - 1)).bind(space)
    space_link(read, np.zeros(cells + SPARE_CELLS), BodyFields.FORCE, np.zeros(cells // 2)).bind(space)


def test_fields_and_arrays_are_checked_when_the_link_is_made():
    assert body_cells(BodyFields.POSITION | BodyFields.ANGLE | BodyFields.VELOCITY) == 5
    with pytest.raises(ValueError, match="float body fields"):
        space_link(BodyFields.BODY_ID | BodyFields.POSITION, np.zeros(16))
    with pytest.raises(ValueError, match="float64"):
        space_link(BodyFields.POSITION, np.zeros(16, dtype=np.float32))
    with pytest.raises(ValueError, match="float64"):
        space_link(BodyFields.POSITION, np.zeros(32)[::2])
    with pytest.raises(ValueError, match="together"):
        space_link(BodyFields.POSITION, np.zeros(16), BodyFields.FORCE)


def test_without_pymunks_cffi_module_links_take_the_public_path(monkeypatch):
    monkeypatch.setitem(sys.modules, "pymunk._chipmunk_cffi", None)  # makes importing it fail
    assert physics2d.link._probe_direct() is None
