"""Robot games on MuJoCo, what they share (PettingZoo's API and 200-step determinism are in the
shared tests/test_envs_api.py): the batched path equal to the env path, fall detection and physics, the ant and its scenes, the observation's robot
block and seat frame, measures, annealing of the dense reward, and headless pictures."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from arena_league.envs import make
from arena_league.envs.robots import (
    ANT,
    FALLEN_UP_Z,
    JOINTS,
    RobotMatches,
    SceneLayout,
    StartPose,
    ant_spec,
    compile_scene,
    stand,
    trot,
)
from arena_league.envs.robots import observation as cells
from arena_league.envs.social.rewards import lookup_reward

ROBOT_IDS = ["Sumo-2T1P-v1", "RunToGoal-2T1P-v1", "YouShallNotPass-2T1P-v1", "PushBox-2T2P-v1"]


def no_boxes() -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((0, 2)), np.zeros(0)


# --- the shared env contract ------------------------------------------------------------------------
#: observation sizes as the games' manuals give them
OBS_DIM = {"Sumo-2T1P-v1": 51, "RunToGoal-2T1P-v1": 51, "YouShallNotPass-2T1P-v1": 52, "PushBox-2T2P-v1": 73}


@pytest.mark.parametrize("game_id", ROBOT_IDS)
def test_spaces_are_those_of_the_manual(game_id):
    # PettingZoo's API test and the 200-step determinism test run for these ids in tests/test_envs_api.py
    env = make(game_id)
    assert env.rules.action_type == "continuous" and env.rules.act_dim == 8
    assert env.rules.obs_dim == OBS_DIM[game_id]


def test_a_seed_gives_the_same_match_whatever_the_instance_played_before():
    def trace(env, seed):
        rng = np.random.default_rng(seed)
        env.reset(seed=seed)
        out = []
        for _ in range(60):
            obs, *_ = env.step({a: env.rules.random_action(i, rng) for i, a in enumerate(env.agents)})
            out.append(np.stack([obs[a] for a in env.possible_agents]))
            if not env.agents:
                break
        return out

    fresh = trace(make("PushBox-2T2P-v1"), 3)
    used = make("PushBox-2T2P-v1")
    trace(used, 11)
    again = trace(used, 3)
    assert len(fresh) == len(again) and all(np.array_equal(a, b) for a, b in zip(fresh, again))


@pytest.mark.parametrize("game_id", ROBOT_IDS)
def test_state_and_state_in_observation(game_id):
    env = make(game_id, state_in_obs=True)
    obs, _ = env.reset(seed=1)
    state = env.state()
    assert state.shape == env.state_space.shape and state.dtype == np.float32
    base = env.rules.obs_dim
    for agent in env.possible_agents:
        assert np.array_equal(obs[agent][base:], state)


# --- the batched path -------------------------------------------------------------------------------
@pytest.mark.parametrize("game_id, threads", [("Sumo-2T1P-v1", 2), ("PushBox-2T2P-v1", 2), ("RunToGoal-2T1P-v1", 1)])
def test_batched_matches_are_bit_identical_to_one_match_at_a_time(game_id, threads):
    max_cycles = 40
    seeds = [5, 6, 7, 8, 9]
    probe = make(game_id)
    rules_cls = type(probe.rules)
    n_teams, players = rules_cls.layouts[0]

    def policy(obs, slot_rng, n):
        actions = rules_cls.heuristic(obs, "continuous")
        actions[n // 2:] = slot_rng.uniform(-1, 1, (n - n // 2, 8))  # one side skilled, one random
        return actions.astype(np.float32)

    # one match at a time, on the rules (the env's own stepping)
    single = []
    for seed in seeds:
        rules = rules_cls(n_teams, players)
        rules.reset(seed)
        rng = np.random.default_rng(100 + seed)
        observations = [rules.observe()]
        for _ in range(max_cycles):
            rules.step(policy(rules.observe(), rng, rules.n_agents))
            observations.append(rules.observe())
            if rules.game_over:
                break
        if not rules.game_over:
            rules.finish()
        single.append((observations, rules.team_result(), len(observations) - 1))
    # all at once on the engine, more slots than matches (an idle slot stays idle)
    rules = rules_cls(n_teams, players)
    engine = RobotMatches(rules, len(seeds) + 1, max_cycles, threads=threads)
    try:
        for slot, seed in enumerate(seeds):
            engine.start(slot, seed)
        rngs = [np.random.default_rng(100 + seed) for seed in seeds]
        batched = [[engine.observe()[slot]] for slot in range(len(seeds))]
        finished: dict[int, tuple[np.ndarray, int]] = {}
        while len(finished) < len(seeds):
            obs = engine.observe()
            actions = np.zeros((engine.n_slots, rules.n_agents, 8), dtype=np.float32)
            for slot in range(len(seeds)):
                if slot not in finished:
                    actions[slot] = policy(obs[slot], rngs[slot], rules.n_agents)
            ended = engine.step(actions)
            obs = engine.observe()
            for slot in range(len(seeds)):
                if slot not in finished:
                    batched[slot].append(obs[slot])
                if ended[slot]:
                    finished[slot] = (engine.team_result(slot), engine.steps(slot))
        assert engine.steps(len(seeds)) == 0  # the idle slot never moved
    finally:
        engine.close()
    for slot, (observations, result, steps) in enumerate(single):
        assert finished[slot][1] == steps and np.array_equal(finished[slot][0], result)
        assert len(batched[slot]) == len(observations)
        assert all(np.array_equal(a, b) for a, b in zip(batched[slot], observations))


# --- falls and physics --------------------------------------------------------------------------------
def test_random_torques_topple_an_ant_in_most_episodes_while_standing_stays_up():
    # RunToGoal ends only at the goal lines, far away here: both ants play the whole episode
    env = make("RunToGoal-2T1P-v1", field_length=10.0)
    rules = env.rules
    toppled = stood = 0
    for episode in range(10):
        rules.reset(episode)
        rng = np.random.default_rng(episode)
        fell = [False, False]
        for _ in range(200):
            obs = rules.observe()
            actions = np.stack([rng.uniform(-1, 1, 8), stand(obs[1:2])[0]]).astype(np.float32)
            rules.step(actions)
            fell = [fell[i] or bool(rules.measures.fallen[i]) for i in range(2)]
            # the measure is the observation's up-axis cell, read at the same instant
            assert np.array_equal(rules.measures.fallen, rules.observe()[:, cells.UP_Z] < FALLEN_UP_Z)
        toppled += fell[0]
        stood += not fell[1]
        assert 0.3 < rules.observe()[1, cells.HEIGHT] < 0.7, "the standing ant holds its torso up"
    assert toppled >= 8 and stood == 10


def test_stepping_is_mj_step_with_frame_skip_sub_steps_to_the_bit():
    # the sub-steps before the last run on a sensor-free copy of the model: same physics
    import mujoco

    rules = make("PushBox-2T2P-v1").rules
    rules.reset(0)
    plain = mujoco.MjData(rules.model)
    rules.place(plain, rules.start_pose(np.random.default_rng(0)), np.random.default_rng(0))
    mine = mujoco.MjData(rules.model)
    rules.place(mine, rules.start_pose(np.random.default_rng(0)), np.random.default_rng(0))
    rng = np.random.default_rng(1)
    for _ in range(40):
        plain.ctrl[:] = mine.ctrl[:] = rng.uniform(-1, 1, rules.model.nu)
        mujoco.mj_step(rules.model, plain, nstep=rules.frame_skip)
        rules.simulate(mine)
    assert np.array_equal(plain.qpos, mine.qpos) and np.array_equal(plain.qvel, mine.qvel)
    assert np.array_equal(plain.sensordata, mine.sensordata) and plain.time == mine.time


def test_ants_push_each_other_and_feel_it_but_not_their_own_legs():
    env = make("Sumo-2T1P-v1")
    rules = env.rules
    rules.reset(0)
    m = rules.measures
    assert m.force.tolist() == [0.0, 0.0]
    for _ in range(20):  # the ants drop 2 cm onto their feet and settle
        rules.step(stand(rules.observe()))
    floor = rules.observe()[:, cells.FLOOR_FORCE] * cells.FORCE_UNIT
    np.testing.assert_allclose(floor[:, 2], 1.0, atol=0.05)  # the floor carries the whole weight at rest
    assert m.force.tolist() == [0.0, 0.0]
    # both trot head-on (each toward +x of its own frame, i.e. toward the other)
    forward = np.array([[1.0, 0.0], [1.0, 0.0]])
    pushed = False
    for _ in range(80):
        rules.step(trot(rules.observe(), forward))
        pushed |= bool((m.force > 0.2).all())
        if rules.game_over:
            break
    assert pushed, "two ants running into each other feel a contact force"
    model = rules.model
    bits = model.geom_contype, model.geom_conaffinity
    ant0 = [g for g in range(model.ngeom) if model.geom(g).name.startswith("r0/")]
    ant1 = [g for g in range(model.ngeom) if model.geom(g).name.startswith("r1/")]

    def collide(a, b):
        return bool((bits[0][a] & bits[1][b]) | (bits[0][b] & bits[1][a]))

    floor_id = model.geom("floor").id
    assert not any(collide(a, b) for a in ant0 for b in ant0)
    assert all(collide(a, b) for a in ant0 for b in ant1)
    assert all(collide(a, floor_id) for a in ant0 + ant1)


def test_the_ant_has_gym_ant_proportions_and_eight_torque_motors():
    spec = ant_spec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1])
    model = spec.compile()
    assert model.nu == 8 and model.njnt == 9  # free joint + 8 hinges
    assert [model.actuator(k).name for k in range(8)] == list(JOINTS)
    np.testing.assert_allclose(model.actuator_gear[:, 0], 150.0)
    np.testing.assert_allclose(model.actuator_ctrlrange, np.tile([-1.0, 1.0], (8, 1)))
    hips = [model.joint(j).id for j in JOINTS[0::2]]
    ankles = [model.joint(j).id for j in JOINTS[1::2]]
    np.testing.assert_allclose(model.jnt_range[hips], np.tile([-np.pi / 6, np.pi / 6], (4, 1)))
    np.testing.assert_allclose(model.jnt_range[ankles], np.tile([np.pi / 6, 7 * np.pi / 18], (4, 1)))
    assert 0.8 < model.body_subtreemass[model.body("torso").id] < 1.0  # Gym's ant: about 0.88 kg
    assert model.geom("torso").size[0] == ANT.torso_radius


def test_a_scene_is_compiled_once_per_layout():
    a, b = make("Sumo-2T1P-v1"), make("Sumo-2T1P-v1")
    assert a.rules.model is b.rules.model and a.rules.data is not b.rules.data
    wide = make("Sumo-2T1P-v1", ring_radius=3.0)
    assert wide.rules.model is not a.rules.model
    layout = SceneLayout(robots=("ant", "ant", "ant"), teams=(0, 1, 2), box_teams=(1,))
    scene = compile_scene(layout)
    assert scene is compile_scene(SceneLayout(robots=("ant",) * 3, teams=(0, 1, 2), box_teams=(1,)))
    names = [scene.model.body(k).name for k in range(scene.model.nbody)]
    assert {"r0/torso", "r1/torso", "r2/torso", "box0/body"} <= set(names)
    with pytest.raises(ValueError, match="unknown robot"):
        SceneLayout(robots=("humanoid",), teams=(0,))


# --- observations and measures --------------------------------------------------------------------------
def test_robot_block_cell_by_cell_and_the_turned_seat_frame():
    env = make("Sumo-2T1P-v1")
    rules = env.rules
    rules.reset(0)
    rules.arrange(StartPose(np.array([[-0.8, 0.3], [1.1, -0.4]]), np.array([0.5, 2.0]), *no_boxes()))
    obs = rules.observe()
    data, scene = rules.data, rules.scene
    for seat, turn in ((0, 1.0), (1, -1.0)):  # team 1's frame is the world turned by 180 degrees
        torso = scene.torso_body[seat]
        frame = np.array([turn, turn, 1.0])
        o = obs[seat]
        assert o[cells.ACTIVE] == 1.0
        assert o[cells.HEIGHT] == pytest.approx(data.xpos[torso][2], abs=1e-6)
        np.testing.assert_allclose(o[cells.FORWARD], frame * data.xmat[torso].reshape(3, 3)[:, 0], atol=1e-6)
        np.testing.assert_allclose(o[cells.UP], frame * data.xmat[torso].reshape(3, 3)[:, 2], atol=1e-6)
        np.testing.assert_allclose(o[cells.JOINT_ANGLES], data.qpos[scene.joint_qpos[seat]], atol=1e-6)
        np.testing.assert_allclose(o[cells.POSITION], turn * data.xpos[torso][:2] / cells.POSITION_UNIT, atol=1e-6)
        other = data.xpos[scene.torso_body[1 - seat]][:2] - data.xpos[torso][:2]
        np.testing.assert_allclose(o[cells.TARGET], turn * other / cells.POSITION_UNIT, atol=1e-6)
        assert o[cells.TIME] == 0.0
        assert o[cells.CLOCK].tolist() == [1.0, 0.0]  # the gait clock starts at phase 0
    assert rules.measures.target_distance == pytest.approx([np.hypot(1.9, 0.7)] * 2, abs=1e-6)
    rules.step(np.zeros((2, 8), np.float32))
    # the sensors' instant: the start of the step's last physics sub-step (4 of 5 sub-steps in)
    np.testing.assert_allclose(rules.observe()[:, cells.TIME], 0.04 / cells.TIME_UNIT, rtol=1e-6)
    # the gait clock turns once per CLOCK_PERIOD (0.5 s): at 0.04 s it reads the phase 0.16 pi
    phase = 2 * np.pi * 0.04 / cells.CLOCK_PERIOD
    np.testing.assert_allclose(rules.observe()[:, cells.CLOCK], [[np.cos(phase), np.sin(phase)]] * 2, atol=1e-6)


def test_mirrored_match_gives_each_seat_the_same_observation():
    env = make("Sumo-2T1P-v1")
    rules = env.rules
    rules.reset(0)
    # ant 1 stands where ant 0 stands, turned by 180 degrees about the centre
    rules.arrange(StartPose(np.array([[-0.9, 0.25], [0.9, -0.25]]), np.array([0.2, 0.2 + np.pi]), *no_boxes()))
    obs = rules.observe()
    np.testing.assert_allclose(obs[0], obs[1], atol=1e-6)
    np.testing.assert_array_equal(rules.heuristic(obs[0:1], "continuous"), rules.heuristic(obs[1:2], "continuous"))
    for _ in range(4):  # the same torques keep the match symmetric (up to rounding)
        rules.step(np.repeat(stand(obs[0:1]), 2, axis=0))
        obs = rules.observe()
    np.testing.assert_allclose(obs[0], obs[1], atol=1e-5)


def test_kinematic_measures_follow_their_definitions():
    env = make("RunToGoal-2T1P-v1")
    rules = env.rules
    rules.reset(2)
    rng = np.random.default_rng(0)
    for _ in range(30):
        actions = rng.uniform(-1, 1, (2, 8)).astype(np.float32)
        rules.step(actions)
        if rules.game_over:
            break
        m, obs = rules.measures, rules.observe().astype(np.float64)
        np.testing.assert_allclose(m.energy, (actions.astype(np.float64) ** 2).mean(axis=1))
        velocity = obs[:, cells.VELOCITY][:, :2] * cells.VELOCITY_UNIT  # seat frame
        way = obs[:, cells.TARGET] * cells.POSITION_UNIT  # (goal - x, 0) in the seat frame
        np.testing.assert_allclose(m.target_distance, np.linalg.norm(way, axis=1), atol=1e-5)
        np.testing.assert_allclose(m.velocity_to_target, velocity[:, 0] * np.sign(way[:, 0]), atol=1e-5)
        np.testing.assert_allclose(m.speed, np.linalg.norm(velocity, axis=1), atol=1e-5)
        forward = obs[:, cells.FORWARD][:, :2]
        np.testing.assert_allclose(m.facing_target, forward[:, 0] * np.sign(way[:, 0]), atol=1e-5)


def test_inactive_seats_torques_are_ignored():
    env = make("PushBox-2T2P-v1")
    rules = env.rules
    rules.reset(0)
    rules.match.active[0, 2:] = False  # as if team 1's box had arrived
    rules.match.any_inactive = True
    rules.step(np.ones((4, 8), np.float32))
    assert rules.measures.energy.tolist() == [1.0, 1.0, 0.0, 0.0]
    assert rules.observe()[:, cells.ACTIVE].tolist() == [1.0, 1.0, 0.0, 0.0]
    np.testing.assert_array_equal(rules.data.ctrl.reshape(4, 8)[2:], 0.0)


# --- dense rewards and annealing -------------------------------------------------------------------------
def _rewards(game_id: str, anneal: float | None, steps: int = 40) -> list[np.ndarray]:
    env = make(game_id) if anneal is None else make(game_id, anneal=anneal)
    env.reset(seed=4)
    rng = np.random.default_rng(4)
    out = []
    for _ in range(steps):
        _, rewards, *_ = env.step({a: env.rules.random_action(i, rng) for i, a in enumerate(env.agents)})
        out.append(np.array(list(rewards.values())))
        if not env.agents:
            break
    return out


def test_annealing_scales_the_dense_motor_reward_and_leaves_the_outcome():
    full = _rewards("Sumo-2T1P-v1", None)
    half = _rewards("Sumo-2T1P-v1", 0.5)
    none = _rewards("Sumo-2T1P-v1", 0.0)
    assert len(full) == len(half) == len(none) < 40, "random ants end a Sumo match early (a fall or a step out)"
    for r1, r_half in zip(full[:-1], half[:-1]):
        np.testing.assert_allclose(r_half, 0.5 * r1, atol=1e-12)
    assert all(np.all(r == 0.0) for r in none[:-1])
    # the last step pays the win/loss (scale 100) besides the annealed dense reward
    np.testing.assert_allclose(none[-1], full[-1] - _dense_part(full), atol=1e-9)
    assert sorted(none[-1].tolist()) == [-100.0, 100.0] or none[-1].tolist() == [0.0, 0.0]


def _dense_part(full: list[np.ndarray]) -> np.ndarray:
    # the dense part of the last step: replay it with anneal 1 and the outcome reward removed
    env = make("Sumo-2T1P-v1", tree={"scheme": "NL", "reward": "none", "children": [
        {"agent": "player_0", "scheme": "IS", "reward": "robot_motion"},
        {"agent": "player_1", "scheme": "IS", "reward": "robot_motion"}]})
    env.reset(seed=4)
    rng = np.random.default_rng(4)
    for _ in range(len(full)):
        _, rewards, *_ = env.step({a: env.rules.random_action(i, rng) for i, a in enumerate(env.agents)})
    return np.array(list(rewards.values()))


def test_robot_motion_pays_speed_to_target_minus_fall_control_and_contact_costs():
    tree = {"scheme": "NL", "children": [
        {"agent": "player_0", "scheme": "IS", "reward": "robot_motion"},
        {"agent": "player_1", "scheme": "IS", "reward": "robot_motion",
         "params": {"velocity": 2.0, "fall": 3.0, "control": 0.25, "contact": 0.5}}]}
    env = make("Sumo-2T1P-v1", tree=tree, anneal=0.5)
    env.reset(seed=2)
    rng = np.random.default_rng(2)
    weights = np.array([[1.0, 1.0, 0.5, 0.01], [2.0, 3.0, 0.25, 0.5]])
    for _ in range(30):
        _, rewards, *_ = env.step({a: env.rules.random_action(i, rng) for i, a in enumerate(env.agents)})
        m = env.rules.measures
        terms = np.stack([m.velocity_to_target, -m.fallen.astype(float), -m.energy, -m.force], axis=1)
        np.testing.assert_allclose([rewards["player_0"], rewards["player_1"]],
                                   0.5 * (weights * terms).sum(axis=1), rtol=1e-12, atol=1e-12)
        if not env.agents:
            break


def test_set_anneal_is_checked_and_kept_across_resets():
    env = make("PushBox-2T2P-v1", anneal=0.25)
    assert env.rules.anneal == 0.25
    env.rules.set_anneal(0.75)
    env.reset(seed=0)
    assert env.rules.anneal == 0.75 and env.rules.measures.anneal == 0.75
    for bad in (1.5, -0.1, True, "0.5", None):
        with pytest.raises(ValueError, match=r"anneal .* must be a number in \[0, 1\]"):
            env.rules.set_anneal(bad)
    with pytest.raises(ValueError, match=r"Sumo option anneal must be a number in \[0.0, 1.0\] \(default 1.0: "
                                         r"weight of the dense motor reward.*\), not 2$"):
        make("Sumo-2T1P-v1", anneal=2)


def test_robot_motion_is_an_is_reward_that_needs_robot_measures():
    fn = lookup_reward("IS", "robot_motion")
    assert set(fn.needs) == {"velocity_to_target", "fallen", "energy", "force"}
    assert fn.defaults == {"velocity": 1.0, "fall": 1.0, "control": 0.5, "contact": 0.01}
    from arena_league.envs import TreeSpecError

    with pytest.raises(TreeSpecError, match=r"needs the measure\(s\) \['fallen'\]"):
        make("Soccer-2T1P-v1", tree={"scheme": "NL", "children": [
            {"agent": "player_0", "scheme": "IS", "reward": "robot_motion"}, "player_1"]})


# --- options and errors -----------------------------------------------------------------------------------
@pytest.mark.parametrize("game_id", ROBOT_IDS)
def test_unknown_or_bad_kwargs_and_discrete_actions_are_refused(game_id):
    name = game_id.split("-")[0]
    with pytest.raises(ValueError, match=rf"{name} has no option 'gravity'; its options: .*start_jitter: a number in "
                                         r"\[0.0, 0.[45]\], default 0.2 .*; frame_skip: .*; anneal: "):
        make(game_id, gravity=1.0)
    with pytest.raises(ValueError, match=rf"{name} option frame_skip must be an integer in \[1, 20\] \(default 5: "
                                         r"MuJoCo sub-steps of 0.01 s per match step\), not 0$"):
        make(game_id, frame_skip=0)
    with pytest.raises(ValueError, match=rf"{name} has no option 'start_jiter' \(did you mean 'start_jitter'\?\)"):
        make(game_id, start_jiter=0.1)
    with pytest.raises(ValueError, match="no discrete action variant"):
        make(game_id, action_type="discrete")
    quick = make(game_id, frame_skip=2)
    assert quick.rules.frame_skip == 2


# --- pictures -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("game_id", ROBOT_IDS)
def test_top_down_picture_is_headless_and_shows_both_teams(game_id, monkeypatch):
    from arena_league.envs.rendering import TEAM_COLOURS

    monkeypatch.delenv("DISPLAY", raising=False)
    env = make(game_id, render_mode="rgb_array")
    env.reset(seed=0)
    picture = env.render()
    assert picture.dtype == np.uint8 and picture.ndim == 3 and picture.shape[2] == 3 and min(picture.shape[:2]) >= 200
    colours = {tuple(c) for c in np.unique(picture.reshape(-1, 3), axis=0)}
    assert TEAM_COLOURS[0] in colours and TEAM_COLOURS[1] in colours


def test_mujoco_camera_picture_where_gl_is_available():
    env = make("Sumo-2T1P-v1")
    env.reset(seed=0)
    try:
        picture = env.rules.render_camera(160, 120)
    except RuntimeError as err:
        assert "MUJOCO_GL=egl" in str(err)
        pytest.skip(f"no OpenGL context here: {err}")
    assert picture.shape == (120, 160, 3) and picture.dtype == np.uint8 and picture.std() > 0
