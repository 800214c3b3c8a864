"""LineRace: a tiny real game for the social tree's tests (not in the catalog).

Each seat runs along its own line from 0 toward 10; action 1 moves one unit (2 for action 2),
action 0 waits. A seat that reaches 10 arrives. Each step a seat that moves also eats one unit
of a shared pile of food (a limited resource: when the pile is empty nobody gains). The match ends
when everyone has arrived; the first team to finish wins.
"""

from __future__ import annotations

import numpy as np

from arena_league.envs.core import GameRules


class LineRace(GameRules):
    name = "LineRace"
    layouts = ((2, 1), (2, 2), (3, 1))
    measures_provided = frozenset({"active", "arrived", "alive", "target_distance", "object_progress",
                                   "resource_gain", "outcome", "energy"})
    default_max_cycles = 30
    goal = 10.0

    def __init__(self, n_teams, players_per_team, action_type, food: int = 20):
        super().__init__(n_teams, players_per_team, action_type)
        self.obs_dim = 3
        self.state_dim = self.n_agents
        self.n_actions = 3
        self.action_meanings = ("wait", "step", "run")
        self.food0 = food
        self.position = np.zeros(self.n_agents)

    def reset(self, seed):
        self.rng = np.random.default_rng(seed)
        self.position = self.rng.integers(0, 2, self.n_agents).astype(float)
        self.food = self.food0
        self.finish_step = np.full(self.n_teams, np.inf)
        self.t = 0
        m = self.measures
        m.active[:] = True
        m.arrived[:] = False
        m.alive[:] = True
        m.outcome[:] = 0
        m.resource_gain[:] = 0
        m.object_progress[:] = 0
        m.target_distance[:] = self.goal - self.position
        self.game_over = False

    def step(self, actions):
        m = self.measures
        self.t += 1
        move = np.where(m.active, actions, 0).astype(float)
        self.position = np.minimum(self.position + move, self.goal)
        gain = np.zeros(self.n_agents)
        for i in np.flatnonzero(move > 0):
            if self.food > 0:
                self.food -= 1
                gain[i] = 1
        m.resource_gain[:] = gain
        m.energy[:] = move / 2
        team_move = np.bincount(self.team_of, weights=move, minlength=self.n_teams)
        m.object_progress[:] = team_move[self.team_of]
        m.target_distance[:] = self.goal - self.position
        m.arrived[:] = self.position >= self.goal
        m.active[:] = ~m.arrived
        for t in range(self.n_teams):
            if np.isinf(self.finish_step[t]) and m.arrived[self.team_of == t].all():
                self.finish_step[t] = self.t
        if m.arrived.all():
            self.game_over = True
            self._set_outcome()

    def _set_outcome(self):
        best = self.finish_step.min()
        winners = self.finish_step == best
        for seat in range(self.n_agents):
            t = self.team_of[seat]
            self.measures.outcome[seat] = 0.0 if winners.all() else (1.0 if winners[t] else -1.0)

    def finish(self):
        self._set_outcome()

    def team_result(self):
        best = self.finish_step.min()
        return np.where(self.finish_step == best, 1.0 if (self.finish_step == best).sum() == 1 else 0.5, 0.0)

    def observe(self):
        obs = np.zeros((self.n_agents, 3), dtype=np.float32)
        obs[:, 0] = self.position / self.goal
        obs[:, 1] = self.measures.active
        obs[:, 2] = self.food / max(self.food0, 1)
        return obs

    def state(self):
        return (self.position / self.goal).astype(np.float32)

    def render_topdown(self):
        picture = np.full((8 * self.n_agents, 88, 3), 255, dtype=np.uint8)
        for i, p in enumerate(self.position):
            picture[8 * i:8 * i + 8, int(p * 8):int(p * 8) + 8] = (200, 40, 40)
        return picture

    @classmethod
    def default_tree(cls, n_teams, players_per_team):
        return {"scheme": "CP", "reward": "ranking", "scale": 10, "children": [
            {"scheme": "CL", "reward": "team_target", "children": [f"player_{t * players_per_team + p}"
                                                                    for p in range(players_per_team)]}
            for t in range(n_teams)]}

    @staticmethod
    def heuristic(obs, action_type):
        return np.full(len(obs), 2, dtype=np.int64)


def make_line_race(n_teams=2, players=2, tree=None, max_cycles=None, **kwargs):
    """A LineRace ParallelEnv built the way make() builds catalog games."""
    from arena_league.envs.env import ArenaParallelEnv
    from arena_league.envs.social.tree import SocialTree

    rules = LineRace(n_teams, players, "discrete", **kwargs)
    names = [f"player_{i}" for i in range(rules.n_agents)]
    spec = LineRace.default_tree(n_teams, players) if tree is None else tree
    social = SocialTree.build(spec, names, rules.team_of, rules.measures_provided, game="LineRace")
    return ArenaParallelEnv(f"LineRace-{n_teams}T{players}P-v1", rules, social,
                            max_cycles or rules.default_max_cycles, **kwargs.get("env_kwargs", {}))
