"""The 2D engine's declarations: a field built in declared order, the work vector addressed by name,
observation layouts with their bounds, and the seats' compass thrust."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.envs.physics2d import (
    ONE,
    Bodies,
    CellLayout,
    Field,
    Material,
    Run,
    SeatThrust,
    Walls,
    World,
)

WALLS = Walls((((-3.0, -2.0), (3.0, -2.0)), ((3.0, -2.0), (3.0, 2.0))), 0.1, Material(0.5, 0.2))


def field(**extra) -> Field:
    return Field(dt=0.1, damping=0.5, collision_slop=0.01, parts=(
        WALLS, Bodies("agent", 2, 0.25, 1.0, Material(0.5, 0.3)), Bodies("ball", 1, 0.2, 0.4, rotates=True)), **extra)


def test_work_vector_is_addressed_by_body_and_slot_names():
    world = World(field(), slots=(("v_before", 4), ("thrust", 4), (ONE, 1)))
    assert world.n_bodies == 4  # two agents, the ball, the walls' static body
    assert (world.index("agent", 1), world.index("ball")) == (1, 2)
    assert (world.pos(2, 0), world.pos(2, 1), world.vel(2, 0), world.vel(2, 1)) == (8, 9, 10, 11)
    # the bodies' block, room pymunk's batch array needs, then the slots in declared order
    assert world.at("v_before") == 4 * 4 + 8
    assert world.at("thrust", 3) == world.at("v_before") + 4 + 3
    assert world.work[world.at(ONE)] == 1.0
    world.view("thrust")[:] = [1.0, 2.0, 3.0, 4.0]
    assert world.complex_view("thrust").tolist() == [1 + 2j, 3 + 4j]


def test_a_match_is_built_in_declared_order_and_read_into_the_work_vector():
    world = World(field(), slots=((ONE, 1),))
    world.build({"agent": [[-1.0, 0.5], [1.0, -0.5]], "ball": [[0.0, 0.25]]}, velocities={"ball": [[0.5, 0.0]]})
    assert world.table[:3, 0:2].tolist() == [[-1.0, 0.5], [1.0, -0.5], [0.0, 0.25]]
    assert world.table[2, 2:4].tolist() == [0.5, 0.0]
    assert [len(world.bodies[k]) for k in ("agent", "ball")] == [2, 1]
    assert world.bodies["agent"][0].moment == float("inf") and world.bodies["ball"][0].moment < float("inf")
    world.place_all({"agent": [[-2.0, 0.0], [2.0, 0.0]], "ball": [[0.0, 1.0]]}, {"agent": [[0.1, 0.0], [0.0, 0.0]]})
    assert world.table[:3, 0:4].tolist() == [[-2.0, 0.0, 0.1, 0.0], [2.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]


def test_the_force_matrix_pushes_bodies_before_every_physics_step():
    world = World(field(substeps=2), slots=(("thrust", 4), (ONE, 1)))
    world.build({"agent": [[-1.0, 0.0], [1.0, 1.0]], "ball": [[0.0, -1.0]]})
    world.force_matrix = world.matrix(2 * world.n_bodies)
    world.force_matrix[0, world.at("thrust", 0)] = 5.0  # agent 0 pushed along +x only
    world.view("thrust")[0] = 1.0
    world.step()
    assert world.table[0, 2] > 0.0 and world.table[1, 2] == 0.0 and world.table[2, 2] == 0.0


def test_a_slot_for_the_applied_forces_must_hold_every_body():
    with pytest.raises(ValueError, match="give it 8 cells"):
        World(field(), slots=(("force", 6),), applied="force")
    world = World(field(), slots=(("before", 2), ("force", 8)), applied="force")
    assert len(world.force_source) == world.at("force")


def test_layouts_name_their_runs_and_bound_every_cell():
    layout = CellLayout([Run("active", 1, (0, 1), "own flag"), Run("position", 2, ((-1, 1), (-0.5, 0.5))),
                         Run("velocity", 2, (-2, 2))])
    assert (layout.size, layout.at("position", 1), layout.at("velocity")) == (5, 2, 3)
    low, high = layout.bounds()
    assert low.tolist() == [0, -1, -0.5, -2, -2] and high.tolist() == [1, 1, 0.5, 2, 2]
    assert [row["cells"] for row in layout.table()] == ["0", "1-2", "3-4"]
    with pytest.raises(ValueError, match="two runs named 'active'"):
        CellLayout([Run("active", 1, (0, 1)), Run("active", 1, (0, 1))])
    with pytest.raises(ValueError, match="3 bounds for 2 cells"):
        CellLayout([Run("position", 2, ((0, 1), (0, 1), (0, 1)))]).bounds()


def test_seat_thrust_scales_a_long_vector_back_and_names_compass_moves():
    thrust = np.zeros(3, dtype=np.complex128)
    energy = np.zeros(3)
    continuous = SeatThrust(thrust, "continuous")
    continuous.set(np.array([[3.0, 4.0], [0.3, 0.4], [0.0, 0.0]]), energy)
    assert np.allclose(thrust, [0.6 + 0.8j, 0.3 + 0.4j, 0.0]) and np.allclose(energy, [1.0, 0.25, 0.0])
    discrete = SeatThrust(thrust, "discrete")
    discrete.set(np.array([0, 1, 3]), energy)  # noop, E, N
    assert np.allclose(thrust, [0.0, 1.0, 1.0j]) and energy.tolist() == [0.0, 1.0, 1.0]


def _trace(env, seed: int) -> list[bytes]:
    """Every step's observations and rewards of the match of ``seed``, with seeded random actions."""
    rng = np.random.default_rng(seed)
    out = [env.reset_arrays(seed=seed).tobytes()]
    while True:
        rules = env.rules
        if rules.action_type == "discrete":
            actions = rng.integers(0, rules.n_actions, size=rules.n_agents)
        else:
            actions = rng.uniform(-1.0, 1.0, size=(rules.n_agents, rules.act_dim))
        obs, rewards, terminated, truncated = env.step_arrays(actions)
        out += [obs.tobytes(), rewards.tobytes()]
        if terminated or truncated:
            return out


