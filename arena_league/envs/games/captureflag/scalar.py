"""CaptureFlag's one-board engine: one match in plain Python numbers, for the env's step.

A one-board :class:`~arena_league.envs.games.captureflag.engine.CaptureFlagBoards` pays numpy's
per-call cost on some 150-200 array operations a step; this engine plays the same step with Python
ints and lists, and builds an observation from rows of tables made once per map. The batched engine
stays the reference: maps are drawn by it (:meth:`ScalarBoard.load` reads a board of it, map
included), :meth:`ScalarBoard.store` writes a match back into it, and
``tests/test_game_captureflag_scalar.py`` checks that both play every step alike.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from arena_league.envs.games.captureflag.engine import N_ACTIONS, CaptureFlagBoards

_NO_DANGER = (0.0,) * N_ACTIONS
#: The per-seat and per-team arrays a board's match is, as ``CaptureFlagBoards`` names them.
_STATE = ("pos", "active", "respawn", "carrier", "captures", "held_steps", "tagged", "picked", "scored",
          "target_distance", "toward_target", "flag_progress")


class ScalarBoard:
    """One CaptureFlag match of ``engine``'s layout and options, its state in Python lists:
    ``pos`` (padded cells), ``active``, ``respawn``, ``carrier`` (the seat carrying each team's
    flag, or -1), ``captures``, ``held_steps`` and the last step's ``tagged``, ``picked``, ``scored``,
    named as the batched engine's arrays (one board's row of each)."""

    def __init__(self, engine: CaptureFlagBoards) -> None:
        e = engine
        self.n, self.rows, self.cols = e.n_agents, e.rows, e.cols
        self.obs_dim, self.state_dim = e.obs_dim, e.state_dim
        self.respawn_delay, self.captures_to_win = e.respawn_delay, e.captures_to_win
        self.team = e.team_of.tolist()
        self.row_of, self.col_of = e._row_of.tolist(), e._col_of.tolist()
        self.half_of = e._half_of.tolist()
        padded = e._padded
        self.frame_col = [e._frame_cols[:padded].tolist(), e._frame_cols[padded:].tolist()]
        self.stands, self.spawns = e.stands.tolist(), e.spawns.tolist()
        self.delta = e._delta.tolist()
        self.others, self.rivals = e._others.tolist(), e._rivals.tolist()
        self.team_seats = [seats.tolist() for seats in e._team_seats]
        # the numpy tables a map's rows are cut from: one seat of each team stands for its frame
        first = [int(seats[0]) for seats in e._team_seats]
        self._frame_delta = e._delta[first]  # [team, action]
        self._frame_window = e._window[first]  # [team, window cells]
        self._inner = e._inner
        self._padded = padded
        self._scale = 1.0 / (2 * (e.rows + e.cols))
        # d / (size - 1) as the observation computes it, ``d * (1 / (size - 1))``, for every difference
        # d of two rows (columns), negative ones indexed from the end as Python lists are
        inv_r, inv_c = 1.0 / (e.rows - 1), 1.0 / (e.cols - 1)
        self._rel_row = [d * inv_r for d in range(e.rows)] + [d * inv_r for d in range(1 - e.rows, 0)]
        self._rel_col = [d * inv_c for d in range(e.cols)] + [d * inv_c for d in range(1 - e.cols, 0)]
        self._map_walls: np.ndarray | None = None
        self._map_dist: np.ndarray | None = None
        self._written: dict[str, list] = {}

    # --- to and from the batched engine ------------------------------------------------------
    def load(self, engine: CaptureFlagBoards, board: int = 0) -> None:
        """Take board ``board`` of ``engine`` as this match: its map (the tables are rebuilt only
        when the map differs from the one held) and its whole state."""
        b = board
        walls, dist = engine.walls[b], engine.dist[b]
        if (self._map_walls is None or not np.array_equal(walls, self._map_walls)
                or not np.array_equal(dist, self._map_dist)):
            self._set_map(walls.copy(), dist.copy(), int(engine.stand_distance[b]))
        for name in _STATE:
            setattr(self, name, getattr(engine, name)[b].tolist())
        self.t = int(engine.t[b])
        self.done = bool(engine.done[b])
        self._written.clear()

    def store(self, engine: CaptureFlagBoards, board: int = 0) -> None:
        """Write this match's state into board ``board`` of ``engine``, which holds its map."""
        b = board
        for name in _STATE:
            getattr(engine, name)[b] = getattr(self, name)
        engine.t[b] = self.t
        engine.done[b] = self.done
        engine.truncated[b] = False
        engine.final_scores[b] = self.team_scores() if self.done else np.nan
        engine._update_flags()

    def _set_map(self, walls: np.ndarray, dist: np.ndarray, stand_distance: int) -> None:
        """The map's Python tables, and the numpy tables the observation's rows are cut from."""
        self._map_walls, self._map_dist = walls, dist
        self.walls = walls.tolist()
        self.dist = dist.tolist()
        self.stand_distance = stand_distance
        inner = self._inner
        static = np.zeros((2, self._padded, 3 * N_ACTIONS + self._frame_window.shape[1]), dtype=np.float32)
        dests = np.zeros((2, self._padded, N_ACTIONS), dtype=np.int64)
        for team in (0, 1):
            dest = inner[:, None] + self._frame_delta[team][None, :]
            blocked = walls[dest]
            dest = np.where(blocked, inner[:, None], dest)
            dests[team, inner] = dest
            rows = static[team, inner]
            rows[:, :N_ACTIONS] = blocked
            rows[:, N_ACTIONS:2 * N_ACTIONS] = np.minimum(dist[1 - team][dest] * self._scale, 1.0)
            rows[:, 2 * N_ACTIONS:3 * N_ACTIONS] = np.minimum(dist[team][dest] * self._scale, 1.0)
            rows[:, 3 * N_ACTIONS:] = walls[inner[:, None] + self._frame_window[team][None, :]]
            static[team, inner] = rows
        self._static, self._dests = static, dests
        # a cell's rows become Python lists the first time a seat of that team stands on it
        self._cells: list[list[Any]] = [[None] * self._padded, [None] * self._padded]
        self._wall_cells = walls[inner].astype(np.float64).tolist()

    def _cell(self, team: int, p: int) -> tuple:
        """``(blocked + to_enemy_stand + to_own_stand, walls, dests, row, column, in_enemy_half)`` of
        padded cell ``p`` in ``team``'s frame: the observation's fixed runs there, each action's
        cell as ``(row, col, half)`` and the seat's own cells of the observation."""
        rows = self._static[team, p].tolist()
        dests = self._dests[team, p].tolist()
        at = 3 * N_ACTIONS
        cell = (rows[:at], rows[at:], [(self.row_of[d], self.col_of[d], self.half_of[d]) for d in dests],
                self.row_of[p] * (2.0 / (self.rows - 1)) - 1.0, self.frame_col[team][p] * (2.0 / (self.cols - 1)) - 1.0,
                self.half_of[p] != team)
        self._cells[team][p] = cell
        return cell

    # --- the match ---------------------------------------------------------------------------
    def step(self, actions: list[int]) -> None:
        """One step of the match (it must not be over); ``actions[i]`` is in seat ``i``'s frame."""
        n, team, dist, walls, delta = self.n, self.team, self.dist, self.walls, self.delta
        pos, active, respawn, carrier = self.pos, self.active, self.respawn, self.carrier
        row_of, col_of, half_of = self.row_of, self.col_of, self.half_of
        before = self._flag_gain()
        # 1. moves; each seat's target field as it stood (its own stand's while it carries)
        moved = pos[:]
        fields = []
        for i in range(n):
            t = team[i]
            fields.append(dist[t] if carrier[1 - t] == i else dist[1 - t])
            if active[i]:
                q = pos[i] + delta[i][actions[i]]
                if not walls[q]:
                    moved[i] = q
        # 2. tags, judged at once on everyone's new cells: an exposed seat next to an active opponent
        tagged = [False] * n
        any_tag = False
        for i in range(n):
            p = moved[i]
            if active[i] and (carrier[1 - team[i]] == i or half_of[p] != team[i]):
                r, c = row_of[p], col_of[p]
                for j in self.rivals[i]:
                    q = moved[j]
                    if active[j] and abs(r - row_of[q]) + abs(c - col_of[q]) <= 1:
                        tagged[i] = any_tag = True
                        break
        if any_tag:
            for flag in (0, 1):
                if carrier[flag] >= 0 and tagged[carrier[flag]]:
                    carrier[flag] = -1
            for i in range(n):
                if tagged[i]:
                    moved[i] = self.spawns[i]
                    respawn[i] = self.respawn_delay + 1
        # 3. pick-ups, the lowest seat first
        picked = [False] * n
        stands = self.stands
        for flag in (0, 1):
            if carrier[flag] < 0:
                for i in self.team_seats[1 - flag]:
                    if active[i] and not tagged[i] and moved[i] == stands[flag]:
                        carrier[flag] = i
                        picked[i] = True
                        break
        # 4. captures: team t scores with the flag its seat carrier[1 - t] holds
        scored = [carrier[1 - t] >= 0 and moved[carrier[1 - t]] == stands[t] and carrier[t] < 0 for t in (0, 1)]
        for t in (0, 1):
            if scored[t]:
                carrier[1 - t] = -1
                self.captures[t] += 1
        # 5. respawns; the measures: the step toward the target a playing seat had, the target now
        toward, target, was = [], [], self.target_distance
        for i in range(n):
            p = moved[i]
            if not active[i]:
                respawn[i] -= 1
                if respawn[i] <= 0:
                    active[i] = True
                toward.append(0)
            elif tagged[i]:
                respawn[i] -= 1
                active[i] = False
                toward.append(0)
            else:
                toward.append(was[i] - fields[i][p])
            t = team[i]
            target.append(dist[t][p] if carrier[1 - t] == i else dist[1 - t][p])
        self.pos = moved
        self.t += 1
        self.tagged, self.picked, self.scored = tagged, picked, scored
        self.toward_target, self.target_distance = toward, target
        for t in (0, 1):
            if carrier[1 - t] >= 0:
                self.held_steps[t] += 1
        after = self._flag_gain()
        sd = self.stand_distance
        self.flag_progress = [after[t] + (sd if scored[t] else 0) - before[t] for t in (0, 1)]
        if self.captures[0] >= self.captures_to_win or self.captures[1] >= self.captures_to_win:
            self.done = True

    def _flag_gain(self) -> list[int]:
        """How far each team has brought the flag it carries from the opponents' stand toward its own."""
        carrier, dist, pos = self.carrier, self.dist, self.pos
        return [self.stand_distance - dist[t][pos[carrier[1 - t]]] if carrier[1 - t] >= 0 else 0 for t in (0, 1)]

    def team_scores(self) -> np.ndarray:
        """``float64[2]``: the batched engine's ``team_scores`` of this match."""
        c, held = self.captures, self.held_steps
        lead = c[0] - c[1] if c[0] != c[1] else held[0] - held[1]
        first = 1.0 if lead > 0 else 0.0 if lead < 0 else 0.5
        return np.array([first, 1.0 - first])

    def events(self) -> list[dict]:
        """The last step's tags, pick-ups and captures, as the rules report them."""
        if not (True in self.tagged or True in self.picked or True in self.scored):
            return []
        events = [{"kind": "tag", "seat": i} for i, x in enumerate(self.tagged) if x]
        events += [{"kind": "pickup", "seat": i} for i, x in enumerate(self.picked) if x]
        return events + [{"kind": "capture", "team": t} for t, x in enumerate(self.scored) if x]

    def write_measures(self, m: Any, ended: bool) -> None:
        """The measures the rules set after a step or a start (``m``: one match's rows), the
        outcome too when the match ``ended``; an array is written only when its values change."""
        written = self._written
        m.target_distance[:] = self.target_distance
        m.velocity_to_target[:] = self.toward_target
        if written.get("active") != self.active:
            m.active[:] = written["active"] = self.active[:]
        progress = self.flag_progress
        if written.get("object_progress") != progress:
            m.object_progress[:] = [progress[t] for t in self.team]
            written["object_progress"] = progress
        if ended:
            scores = self.team_scores().tolist()
            m.outcome[:] = [2.0 * scores[t] - 1.0 for t in self.team]
            written["outcome"] = True
        elif written.get("outcome") is not False:
            m.outcome[:] = 0.0
            written["outcome"] = False

    def forget_measures(self) -> None:
        """Someone else wrote the measures: the next :meth:`write_measures` writes every array."""
        self._written.clear()

    # --- what seats see -----------------------------------------------------------------------
    def observe(self) -> np.ndarray:
        """``float32[seats, obs_dim]``: the batched engine's ``observe()`` of this match."""
        n, team = self.n, self.team
        pos, active, carrier = self.pos, self.active, self.carrier
        row_of, col_of, half_of, frame_col = self.row_of, self.col_of, self.half_of, self.frame_col
        rel_row, rel_col = self._rel_row, self._rel_col
        per_capture, per_step = 1.0 / self.captures_to_win, 1.0 / self.respawn_delay
        c0, c1 = self.captures
        # per team: its flag home, the opponents' home, its captures and theirs, scaled
        teams = ((carrier[0] < 0, carrier[1] < 0, c0 * per_capture, c1 * per_capture),
                 (carrier[1] < 0, carrier[0] < 0, c1 * per_capture, c0 * per_capture))
        k0, k1 = carrier
        flag_at = (pos[k0] if k0 >= 0 else self.stands[0], pos[k1] if k1 >= 0 else self.stands[1])
        rows = []
        for i in range(n):
            f, p = team[i], pos[i]
            cell = self._cells[f][p] or self._cell(f, p)
            carrying = carrier[1 - f] == i
            pr, pc, fcols = row_of[p], frame_col[f][p], frame_col[f]
            home, away, own, enemy = teams[f]
            row = [active[i], cell[3], cell[4], carrying, home, away, cell[5],
                   0.0 if active[i] else self.respawn[i] * per_step, own, enemy]
            row += cell[0]
            # danger: each action's cell, exposed there, within 2 steps of an active opponent (one more
            # than 3 steps from the seat is more than 2 from every such cell)
            pcol = col_of[p]
            near = None
            for j in self.rivals[i]:
                if active[j]:
                    q = pos[j]
                    r, c = row_of[q], col_of[q]
                    if abs(pr - r) + abs(pcol - c) <= 3:
                        if near is None:
                            near = [(r, c)]
                        else:
                            near.append((r, c))
            if near is None:
                row += _NO_DANGER
            else:
                for dr, dc, dh in cell[2]:
                    if carrying or dh != f:
                        gap = 3
                        for r, c in near:
                            g = abs(dr - r) + abs(dc - c)
                            if g < gap:
                                gap = g
                        row.append(1.0 if gap <= 1 else 0.5 if gap == 2 else 0.0)
                    else:
                        row.append(0.0)
            enemy_at, own_at = flag_at[1 - f], flag_at[f]
            row += (rel_row[row_of[enemy_at] - pr], rel_col[fcols[enemy_at] - pc],
                    rel_row[row_of[own_at] - pr], rel_col[fcols[own_at] - pc])
            row += cell[1]
            for j in self.others[i]:
                q = pos[j]
                h = k0 == j or k1 == j
                row += (rel_row[row_of[q] - pr], rel_col[fcols[q] - pc], active[j], h, h or half_of[q] != team[j])
            rows.append(row)
        return np.array(rows, dtype=np.float32)

    def state(self) -> np.ndarray:
        """``float32[state_dim]``: the batched engine's ``state()`` of this match."""
        row_of, col_of, pos, carrier = self.row_of, self.col_of, self.pos, self.carrier
        to_row, to_col = 2.0 / (self.rows - 1), 2.0 / (self.cols - 1)
        per_capture, per_step = 1.0 / self.captures_to_win, 1.0 / self.respawn_delay
        state = self._wall_cells[:]
        for i in range(self.n):
            p = pos[i]
            state += (row_of[p] * to_row - 1.0, col_of[p] * to_col - 1.0, self.active[i],
                      carrier[1 - self.team[i]] == i, 0.0 if self.active[i] else self.respawn[i] * per_step)
        for k in (0, 1):
            at = pos[carrier[k]] if carrier[k] >= 0 else self.stands[k]
            state += (row_of[at] * to_row - 1.0, col_of[at] * to_col - 1.0, carrier[k] >= 0)
        state += (self.captures[0] * per_capture, self.captures[1] * per_capture)
        return np.array(state, dtype=np.float32)

