"""The social tree: composition of rewards, validation of specs, ranking, boards, verification."""

from __future__ import annotations

import numpy as np
import pytest
from line_race import LineRace, make_line_race

from arena_league.envs.social import TreeSpecError, register_reward, unregister_reward
from arena_league.envs.social.verify import verify_env

TEAMS = {"scheme": "CP", "reward": "ranking", "scale": 10, "children": [
    {"scheme": "CL", "reward": "team_target", "scale": 1, "children": [
        {"agent": "player_0", "scheme": "IS", "reward": "energy", "scale": 0.5}, "player_1"]},
    {"scheme": "CL", "reward": "team_target", "scale": 1, "children": ["player_2", "player_3"]}]}


def run(env, policy, seed=0):
    env.reset(seed=seed)
    totals = dict.fromkeys(env.possible_agents, 0.0)
    steps = 0
    while env.agents:
        _, rewards, *_ = env.step({a: policy(a) for a in env.agents})
        steps += 1
        for a, r in rewards.items():
            totals[a] += r
    return totals, steps


def test_reward_is_scaled_sum_along_path():
    env = make_line_race(tree=TEAMS)
    env.reset(seed=3)
    start = env.rules.position.copy()
    _, rewards, *_ = env.step({"player_0": 2, "player_1": 1, "player_2": 0, "player_3": 1})
    # team 0 moved 2 + 1, team 1 moved 0 + 1; player_0 also pays energy 2/2 at scale 0.5
    assert rewards["player_0"] == pytest.approx(1.5 - 0.5)
    assert rewards["player_1"] == pytest.approx(1.5)
    assert rewards["player_2"] == rewards["player_3"] == pytest.approx(0.5)
    assert (env.rules.position - start).tolist() == [2, 1, 0, 1]


def test_ranking_pays_winner_and_loser_once():
    env = make_line_race(tree=TEAMS)
    totals, _ = run(env, lambda a: 2 if a in ("player_0", "player_1") else 1)
    # ranking: +10 / -10 once; team_target: each team's mean progress over the episode
    start = np.array([0, 0, 0, 0])  # recomputed below from the same seed
    env.reset(seed=0)
    start = env.rules.position
    progress0 = (10 - start[:2]).mean()
    progress1 = (10 - start[2:]).mean()
    assert totals["player_1"] == pytest.approx(10 + progress0)
    assert totals["player_3"] == pytest.approx(-10 + progress1)


def test_ranking_ties_and_tie_penalty():
    tree = {"scheme": "CP", "reward": "ranking", "params": {"order": "depart", "tie_penalty": 0.25},
            "children": ["player_0", "player_1", "player_2"]}
    env = make_line_race(n_teams=3, players=1, tree=tree)
    env.reset(seed=0)
    env.rules.position[:] = [8, 8, 5]
    paid = np.zeros(3)
    while env.agents:
        _, r, *_ = env.step({"player_0": 2, "player_1": 2, "player_2": 1})
        paid += [r[a] for a in env.possible_agents]
    # players 0 and 1 tie for places 0 and 1 (mean 0.5 -> 1 - 2*0.5/2 = 0.5, minus the tie penalty)
    assert paid.tolist() == pytest.approx([0.25, 0.25, -1.0])


def test_survive_ranking_places_the_last_standing_first():
    rules = LineRace(3, 1, "discrete")
    from arena_league.envs.social.rewards import NodeView, RewardContext, lookup_reward

    fn = lookup_reward("CP", "ranking")
    node = NodeView(np.arange(3), np.arange(3), 3)
    m = rules.measures
    m.alive[:] = [True, False, True]
    ctx = RewardContext(m, {}, rules.team_of, 1, False)
    first = fn.fn(ctx, node, fn.check_params({"order": "survive"}))
    assert first.tolist() == [0, -1, 0]
    m.alive[:] = [False, False, True]
    second = fn.fn(ctx, node, fn.check_params({"order": "survive"}))
    assert second.tolist() == [0, 0, 1]  # player_0 second-to-last (0), player_2 wins at once (1)