@pytest.mark.parametrize("game_id, action_type, matches", [("BattleCity-2T2P-v1", "continuous", 24),
                                                           ("Fighter-2T2P-v1", "discrete", 6),
                                                           ("Soccer-2T2P-v1", "continuous", 3)])
def test_a_reused_space_plays_every_seed_as_a_fresh_space_does(game_id, action_type, matches, monkeypatch):
    from arena_league.envs import make
    from arena_league.envs.physics2d import link

    if not link.can_restart():
        pytest.skip("pymunk's internals differ from what the reuse expects: every match gets a new space")
    reused = make(game_id, action_type=action_type)
    traces = [_trace(reused, seed) for seed in range(matches)]
    space = reused.rules.world.space
    assert _trace(reused, matches) and reused.rules.world.space is space, "the direct path reuses the space"
    # the public path builds a new space every match: the reference (a tank kept with Chipmunk's
    # bias velocity from its last contact changes BattleCity's third match)
    monkeypatch.setattr(link, "FORCE_PUBLIC_API", True)
    fresh = make(game_id, action_type=action_type)
    for seed, trace in enumerate(traces):
        assert _trace(fresh, seed) == trace, f"seed {seed}"
    assert fresh.rules.world.space is not space


def test_a_reused_space_holds_one_match_and_keeps_pymunks_records():
    from arena_league.envs import make

    env = make("BattleCity-2T2P-v1", action_type="continuous")
    counts = set()
    for seed in range(12):
        _trace(env, seed)
        world, tiles = env.rules.world, env.rules.tiles
        space = world.space
        # the walls, the tanks and one box per run of tiles: nothing from earlier matches stays
        assert len(space.shapes) == 4 + 4 + len(tiles._shapes) and len(space.bodies) == 4
        assert all(shape.space is space for shape in space.shapes)
        counts.add(len(space.shapes))
    assert len(counts) > 1, "different mazes, different numbers of boxes"


def test_restart_and_renew_refuse_what_they_cannot_make_fresh():
    import pymunk

    from arena_league.envs.physics2d import link

    if not link.can_restart():
        pytest.skip("pymunk's internals differ from what restart expects")
    space = pymunk.Space()
    body = pymunk.Body(1.0, 1.0)
    link.add_to(space, body, pymunk.Circle(body, 0.5))
    with pytest.raises(ValueError, match="restart an empty space"):
        link.restart(space)
    with pytest.raises(ValueError, match="renew a body out of its space"):
        link.renew(body)
    link.remove_from(space, *space.shapes, body)
    assert not space.shapes and not space.bodies and body.space is None
    link.restart(space)
    body.velocity = (3.0, 4.0)
    link.renew(body)
    assert tuple(body.velocity) == (0.0, 0.0) and tuple(body.position) == (0.0, 0.0)


def test_seat_thrust_listed_and_its_moves_match_the_numpy_path_bit_for_bit():
    rng = np.random.default_rng(5)
    for action_type in ("continuous", "discrete"):
        thrust, listed_thrust = np.zeros(4, dtype=np.complex128), np.zeros(4, dtype=np.complex128)
        energy, listed_energy = np.zeros(4), np.zeros(4)
        numpy_path, list_path = SeatThrust(thrust, action_type), SeatThrust(listed_thrust, action_type)
        for _ in range(200):
            if action_type == "continuous":
                actions = rng.uniform(-1.0, 1.0, size=(4, 2)).astype(np.float32)
                actions[rng.random(4) < 0.1] = -0.0
                numpy_path.set(actions, energy)
                list_path.set(actions, listed_energy)
                pairs, length = list_path.listed()
            else:
                actions = rng.integers(0, 9, size=4)
                numpy_path.set(actions, energy)
                list_path.set_moves(actions.tolist(), listed_energy)
                pairs = [x for action in actions.tolist() for x in list_path.move_pairs[action]]
                length = [list_path.move_lengths[action] for action in actions.tolist()]
            assert listed_thrust.tobytes() == thrust.tobytes() and listed_energy.tobytes() == energy.tobytes()
            assert np.array(pairs).tobytes() == thrust.view(np.float64).tobytes()
            assert np.array(length).tobytes() == np.abs(thrust).tobytes()
