"""CaptureFlag's whole-array engine: many boards of one layout stepped by a few numpy operations
(the rules are the package's manual; this module is how they run)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from arena_league.envs.boards import BoardSlots, grow, reset_keys
from arena_league.envs.core import Measures

#: Actions in the seat's own frame (its base on the left): "right" leads toward the opponents' base.
ACTIONS: tuple[str, ...] = ("stay", "up", "right", "down", "left")
ACTION_ROW = np.array([0, -1, 0, 1, 0], dtype=np.int64)
ACTION_COL = np.array([0, 0, 1, 0, -1], dtype=np.int64)  # seat frame; team 1's columns run mirrored
N_ACTIONS = len(ACTIONS)
VIEW_RADIUS = 2
WINDOW = 2 * VIEW_RADIUS + 1
PER_OTHER = 5
#: The observation's runs, in order: (name, cells).
RUNS: tuple[tuple[str, int], ...] = (
    ("active", 1), ("position", 2), ("carrying", 1), ("own_flag_home", 1), ("enemy_flag_home", 1),
    ("in_enemy_half", 1), ("respawn", 1), ("captures", 2), ("blocked", N_ACTIONS), ("to_enemy_stand", N_ACTIONS),
    ("to_own_stand", N_ACTIONS), ("danger", N_ACTIONS), ("enemy_flag", 2), ("own_flag", 2),
    ("walls", WINDOW * WINDOW))
AT: dict[str, int] = {}
_start = 0
for _name, _cells in RUNS:
    AT[_name] = _start
    _start += _cells
N_HEADER = _start  # the others' runs follow, PER_OTHER cells each
_FAR = 1 << 20  # the distance of a wall or an unreachable cell

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def _scramble(x: np.ndarray) -> np.ndarray:
    """A bijective mix of ``uint64`` values (SplitMix64's finaliser, wrapping arithmetic)."""
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


def map_draws(keys: np.ndarray, count: int) -> np.ndarray:
    """``uint64[K, count]``: draws numbered ``0..count-1`` from each board's key, a function of the
    key alone (a board's map is the same whatever else is in the batch)."""
    index = (np.arange(count, dtype=np.uint64) + np.uint64(1)) * _GOLDEN
    return _scramble(_scramble(keys.astype(np.uint64)[:, None] + _GOLDEN) ^ index[None, :])


def _pick(draws: np.ndarray, n: int) -> np.ndarray:
    return (draws % np.uint64(n)).astype(np.int64)


class CaptureFlagBoards:
    """``n_boards`` CaptureFlag matches of two teams of ``players_per_team`` stepped together.

    Boards are padded with a wall border ``VIEW_RADIUS`` cells wide, so moves and windows need no
    bounds check; positions are padded cells (``pos``), ``cell()`` gives board cells
    (``row * cols + col``).
    """

    def __init__(self, n_boards: int, players_per_team: int = 1, rows: int = 11, cols: int = 20,
                 wall_segments: int = 8, respawn_delay: int = 5, captures_to_win: int = 3,
                 autoreset: bool = False, max_steps: int | None = None, seed: int = 0) -> None:
        if n_boards < 1 or not 1 <= players_per_team <= 4:
            raise ValueError(f"CaptureFlagBoards needs n_boards >= 1 and 1..4 players a team, not {n_boards}, "
                             f"{players_per_team}")
        if rows < 7 or cols < 10 or cols % 2:
            raise ValueError(f"a CaptureFlag map has at least 7 rows and an even number of columns, at least 10 "
                             f"(the halves mirror each other); got {rows} x {cols}")
        self.n_boards, self.players_per_team = int(n_boards), int(players_per_team)
        self.rows, self.cols = int(rows), int(cols)
        self.wall_segments, self.respawn_delay = int(wall_segments), int(respawn_delay)
        self.captures_to_win = int(captures_to_win)
        self.autoreset, self.max_steps = bool(autoreset), max_steps
        self.rng = np.random.default_rng(seed)
        n = self.n_agents = 2 * self.players_per_team
        self.n_teams = 2
        self.team_of = np.repeat(np.arange(2, dtype=np.int64), self.players_per_team)
        self.obs_dim = N_HEADER + PER_OTHER * (n - 1)
        self.n_cells = self.rows * self.cols
        self.state_dim = self.n_cells + 5 * n + 6 + 2
        self._build_tables()
        b = self.n_boards
        self._boards = np.arange(b)
        self.walls = np.zeros((b, self._padded), dtype=bool)
        self.dist = np.zeros((b, 2, self._padded), dtype=np.int64)  # steps to each team's stand
        self.stand_distance = np.zeros(b, dtype=np.int64)
        self.pos = np.zeros((b, n), dtype=np.int64)
        self.active = np.ones((b, n), dtype=bool)
        self.respawn = np.zeros((b, n), dtype=np.int64)
        self.carrier = np.full((b, 2), -1, dtype=np.int64)  # the seat carrying team t's flag
        self.captures = np.zeros((b, 2), dtype=np.int64)
        self.held_steps = np.zeros((b, 2), dtype=np.int64)  # steps each team ended holding the other's flag
        self.t = np.zeros(b, dtype=np.int64)
        self.keys = np.zeros(b, dtype=np.uint64)
        self.done = np.zeros(b, dtype=bool)
        self.truncated = np.zeros(b, dtype=bool)
        self.final_scores = np.full((b, 2), np.nan)
        self.tagged = np.zeros((b, n), dtype=bool)
        self.picked = np.zeros((b, n), dtype=bool)
        self.scored = np.zeros((b, 2), dtype=bool)
        self.target_distance = np.zeros((b, n), dtype=np.int64)
        self.toward_target = np.zeros((b, n), dtype=np.int64)
        self.flag_progress = np.zeros((b, 2), dtype=np.int64)
        # flat offsets of each board's rows in the arrays above, for one-call gathers
        self._wall_offset = (self._boards * self._padded)[:, None]
        self._seat_offset = (self._boards * n)[:, None]
        self._field_offset = (self._boards[:, None] * 2 + np.arange(2)[None, :]) * self._padded  # [B, team]
        self._enemy_field = self._field_offset[:, 1 - self.team_of]  # [B, N]: the stand each seat raids
        self._own_field = self._field_offset[:, self.team_of]
        self.carrying = np.zeros((b, n), dtype=bool)  # seat carries the opponents' flag
        self.flag_at = np.zeros((b, 2), dtype=np.int64)  # padded cell of each team's flag
        self.reset()

    # --- fixed tables ----------------------------------------------------------------------------
    def _build_tables(self) -> None:
        r, c, p = self.rows, self.cols, VIEW_RADIUS
        side = self._side = c + 2 * p
        self._padded = (r + 2 * p) * side
        rows, cols = np.divmod(np.arange(self.n_cells), c)
        self._inner = (rows + p) * side + cols + p  # board cell -> padded cell
        pr, pc = np.divmod(np.arange(self._padded), side)
        self._row_of, self._col_of = pr - p, pc - p  # board row and column of every padded cell
        self._half_of = (self._col_of >= c // 2).astype(np.int64)  # 0: team 0's half
        # every padded cell's column in team 0's frame, then in team 1's (mirrored)
        self._frame_cols = np.concatenate([self._col_of, c - 1 - self._col_of])
        mid = r // 2
        self.stands = np.array([(mid + p) * side + 1 + p, (mid + p) * side + c - 2 + p], dtype=np.int64)
        spawn_rows = np.array([mid - 1, mid + 1, mid - 2, mid + 2])[:self.players_per_team]
        spawn = np.concatenate([(spawn_rows + p) * side + p, (spawn_rows + p) * side + c - 1 + p])
        self.spawns = spawn.astype(np.int64)
        mirror = np.where(self.team_of == 1, -1, 1)  # team 1's seat frame flips columns
        self._frame_offset = self.team_of * self._padded  # each seat's half of _frame_cols
        self._mirror = mirror
        self._delta = ACTION_ROW[None, :] * side + ACTION_COL[None, :] * mirror[:, None]  # [N, A]
        dr, dc = np.divmod(np.arange(WINDOW * WINDOW), WINDOW)
        dr, dc = dr - p, dc - p
        self._window = dr[None, :] * side + dc[None, :] * mirror[:, None]  # [N, W^2] seat frame order
        n = self.n_agents
        others = []
        for i in range(n):
            mates = [j for j in range(n) if j != i and self.team_of[j] == self.team_of[i]]
            rivals = [j for j in range(n) if self.team_of[j] != self.team_of[i]]
            others.append(mates + rivals)
        self._others = np.array(others, dtype=np.int64).reshape(n, n - 1)
        self._team_seats = (np.flatnonzero(self.team_of == 0), np.flatnonzero(self.team_of == 1))
        self._rivals = np.array([[j for j in range(n) if self.team_of[j] != self.team_of[i]] for i in range(n)])
        # cells never walled: each base's stand, spawns and the cells around them (rows mid +- 2, 3 columns)
        keep = np.zeros((r, c // 2), dtype=bool)
        keep[max(mid - 2, 0):mid + 3, 0:3] = True
        self._kept = keep

    def cell(self, padded: np.ndarray) -> np.ndarray:
        """Board cells ``row * cols + col`` of padded cells."""
        return self._row_of[padded] * self.cols + self._col_of[padded]

    def frame_col(self, padded: np.ndarray) -> np.ndarray:
        """Columns of padded cells in each seat's frame (team 1's mirrored); ``padded`` is ``[..., N]``."""
        return np.take(self._frame_cols, self._frame_offset + padded)

    # --- maps ------------------------------------------------------------------------------------
    def draw_walls(self, keys: np.ndarray) -> np.ndarray:
        """``bool[K, rows, cols]``: the map of each key, walls in the left half drawn as segments and
        mirrored into the right half, unreachable pockets filled (manual, "Field")."""
        k, r, half = len(keys), self.rows, self.cols // 2
        s = self.wall_segments
        walls = np.zeros((k, r, half), dtype=bool)
        if s:
            draws = map_draws(keys, 4 * s).reshape(k, s, 4)
            row0, col0 = _pick(draws[..., 0], r), _pick(draws[..., 1], half)
            vertical, length = _pick(draws[..., 2], 2), 2 + _pick(draws[..., 3], 3)
            step = np.arange(4)
            rows = row0[..., None] + vertical[..., None] * step
            cols = col0[..., None] + (1 - vertical[..., None]) * step
            inside = (step < length[..., None]) & (rows < r) & (cols < half)
            board = np.broadcast_to(np.arange(k)[:, None, None], rows.shape)
            walls[board[inside], rows[inside], cols[inside]] = True
            walls &= ~self._kept
        full = np.concatenate([walls, walls[:, :, ::-1]], axis=2)
        return full

    def _distances(self, walls: np.ndarray) -> np.ndarray:
        """``int64[K, rows, cols]``: steps from team 0's stand over open cells (``_FAR`` for walls and
        cells it cannot reach), by breadth-first waves over every board at once."""
        k, r, c = walls.shape
        dist = np.full((k, r, c), _FAR, dtype=np.int64)
        reached = np.zeros((k, r, c), dtype=bool)
        reached[:, r // 2, 1] = True
        dist[:, r // 2, 1] = 0
        open_ = ~walls
        wave = 0
        while True:
            grown = grow(reached, open_)
            new = grown & ~reached
            if not new.any():
                return dist
            wave += 1
            dist[new] = wave
            reached = grown

    def _set_maps(self, sel: np.ndarray, walls: np.ndarray, mirrored: bool = True) -> None:
        """Put the maps ``walls`` (``bool[K, rows, cols]``) on boards ``sel``: pockets the stands
        cannot reach become walls, a map whose halves do not meet loses its walls. On ``mirrored``
        maps team 1's distances are the mirror image of team 0's."""
        dist = self._distances(walls)
        cut = dist[:, self.rows // 2, self.cols - 2] >= _FAR
        if cut.any():
            walls = walls.copy()
            walls[cut] = False
            dist[cut] = self._distances(walls[cut])
        walls = walls | (dist >= _FAR)
        flat_walls = np.ones((len(sel), self._padded), dtype=bool)
        flat_walls[:, self._inner] = walls.reshape(len(sel), -1)
        self.walls[sel] = flat_walls
        d0 = np.full((len(sel), self._padded), _FAR, dtype=np.int64)
        d0[:, self._inner] = dist.reshape(len(sel), -1)
        d1 = np.full((len(sel), self._padded), _FAR, dtype=np.int64)
        other = dist[:, :, ::-1] if mirrored else self._distances(walls[:, :, ::-1])[:, :, ::-1]
        d1[:, self._inner] = np.where(walls, _FAR, other).reshape(len(sel), -1)
        self.dist[sel, 0] = d0
        self.dist[sel, 1] = d1
        self.stand_distance[sel] = d0[:, self.stands[1]]

    # --- matches ---------------------------------------------------------------------------------
    def reset(self, boards: Any = None, keys: Any = None) -> None:
        """New matches on every board (or on the boards indexed), each map from its board's key."""
        sel, keys = reset_keys(self._boards, self.rng, boards, keys)
        self.keys[sel] = keys
        self._set_maps(sel, self.draw_walls(keys))
        self._start(sel)

    def _start(self, sel: np.ndarray) -> None:
        self.pos[sel] = self.spawns
        self.active[sel] = True
        self.respawn[sel] = 0
        self.carrier[sel] = -1
        self.captures[sel] = 0
        self.held_steps[sel] = 0
        self.t[sel] = 0
        self.done[sel] = False
        self.truncated[sel] = False
        self.final_scores[sel] = np.nan
        self.tagged[sel] = False
        self.picked[sel] = False
        self.scored[sel] = False
        self.toward_target[sel] = 0
        self.flag_progress[sel] = 0
        self._update_flags()
        self.target_distance[sel] = self._target_distance(sel)

    def set_board(self, board: int, walls: np.ndarray, positions: Sequence[int] | None = None) -> None:
        """A position on one board (puzzles, tests): ``walls`` ``bool[rows, cols]`` (mirror-symmetric
        or not: tests may want either), ``positions`` each seat's board cell (default: the spawns).
        Flags go home, captures and the step counter restart at 0."""
        b = int(board)
        walls = np.asarray(walls, dtype=bool)
        if walls.shape != (self.rows, self.cols):
            raise ValueError(f"set_board needs walls of shape ({self.rows}, {self.cols}), not {walls.shape}")
        self._set_maps(np.array([b]), walls[None], mirrored=bool((walls == walls[:, ::-1]).all()))
        self._start(np.array([b]))
        if positions is not None:
            cells = self._inner[np.asarray(positions, dtype=np.int64)]
            if cells.shape != (self.n_agents,) or self.walls[b, cells].any():
                raise ValueError(f"set_board needs one open board cell for each of the {self.n_agents} seats")
            self.pos[b] = cells
            self._update_flags()
            self.target_distance[b] = self._target_distance(np.array([b]))[0]

    def random_actions(self) -> np.ndarray:
        """Uniform random actions from the engine's generator (every action is legal)."""
        return self.rng.integers(N_ACTIONS, size=(self.n_boards, self.n_agents))

    def _update_flags(self) -> None:
        """``carrying`` and ``flag_at`` from ``carrier`` and ``pos`` (a tool may have set those)."""
        self.carrying = self.carrier[:, 1 - self.team_of] == np.arange(self.n_agents)
        carried = self.carrier >= 0
        self.flag_at = np.where(carried, np.take(self.pos, self._seat_offset + np.maximum(self.carrier, 0)),
                                self.stands)

    def _target_offsets(self) -> np.ndarray:
        """``int64[B, N]``: the flat offset of the distance field each seat heads by (its own stand's
        while it carries a flag, else the opponents')."""
        return np.where(self.carrying, self._own_field, self._enemy_field)

    def _target_distance(self, sel: Any) -> np.ndarray:
        return np.take(self.dist, self._target_offsets()[sel] + self.pos[sel])

    def step(self, actions: np.ndarray) -> None:
        """One step of every unfinished board; ``actions[b, i]`` is in seat ``i``'s own frame."""
        actions = np.asarray(actions)
        if actions.shape != (self.n_boards, self.n_agents) or actions.dtype.kind not in "iu":
            raise ValueError(f"CaptureFlagBoards.step takes integer actions of shape ({self.n_boards}, "
                             f"{self.n_agents}); got shape {actions.shape} dtype {actions.dtype}")
        if actions.size and (actions.min() < 0 or actions.max() >= N_ACTIONS):
            raise ValueError("CaptureFlag actions are 0 stay, 1 up, 2 right, 3 down, 4 left (seat frame)")
        if self.autoreset:
            self.done[:] = False
            self.truncated[:] = False
        live = ~self.done
        n, boards = self.n_agents, self._boards
        moving = self.active & live[:, None]
        self._update_flags()
        field = self._target_offsets()
        progress_before = self._flag_gain()
        # 1. moves: a wall keeps the seat where it stands
        target = self.pos + self._delta[np.arange(n), actions]
        blocked = np.take(self.walls, self._wall_offset + target)
        pos = np.where(moving & ~blocked, target, self.pos)
        # 2. tags: an exposed seat (in the opponents' half, or carrying) next to or on an active opponent
        exposed = (self._half_of[pos] != self.team_of) | self.carrying
        row, col = self._row_of[pos], self._col_of[pos]
        rivals = self._rivals
        near = (np.abs(row[:, :, None] - row[:, rivals]) + np.abs(col[:, :, None] - col[:, rivals])) <= 1
        tagged = moving & exposed & (near & moving[:, rivals]).any(axis=2)
        if tagged.any():
            drop = tagged[:, :, None] & (self.carrier[:, None, :] == np.arange(n)[None, :, None])
            self.carrier[drop.any(axis=1)] = -1
            pos = np.where(tagged, self.spawns, pos)
            self.respawn = np.where(tagged, self.respawn_delay + 1, self.respawn)
        playing = moving & ~tagged
        # 3. pick-ups: a seat on the opponents' stand while their flag is there takes it (lowest seat first)
        picked = np.zeros_like(moving)
        on_stand = playing & (pos == self.stands[1 - self.team_of]) & (self.carrier[:, 1 - self.team_of] < 0)
        if on_stand.any():
            for flag, raiders in ((0, self._team_seats[1]), (1, self._team_seats[0])):
                takers = on_stand[:, raiders]
                takes = np.flatnonzero(takers.any(axis=1))
                first = raiders[takers[takes].argmax(axis=1)]
                self.carrier[takes, flag] = first
                picked[takes, first] = True
        # 4. captures: a carrier on its own stand while its own flag is there scores
        held = self.carrier[:, ::-1]  # the seat holding the flag each team would score with
        home = np.take(pos, self._seat_offset + np.maximum(held, 0)) == self.stands
        scored = (held >= 0) & home & (self.carrier < 0) & live[:, None]
        self.carrier[scored[:, ::-1]] = -1  # the captured flag goes back to its stand
        self.captures += scored
        # 5. respawns: a tagged seat misses respawn_delay steps, then stands on its spawn again
        waiting = ~self.active & live[:, None]
        self.respawn = np.where(waiting | tagged, self.respawn - 1, self.respawn)
        back = waiting & (self.respawn <= 0)
        self.active = (self.active & ~tagged) | back
        self.pos = pos
        self.t = self.t + live
        self.tagged, self.picked, self.scored = tagged, picked, scored
        self._update_flags()
        self.held_steps += live[:, None] & (self.carrier[:, ::-1] >= 0)  # team t holds flag 1 - t
        # measures: the step toward the target the seat had, the distance to the one it has now
        after = np.take(self.dist, field + pos)
        self.toward_target = np.where(playing, self.target_distance - after, 0)
        self.target_distance = np.where(live[:, None], self._target_distance(boards), self.target_distance)
        gain = self._flag_gain() + scored * self.stand_distance[:, None]
        self.flag_progress = np.where(live[:, None], gain - progress_before, 0)
        # the end
        won = live & (self.captures >= self.captures_to_win).any(axis=1)
        truncated = live & ~won & (self.t >= self.max_steps) if self.max_steps else np.zeros_like(won)
        self.truncated = truncated
        self.done = self.done | won | truncated
        finished = np.flatnonzero(won | truncated)
        if finished.size:
            self.final_scores[finished] = self.team_scores(finished)
            if self.autoreset:
                saved = (self.done.copy(), self.truncated.copy(), self.final_scores.copy())
                self.reset(finished)
                self.done, self.truncated, self.final_scores = saved

    def _flag_gain(self) -> np.ndarray:
        """``int64[B, 2]``: how far each team has brought the flag it carries from the opponents'
        stand toward its own (0 while it carries none); ``flag_at`` must be current."""
        left = np.take(self.dist, self._field_offset + self.flag_at[:, ::-1])  # team t carries flag 1 - t
        return np.where(self.carrier[:, ::-1] >= 0, self.stand_distance[:, None] - left, 0)

    def team_scores(self, boards: Any = None) -> np.ndarray:
        """``float64[K, 2]``: 1 for more captures, 0 for fewer; on equal captures 1 for more steps
        holding the opponents' flag, 0 for fewer, 0.5 each for as many (manual, the match's end)."""
        sel = self._boards if boards is None else np.asarray(boards, dtype=np.int64).reshape(-1)
        c, held = self.captures[sel], self.held_steps[sel]
        lead = np.where(c[:, 0] != c[:, 1], c[:, 0] - c[:, 1], held[:, 0] - held[:, 1])
        first = np.sign(lead) * 0.5 + 0.5
        return np.stack([first, 1.0 - first], axis=1)

    # --- what seats see -----------------------------------------------------------------------
    def observe(self) -> np.ndarray:
        """``float32[B, N, obs_dim]``: every seat's observation in its own frame (manual)."""
        b, n, r, c = self.n_boards, self.n_agents, self.rows, self.cols
        obs = np.zeros((b, n, self.obs_dim), dtype=np.float32)
        pos = self.pos
        row = self._row_of[pos]
        fcol = self.frame_col(pos)
        team = self.team_of
        own_flag_home = self.carrier[:, team] < 0
        enemy_flag_home = self.carrier[:, 1 - team] < 0
        carrying = self.carrying
        obs[:, :, AT["active"]] = self.active
        obs[:, :, AT["position"]] = row * (2.0 / (r - 1)) - 1.0
        obs[:, :, AT["position"] + 1] = fcol * (2.0 / (c - 1)) - 1.0
        obs[:, :, AT["carrying"]] = carrying
        obs[:, :, AT["own_flag_home"]] = own_flag_home
        obs[:, :, AT["enemy_flag_home"]] = enemy_flag_home
        obs[:, :, AT["in_enemy_half"]] = self._half_of[pos] != team
        obs[:, :, AT["respawn"]] = np.where(self.active, 0, self.respawn) * (1.0 / self.respawn_delay)
        obs[:, :, AT["captures"]] = self.captures[:, team] * (1.0 / self.captures_to_win)
        obs[:, :, AT["captures"] + 1] = self.captures[:, 1 - team] * (1.0 / self.captures_to_win)
        # per action: the cell it leads to
        dest = pos[:, :, None] + self._delta[None]  # [B, N, A]
        wall = np.take(self.walls, self._wall_offset[:, :, None] + dest)
        dest = np.where(wall, pos[:, :, None], dest)
        obs[:, :, AT["blocked"]:AT["blocked"] + N_ACTIONS] = wall
        scale = 1.0 / (2 * (r + c))
        to_enemy = np.take(self.dist, self._enemy_field[:, :, None] + dest)
        to_own = np.take(self.dist, self._own_field[:, :, None] + dest)
        obs[:, :, AT["to_enemy_stand"]:AT["to_enemy_stand"] + N_ACTIONS] = np.minimum(to_enemy * scale, 1.0)
        obs[:, :, AT["to_own_stand"]:AT["to_own_stand"] + N_ACTIONS] = np.minimum(to_own * scale, 1.0)
        # danger: the seat would be exposed on the cell, within 2 steps of an active opponent
        dr, dc = self._row_of[dest], self._col_of[dest]
        rivals = self._rivals
        rival_pos = pos[:, rivals]  # [B, N, R]
        gap = (np.abs(dr[..., None] - self._row_of[rival_pos][:, :, None, :])
               + np.abs(dc[..., None] - self._col_of[rival_pos][:, :, None, :]))
        gap = np.where(self.active[:, rivals][:, :, None, :], gap, _FAR).min(axis=3)
        exposed = (self._half_of[dest] != team[None, :, None]) | carrying[:, :, None]
        obs[:, :, AT["danger"]:AT["danger"] + N_ACTIONS] = exposed * np.where(gap <= 1, 1.0, np.where(gap == 2, 0.5, 0.0))
        # the flags, where they are now (a carried flag is where its carrier is), relative
        for name, flag in (("enemy_flag", 1 - team), ("own_flag", team)):
            at = self.flag_at[:, flag]  # [B, N]
            obs[:, :, AT[name]] = (self._row_of[at] - row) * (1.0 / (r - 1))
            obs[:, :, AT[name] + 1] = (self.frame_col(at) - fcol) * (1.0 / (c - 1))
        obs[:, :, AT["walls"]:AT["walls"] + WINDOW * WINDOW] = np.take(self.walls, self._wall_offset[:, :, None]
                                                                        + pos[:, :, None] + self._window)
        # the others: teammates first, then opponents
        if n > 1:
            o = self._others
            others = obs[:, :, N_HEADER:].reshape(b, n, n - 1, PER_OTHER)
            opos = pos[:, o]
            others[..., 0] = (self._row_of[opos] - row[:, :, None]) * (1.0 / (r - 1))
            ocol = np.take(self._frame_cols, self._frame_offset[:, None] + opos)  # in the viewer's frame
            others[..., 1] = (ocol - fcol[:, :, None]) * (1.0 / (c - 1))
            others[..., 2] = self.active[:, o]
            held = self.carrier[:, :, None, None] == o[None, None]  # [B, 2, N, N-1]
            others[..., 3] = held.any(axis=1)
            others[..., 4] = (self._half_of[opos] != team[o]) | others[..., 3].astype(bool)
        return obs

    def state(self) -> np.ndarray:
        """``float32[B, state_dim]``: the walls, every seat, both flags and the captures (manual)."""
        b, n, r, c = self.n_boards, self.n_agents, self.rows, self.cols
        state = np.zeros((b, self.state_dim), dtype=np.float32)
        state[:, :self.n_cells] = self.walls[:, self._inner]
        seats = state[:, self.n_cells:self.n_cells + 5 * n].reshape(b, n, 5)
        seats[..., 0] = self._row_of[self.pos] * (2.0 / (r - 1)) - 1.0
        seats[..., 1] = self._col_of[self.pos] * (2.0 / (c - 1)) - 1.0
        seats[..., 2] = self.active
        seats[..., 3] = self.carrying
        seats[..., 4] = np.where(self.active, 0, self.respawn) * (1.0 / self.respawn_delay)
        flags = state[:, self.n_cells + 5 * n:self.n_cells + 5 * n + 6].reshape(b, 2, 3)
        at = self.flag_at
        flags[..., 0] = self._row_of[at] * (2.0 / (r - 1)) - 1.0
        flags[..., 1] = self._col_of[at] * (2.0 / (c - 1)) - 1.0
        flags[..., 2] = self.carrier >= 0
        state[:, -2:] = self.captures * (1.0 / self.captures_to_win)
        return state

    def flag_cells(self, board: int = 0) -> np.ndarray:
        """``int64[2]``: the board cell of each team's flag now."""
        self._update_flags()
        return self.cell(self.flag_at[board])


class CaptureFlagMatches(BoardSlots):
    """CaptureFlag matches stepped together on a :class:`CaptureFlagBoards` with the rules'
    options; each match's map key is drawn from its seed exactly as the rules' ``reset``
    draws it. ``measures`` holds every match's measures as the rules set them, ``state()`` every
    match's global state (what ``arena_league.training.engine_batch`` computes rewards from)."""

    def __init__(self, rules: Any, n_slots: int, max_cycles: int) -> None:
        self.n_slots, self.max_cycles = n_slots, max_cycles
        self.team_of = np.asarray(rules.team_of, dtype=np.int64)
        self.boards = CaptureFlagBoards(n_slots, rules.players_per_team, **rules.settings)
        self.boards.done[:] = True  # idle slots: the engine leaves finished boards alone
        self._steps = np.zeros(n_slots, dtype=np.int64)
        self.measures = Measures.allocate(rules.n_agents, rules.measures_provided, n_slots)

    def start(self, slot: int, seed: int) -> None:
        self.boards.reset(np.array([slot]), keys=match_key(seed))
        self._steps[slot] = 0
        write_measures(self.measures, self.boards, np.array([slot]), np.zeros(0, dtype=np.int64))

    def acting(self) -> np.ndarray:
        return self.boards.active & ~self.boards.done[:, None]

    def step(self, actions: np.ndarray) -> np.ndarray:
        playing = np.flatnonzero(~self.boards.done)
        self.boards.step(np.asarray(actions, dtype=np.int64))
        self._steps[playing] += 1
        # a match the rules did not end is cut at the env's max_cycles
        self.boards.done[playing] |= self._steps[playing] >= self.max_cycles
        ended = np.zeros(self.n_slots, dtype=bool)
        ended[playing] = self.boards.done[playing]
        write_measures(self.measures, self.boards, playing, np.flatnonzero(ended))
        return ended

    def steps(self, slot: int) -> int:
        return int(self._steps[slot])


def match_key(seed: int) -> np.ndarray:
    """The map key of a match from its seed (the rules' ``reset`` and the batched matches agree)."""
    return np.random.default_rng(seed).integers(0, 2**64, size=1, dtype=np.uint64)


def write_measures(m: Measures, boards: CaptureFlagBoards, rows: np.ndarray, ended: np.ndarray) -> None:
    """The measures of boards ``rows`` as the rules set them after a step (or a start), and the
    outcome of the boards in ``ended``; a board not yet ended has outcome 0."""
    m.active[rows] = boards.active[rows]
    m.target_distance[rows] = boards.target_distance[rows]
    m.velocity_to_target[rows] = boards.toward_target[rows]
    m.object_progress[rows] = boards.flag_progress[rows][:, boards.team_of]
    m.outcome[rows] = 0.0
    if ended.size:
        scores = boards.team_scores(ended)
        m.outcome[ended] = 2.0 * scores[:, boards.team_of] - 1.0