@pytest.mark.parametrize("tree, message", [
    ({"scheme": "XX", "children": ["player_0", "player_1"]}, "unknown scheme 'XX'; valid schemes: NL, IS, CP, CL, CC"),
    ({"scheme": "CL", "reward": "ranking", "children": ["player_0", "player_1"]}, "'ranking' is a CP function"),
    ({"scheme": "CP", "reward": "ranking", "children": ["player_0"]}, "at least two children"),
    ({"scheme": "CP", "reward": "ranking", "children": ["player_0", "player_0"]}, "listed twice"),
    ({"scheme": "CP", "reward": "ranking", "children": ["player_0", "player_9"]}, "unknown agent 'player_9'"),
    ({"scheme": "IS", "reward": "target", "children": ["player_0"]}, "leaves out agent(s) player_1"),
    ({"scheme": "CP", "reward": "ranking", "colour": 1, "children": ["player_0", "player_1"]}, "unknown key(s) ['colour']"),
    ({"scheme": "CP", "reward": "ranking", "children": [{"agent": "player_0", "scheme": "CP", "reward": "win_loss"},
                                                      "player_1"]}, "only an IS or NL reward"),
    ({"scheme": "IS", "reward": "fall", "children": ["player_0", "player_1"]}, "needs the measure(s) ['fallen']"),
    ({"scheme": "CP", "reward": "ranking", "params": {"order": "sideways"}, "children": ["player_0", "player_1"]},
     "use 'depart'"),
    ({"scheme": "CP", "reward": "ranking", "scale": "big", "children": ["player_0", "player_1"]}, "finite number"),
])
def test_malformed_trees_are_refused_with_the_fix(tree, message):
    with pytest.raises(TreeSpecError) as err:
        make_line_race(n_teams=2, players=1, tree=tree)
    assert message in str(err.value)


def test_cycle_is_refused():
    node = {"scheme": "CL", "reward": "team_target", "children": ["player_0"]}
    node["children"].append(node)
    with pytest.raises(TreeSpecError, match="cycle"):
        make_line_race(n_teams=2, players=1, tree=node)


def test_tree_from_yaml_file(tmp_path):
    path = tmp_path / "tree.yaml"
    path.write_text("scheme: CP\nreward: win_loss\nchildren: [player_0, player_1]\n")
    env = make_line_race(n_teams=2, players=1, tree=str(path))
    assert [n.scheme for n in env.tree.nodes] == ["CP"]
    (tmp_path / "bad.yaml").write_text("scheme: [unclosed\n")
    with pytest.raises(TreeSpecError, match="not valid YAML"):
        make_line_race(n_teams=2, players=1, tree=str(tmp_path / "bad.yaml"))


def test_broadcast_board_extends_actions_and_observations():
    tree = {"scheme": "CP", "reward": "ranking", "board": 1, "children": [
        {"scheme": "CL", "reward": "team_target", "board": 2, "children": ["player_0", "player_1"]},
        {"scheme": "CL", "reward": "team_target", "children": ["player_2", "player_3"]}]}
    env = make_line_race(tree=tree)
    obs, _ = env.reset(seed=0)
    assert env.observation_space("player_0").shape == (3 + 3,)
    assert env.observation_space("player_2").shape == (3 + 1,)
    assert env.action_space("player_0")["message"].shape == (3,)
    assert env.action_space("player_2")["message"].shape == (1,)
    actions = {
        "player_0": {"action": 1, "message": np.array([0.5, 1.0, -1.0], np.float32)},
        "player_1": {"action": 1, "message": np.array([-0.5, 0.0, 0.0], np.float32)},
        "player_2": {"action": 1, "message": np.array([1.0], np.float32)},
        "player_3": {"action": 1, "message": np.array([0.0], np.float32)},
    }
    obs, *_ = env.step(actions)
    # root board: mean of the four first message floats; team board: mean of team 0's last two
    assert obs["player_0"][3:].tolist() == pytest.approx([0.25, 0.5, -0.5])
    assert obs["player_3"][3:].tolist() == pytest.approx([0.25])
    with pytest.raises(ValueError, match="broadcast board"):
        env.step({**actions, "player_1": 1})


def test_state_in_every_observation():
    env = make_line_race(env_kwargs={"state_in_obs": True}) if False else make_line_race()
    from arena_league.envs.env import ArenaParallelEnv

    env = ArenaParallelEnv(env.game_id, env.rules, env.tree, 30, state_in_obs=True)
    obs, _ = env.reset(seed=2)
    assert obs["player_1"][3:].tolist() == pytest.approx(env.state().tolist())


@pytest.mark.parametrize("action, message", [
    (7, "action 7 of player_0 is out of range; valid actions: 0 (wait), 1 (step), 2 (run)"),
    (-1, "out of range"),
    ([1, 2], "is not an integer"),
    ("run", "is not an integer"),
])
def test_bad_actions_name_the_valid_choices(action, message):
    env = make_line_race()
    env.reset(seed=0)
    with pytest.raises(ValueError) as err:
        env.step({"player_0": action, "player_1": 1, "player_2": 1, "player_3": 1})
    assert message in str(err.value)
    with pytest.raises(ValueError, match="missing actions for player_3"):
        env.step({"player_0": 1, "player_1": 1, "player_2": 1})


def test_declared_trees_verify():
    report = verify_env(make_line_race(tree=TEAMS), samples=24)
    assert [(n.path, n.verified) for n in report.nodes] == [
        ("root", "CP"), ("root/0", "CL"), ("root/0/player_0", "IS"), ("root/1", "CL")]
    assert report.ok
    mixed = {"scheme": "CC", "reward": "team_progress_race", "children": ["player_0", "player_1", "player_2", "player_3"]}
    assert verify_env(make_line_race(tree=mixed), samples=24).nodes[0].verified == "CC"
    constant = {"scheme": "NL", "reward": "constant", "children": ["player_0", "player_1", "player_2", "player_3"]}
    assert verify_env(make_line_race(tree=constant), samples=12).nodes[0].verified == "NL"


def test_mis_declared_custom_function_is_caught():
    @register_reward("my_team_bonus", "CL", needs=("object_progress",))
    def my_team_bonus(ctx, node, params):
        """Declared collaborative, but pays each agent its own team's progress minus the others'."""
        progress = ctx.measures.object_progress[node.agents]
        return progress - progress[::-1]

    try:
        tree = {"scheme": "CL", "reward": "my_team_bonus", "children": ["player_0", "player_1"]}
        report = verify_env(make_line_race(n_teams=2, players=1, tree=tree), samples=16)
        node = report.nodes[0]
        assert (node.declared, node.verified, node.ok) == ("CL", "CP", False)
        assert not report.ok
    finally:
        unregister_reward("my_team_bonus", "CL")


def test_sibling_team_nodes_are_computed_in_one_call_with_the_same_rewards():
    # each team's CL team_target is one call on the hot path; the rewards are those node by node
    # (the verification path), bit for bit; a nested node of the same reward stays apart
    nested = {"scheme": "CL", "reward": "team_target", "scale": 1, "children": [
        TEAMS["children"][0], {"scheme": "CL", "reward": "team_target", "scale": 1, "children": ["player_2", "player_3"]}]}
    for tree, calls in ((TEAMS, 3), (nested, 4)):
        env = make_line_race(tree=tree)
        assert len(env.tree.plan) == calls
        env.reset(seed=4)
        for step in range(6):
            env.step({a: (step + k) % 3 for k, a in enumerate(env.agents)})
            per_node = np.zeros((len(env.tree.nodes), env.tree.n_agents))
            assert env.tree.rewards(env._ctx).tobytes() == env.tree.rewards(env._ctx, per_node).tobytes()


def test_calls_over_scattered_seats_pay_what_the_nodes_pay_one_by_one():
    # teams of seats {0, 2} and {1, 3}: every call's seats are out of order, indexed by an array
    tree = {"scheme": "CP", "reward": "ranking", "scale": 10, "params": {"order": "depart"}, "children": [
        {"scheme": "CL", "reward": "team_target", "scale": 1, "children": ["player_0", "player_2"]},
        {"scheme": "CL", "reward": "team_target", "scale": 1, "children": ["player_1", "player_3"]}]}
    env = make_line_race(tree=tree)
    assert all(isinstance(place, np.ndarray) for *_, place, _ in env.tree.plan)
    env.reset(seed=2)
    while env.agents:
        env.step({a: 2 if k % 2 else 1 for k, a in enumerate(env.agents)})
        per_node = np.zeros((len(env.tree.nodes), env.tree.n_agents))
        assert env.tree.rewards(env._ctx).tobytes() == env.tree.rewards(env._ctx, per_node).tobytes()


@pytest.mark.parametrize("reward", ["team_living_longer", "team_living_shorter"])
def test_team_living_nodes_in_one_call_pay_what_they_pay_node_by_node(reward):
    # one team arrives (goes out of play) first: the grouped call pays it 0.0 (-0.0 when shorter),
    # the other team 1.0 (-1.0), the same bytes as the nodes one by one
    tree = {"scheme": "CP", "reward": "ranking", "scale": 10, "children": [
        {"scheme": "CL", "reward": reward, "scale": 0.5, "children": ["player_0", "player_1"]},
        {"scheme": "CL", "reward": reward, "scale": 0.5, "children": ["player_2", "player_3"]}]}
    env = make_line_race(tree=tree)
    assert len(env.tree.plan) == 2
    env.reset(seed=1)
    paid = []
    while env.agents:
        fast = [2, 2, 0, 1]
        env.step({a: fast[k] for k, a in enumerate(env.agents)})
        per_node = np.zeros((len(env.tree.nodes), env.tree.n_agents))
        rewards = env.tree.rewards(env._ctx)
        assert rewards.tobytes() == env.tree.rewards(env._ctx, per_node).tobytes()
        paid.append(tuple(per_node[1:].sum(axis=0)))
    assert (0.0, 0.0, 1.0, 1.0) in paid or (-0.0, -0.0, -1.0, -1.0) in paid
