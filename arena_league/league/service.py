"""League operations: the library calls the ``arena-league`` command (and any web front end) are
thin layers over. They join the layers below: the registry (SQL), agent artifacts and
validation (policies/), the match engine (matchmaking/), the rating engine (rating/) and
replays, after Arena's "ranking among the base population" (Song et al., AAAI 2020).

Every match is played by a job (kind ``evaluate`` or ``rank``), queued for workers or run at
once in the caller's process. A job's matches get ids ``job_id * MATCH_IDS_PER_JOB + k``, so match
seeds (derived from the match id and the league seed) never repeat within a league, and keys
``job:<job id>:<match id>``, so a retried job stores each match once.
"""

from __future__ import annotations

import json
import shutil
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from arena_league import registry as reg
from arena_league.envs import game_spec
from arena_league.matchmaking import (
    AgentRef,
    MatchResult,
    play_adaptive,
    play_matches,
    round_robin,
    specs_for_seatings,
)
from arena_league.registry import League
from arena_league.replay import ReplayRecording

MATCH_IDS_PER_JOB = 2**20
SCRIPTED_AGENTS = ("random", "heuristic")
_RECORD_EVERY = 256  # matches per registry write while a job plays

Progress = Callable[[int, int], None]


# --- league and games ------------------------------------------------------------------------------

def open_home(home: str | Path | None = None, url: str | None = None) -> League:
    """Open (and create if needed) the league at ``home`` / ``url`` (``ARENA_LEAGUE_HOME``,
    ``ARENA_LEAGUE_DB``, default ``~/.arena-league``)."""
    return reg.open_league(url, home)


def register_game(league: League, game_id: str) -> None:
    """Make ``game_id`` known to the league (an unknown id raises, listing the valid ones)."""
    spec = game_spec(game_id)
    with league.transaction() as session:
        reg.ensure_game(session, game_id, spec.n_teams, spec.players_per_team)


def scripted_agent_name(game_id: str, scripted: str) -> str:
    return f"{scripted}@{game_id}"


def ensure_scripted_agents(league: League, game_id: str) -> list[str]:
    """Register the built-in scripted agents (random, heuristic) of ``game_id``; returns their names."""
    register_game(league, game_id)
    names = []
    with league.transaction() as session:
        for scripted in SCRIPTED_AGENTS:
            name = scripted_agent_name(game_id, scripted)
            if reg.get_agent(session, name) is None:
                reg.create_agent(session, name, game_id, "scripted", owner="arena-league", status="active",
                                 metadata={"scripted": scripted})
            names.append(name)
    return names


def agent_ref(league: League, agent: reg.Agent) -> AgentRef:
    """A reference the match engine can load in any process."""
    action_type = (agent.meta or {}).get("action_type")
    if agent.kind == "scripted":
        return AgentRef("scripted", agent.meta["scripted"], agent.game_id, action_type)
    if agent.artifact is None:
        raise ValueError(f"agent {agent.name} ({agent.kind}) has no artifact to play with")
    path = reg.artifact_path(league.home, agent.artifact)
    kind = "onnx" if agent.artifact.format == "onnx" else "arena-policy"
    return AgentRef(kind, str(path), agent.game_id, action_type)


def _active_agents(session, game_id: str, names: Sequence[str] | None) -> list[reg.Agent]:
    if names is None:
        return reg.list_agents(session, game_id=game_id, status="active")
    agents = []
    for name in names:
        agent = reg.require_agent(session, name)
        if agent.game_id != game_id:
            raise ValueError(f"agent {name} plays {agent.game_id}, not {game_id}")
        if agent.status != "active":
            why = f" ({agent.reject_reason})" if agent.reject_reason else ""
            raise ValueError(f"agent {name} is {agent.status}{why}; only active agents play")
        agents.append(agent)
    return agents


# --- submissions ---------------------------------------------------------------------------------

@dataclass
class SubmitResult:
    """What became of a submission."""

    agent: str
    game_id: str
    status: str
    created: bool
    digest: str
    reason: str | None = None
    log: str = ""
    seconds: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def submit(league: League, path: str | Path, game_id: str, name: str, *, owner: str | None = None,
           kind: str = "submission", metadata: Mapping[str, Any] | None = None) -> SubmitResult:
    """Validate an agent artifact and register it under ``name``.

    An artifact that cannot be read safely (pickle, TorchScript, .pt2, over the size limit) or at
    all (truncated, corrupt) is refused with an error and nothing is stored. One that reads but fails validation
    (wrong spaces, non-finite outputs, a crash in its validation match) is stored and registered as
    *rejected*, with the reason and the validation log. The same bytes submitted again return the
    agent already registered for them (idempotent by content hash).
    """
    from arena_league.policies import (
        CorruptArtifactError,
        load_agent,
        read_artifact,
        validate_submission,
        write_artifact,
    )

    start = time.perf_counter()
    register_game(league, game_id)
    artifact = read_artifact(path)  # refuses unsafe, over-size and unreadable files before storing
    with league.reading() as session:
        for existing in reg.find_agents_by_artifact(session, artifact.digest, game_id=game_id):
            return SubmitResult(existing.name, game_id, existing.status, False, artifact.digest,
                                existing.reject_reason, existing.validation_log or "", time.perf_counter() - start)
        reg.refuse_taken_name(session, name)  # before anything is stored
    try:
        load_agent(artifact, game_id)
    except CorruptArtifactError:
        raise  # unreadable (truncated, corrupt): refused, nothing stored
    except Exception:  # noqa: S110 - readable but unfit (spaces...): validation rejects it with the log
        pass
    verdict = validate_submission(artifact, game_id)
    status = "active" if verdict.ok else "rejected"
    info = verdict.spec.as_dict() if verdict.spec else {}
    meta = {**dict(metadata or {}), "artifact_kind": artifact.kind,
            **({"action_type": info["action_type"]} if info.get("action_type") else {})}
    fmt = "onnx" if artifact.kind == "onnx" else "arena-policy"
    with tempfile.TemporaryDirectory() as scratch, league.transaction() as session:
        # store the bytes that were validated, not the file as it may be by now
        source = artifact.content if fmt == "onnx" else write_artifact(artifact, Path(scratch) / "agent")
        stored = reg.store_artifact(session, league.home, source, fmt)
        agent = reg.create_agent(session, name, game_id, kind, owner=owner, artifact_sha256=stored.sha256,
                                 status="pending", metadata=meta)
        reg.set_agent_status(session, agent, status, reason=verdict.reason, log=verdict.log)
    return SubmitResult(name, game_id, status, True, artifact.digest, verdict.reason, verdict.log,
                        time.perf_counter() - start)


# --- evaluation jobs -------------------------------------------------------------------------------

@dataclass
class EvaluationReport:
    """A finished evaluation job."""

    job_id: int
    game_id: str
    agents: list[str]
    matches_per_pair: int
    played: int
    stored: int
    steps: int
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def queue_evaluation(league: League, game_id: str, agents: Sequence[str] | None = None, *,
                     matches_per_pair: int = 10, seed: int = 0, backend: str = "inprocess",
                     workers: int | None = None, record: bool = False, priority: int = 0) -> int:
    """Queue a round robin among ``agents`` (default: every active agent of the game) that brings
    each pair to ``matches_per_pair`` matches; returns the job id."""
    evaluation_payload(game_id, agents, matches_per_pair=matches_per_pair)  # bad options fail before any write
    register_game(league, game_id)
    with league.transaction() as session:
        names = [a.name for a in _active_agents(session, game_id, agents)]
        if len(names) < 2:
            raise ValueError(f"{game_id} has {len(names)} active agent(s); an evaluation needs two. Submit agents "
                             f"with `arena-league submit PATH --game {game_id} --name NAME`")
        job = reg.enqueue(session, "evaluate", evaluation_payload(game_id, names, matches_per_pair=matches_per_pair,
                                                                  seed=seed, backend=backend, workers=workers,
                                                                  record=record), priority=priority)
        return job.id


def evaluation_payload(game_id: str, agents: Sequence[str] | None, *, matches_per_pair: int = 10, seed: int = 0,
                       backend: str = "inprocess", workers: int | None = None, record: bool = False
                       ) -> dict[str, Any]:
    """The payload of an ``evaluate`` job, queued now or by a schedule (``agents`` None: every agent
    active when the job runs). :func:`handle_evaluate` reads it."""
    if matches_per_pair < 1:
        raise ValueError(f"matches_per_pair must be at least 1, not {matches_per_pair}")
    return {"game_id": game_id, "agents": None if agents is None else list(agents),
            "matches_per_pair": int(matches_per_pair), "seed": int(seed), "backend": backend, "workers": workers,
            "record": bool(record)}


def evaluate(league: League, game_id: str, agents: Sequence[str] | None = None, *, matches_per_pair: int = 10,
             seed: int = 0, backend: str = "inprocess", workers: int | None = None, record: bool = False,
             progress: Progress | None = None) -> EvaluationReport:
    """Queue an evaluation and run it here and now (see :func:`queue_evaluation`)."""
    job_id = queue_evaluation(league, game_id, agents, matches_per_pair=matches_per_pair, seed=seed,
                              backend=backend, workers=workers, record=record, priority=100)
    result = reg.run_job_now(league, job_id, job_handlers(progress))
    return EvaluationReport(**result)


def _played_seatings(rows: list[dict[str, Any]]) -> dict[tuple[str, ...], int]:
    """Matches per seating (the agent of team 0, team 1, ...) from seat rows."""
    seatings: dict[tuple[str, ...], int] = {}
    current: dict[int, str] = {}
    last = None
    for row in [*rows, {"match_id": None}]:
        if row["match_id"] != last and current:
            key = tuple(current[t] for t in sorted(current))
            seatings[key] = seatings.get(key, 0) + 1
            current = {}
        last = row["match_id"]
        if row["match_id"] is not None:
            current.setdefault(row["team"], row["agent"])
    return seatings


class _Recorder:
    """Stores a job's match results in batches, checking the job still holds its lease."""

    def __init__(self, ctx: reg.JobContext, game_id: str, total: int, progress: Progress | None) -> None:
        self.ctx = ctx
        self.game_id = game_id
        self.total = total
        self.progress = progress
        self.pending: list[MatchResult] = []
        self.played = 0
        self.stored = 0
        self.steps = 0
        with ctx.league.reading() as session:
            self.ids = {a.name: a.id for a in reg.list_agents(session, game_id=game_id)}

    def __call__(self, result: MatchResult) -> None:
        self.pending.append(result)
        self.played += 1
        self.steps += result.steps
        if len(self.pending) >= _RECORD_EVERY:
            self.flush()
        if self.progress is not None:
            self.progress(self.played, self.total)

    def flush(self) -> None:
        if not self.pending:
            return
        self.ctx.raise_if_lease_lost()
        records = [reg.MatchRecord(match_key(self.ctx.job.id, r.match_id), r.seed, [
            reg.SeatResult(self.ids[agent], team, score, outcome, None if r.positions is None else r.positions[i])
            for i, (agent, team, score, outcome) in enumerate(zip(r.seats, r.teams, r.scores, r.outcomes))],
            r.replay_path) for r in self.pending]
        with self.ctx.league.transaction() as session:
            stored = reg.record_matches(session, self.game_id, records, job_id=self.ctx.job.id)
        self.stored += sum(1 for s in stored if s.created)
        self.pending = []


def match_key(job_id: int, match_id: int) -> str:
    return f"job:{job_id}:{match_id}"


def _recording(league: League, payload: Mapping[str, Any]) -> ReplayRecording | None:
    if not payload.get("record"):
        return None
    path = Path(league.home) / "replays" / payload["game_id"]
    path.mkdir(parents=True, exist_ok=True)
    return ReplayRecording(path)


def handle_evaluate(ctx: reg.JobContext, progress: Progress | None = None) -> dict[str, Any]:
    """Job handler: play the round robin of the job's payload and store its matches."""
    start = time.perf_counter()
    payload = ctx.job.payload
    game_id = payload["game_id"]
    with ctx.league.reading() as session:
        # a scheduled evaluation names no agents: every agent active when it runs
        agents = _active_agents(session, game_id, payload.get("agents"))
        if len(agents) < 2:
            raise ValueError(f"{game_id} has {len(agents)} active agent(s); an evaluation needs two")
        names = [a.name for a in agents]
        refs = {a.name: agent_ref(ctx.league, a) for a in agents}
        rows = reg.match_seat_rows(session, game_id, agents=names, exclude_job_id=ctx.job.id)
        done_keys = reg.match_keys_of_job(session, ctx.job.id)
    seatings = round_robin(names, int(payload["matches_per_pair"]), _played_seatings(rows))
    specs = specs_for_seatings(game_id, seatings, int(payload["seed"]), ctx.job.id * MATCH_IDS_PER_JOB)
    specs = [s for s in specs if match_key(ctx.job.id, s.match_id) not in done_keys]
    recorder = _Recorder(ctx, game_id, len(specs), progress)
    play_matches(specs, refs, backend=payload.get("backend", "inprocess"), workers=payload.get("workers"),
                 recording=_recording(ctx.league, payload), on_result=recorder)
    recorder.flush()
    return {"job_id": ctx.job.id, "game_id": game_id, "agents": names,
            "matches_per_pair": int(payload["matches_per_pair"]), "played": recorder.played,
            "stored": recorder.stored, "steps": recorder.steps, "seconds": round(time.perf_counter() - start, 3)}


# --- ranking an entrant ----------------------------------------------------------------------------

@dataclass
class RankReport:
    """An entrant placed against a base population."""

    agent: str
    game_id: str
    base: str
    base_size: int
    matches: int
    rating: float
    lower: float
    upper: float
    rank: int
    rank_best: int
    rank_worst: int
    percentile: float
    percentile_lower: float
    percentile_upper: float
    nash_score: float
    nash_mass: float
    level: float
    job_id: int
    seconds: float
    opponents: dict[str, dict[str, float]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def base_population(league: League, game_id: str, entrant: str, population: str | None = None
                    ) -> tuple[str, list[str], np.ndarray | None]:
    """The base an entrant is ranked against: the named population (``name`` or ``name:version``;
    its members' stored ratings when it is frozen with ratings), else every other active agent of the
    game. Returns (label, names, ratings or None)."""
    with league.reading() as session:
        if population is not None:
            found = _population_of(session, game_id, population)
            if found is None:
                known = ", ".join(f"{p.name}:{p.version}" for p in reg.list_populations(session, game_id=game_id))
                raise ValueError(f"no population {population!r} for {game_id}; known: {known or 'none'}. Import "
                                 f"one with `arena-league population import FOLDER` (shipped ones lie under "
                                 f"checkpoints/{game_id}/)")
            if found.game_id != game_id:
                raise ValueError(f"population {population} is of {found.game_id}, not {game_id}")
            members = [(m.agent.name, (m.meta or {}).get("rating")) for m in found.members]
            names = [n for n, _ in members if n != entrant]
            ratings = [r for n, r in members if n != entrant]
            label = f"{found.name}:{found.version}"
            if found.frozen and all(r is not None for r in ratings):
                return label, names, np.asarray(ratings, dtype=float)
            return label, names, None
        names = [a.name for a in reg.list_agents(session, game_id=game_id, status="active") if a.name != entrant]
    return "all active agents", names, None


def _base_ratings(league: League, game_id: str, names: list[str], seed: int, progress: Progress | None
                  ) -> np.ndarray:
    """Bradley-Terry ratings of the base agents from their stored matches among themselves,
    playing a short round robin first where pairs have never met."""
    from arena_league.rating import OutcomeTable, bradley_terry

    with league.reading() as session:
        rows = reg.match_seat_rows(session, game_id, agents=names)
    played = _played_seatings(rows)
    met = {frozenset(k) for k in played}
    if any(frozenset((a, b)) not in met for i, a in enumerate(names) for b in names[i + 1:]):
        evaluate(league, game_id, names, matches_per_pair=4, seed=seed, progress=progress)
        with league.reading() as session:
            rows = reg.match_seat_rows(session, game_id, agents=names)
    table = OutcomeTable.from_rows(rows, agents=names)
    counts = table.pair_counts()
    return np.asarray(bradley_terry(counts.wins, counts.draws), dtype=float)


def rank(league: League, agent: str, *, budget: int = 200, population: str | None = None, seed: int = 0,
         target_half_width: float = 3.0, backend: str = "inprocess", progress: Progress | None = None
         ) -> RankReport:
    """Place ``agent`` against its game's base population with adaptive opponent choice, storing
    every match; the rating has a 95% interval, the rank and percentile their intervals."""
    with league.reading() as session:
        entrant = _active_agents(session, reg.require_agent(session, agent).game_id, [agent])[0]
        game_id = entrant.game_id
    if game_spec(game_id).n_teams != 2:
        raise ValueError(f"{game_id} has more than two teams; placement is for two-team games. Use "
                         f"`arena-league evaluate {game_id}` and an openskill leaderboard")
    label, names, ratings = base_population(league, game_id, agent, population)
    if not names:
        raise ValueError(f"{game_id} has no base agents to rank {agent} against; register scripted agents "
                         "(`arena-league quickstart`) or import a base population")
    if ratings is None:
        ratings = _base_ratings(league, game_id, names, seed, None)
    with league.transaction() as session:
        job = reg.enqueue(session, "rank", {
            "game_id": game_id, "agent": agent, "base": names, "base_label": label,
            "base_ratings": [float(r) for r in ratings], "budget": int(budget),
            "target_half_width": float(target_half_width), "seed": int(seed), "backend": backend}, priority=100)
        job_id = job.id
    return RankReport(**reg.run_job_now(league, job_id, job_handlers(progress)))


def handle_rank(ctx: reg.JobContext, progress: Progress | None = None) -> dict[str, Any]:
    """Job handler: adaptive placement of an entrant (re-played from the start on a retry, which the
    engine's determinism makes exact and the match keys make idempotent)."""
    from arena_league.rating import AdaptivePlacement, nash_averaging

    start = time.perf_counter()
    p = ctx.job.payload
    game_id, agent, names = p["game_id"], p["agent"], list(p["base"])
    with ctx.league.reading() as session:
        refs = {a.name: agent_ref(ctx.league, a) for a in _active_agents(session, game_id, [agent, *names])}
    chooser = AdaptivePlacement(np.asarray(p["base_ratings"]), budget=int(p["budget"]),
                                target_half_width=float(p["target_half_width"]))
    recorder = _Recorder(ctx, game_id, int(p["budget"]), progress)

    def play(specs):
        return play_matches(specs, refs, backend=p.get("backend", "inprocess"), on_result=recorder)

    results = play_adaptive(agent, names, chooser, play, game_id, league_seed=int(p["seed"]),
                            first_match_id=ctx.job.id * MATCH_IDS_PER_JOB, max_matches=int(p["budget"]) + 1)
    recorder.flush()
    placement = chooser.placement
    # Nash score of the entrant in the meta-game of base + entrant (logit win rates, smoothed by PSEUDO_COUNT)
    everyone = [*names, agent]
    with ctx.league.reading() as session:
        rows = reg.match_seat_rows(session, game_id, agents=everyone)
    nash_p, nash_scores = _nash_of(rows, everyone, nash_averaging)
    opponents: dict[str, dict[str, float]] = {}
    for r in results:
        mine = r.seats.index(agent)
        other = next(s for s in r.seats if s != agent)
        entry = opponents.setdefault(other, {"matches": 0, "score": 0.0})
        entry["matches"] += 1
        entry["score"] += r.scores[mine]
    return {"agent": agent, "game_id": game_id, "base": p["base_label"], "base_size": len(names),
            "matches": len(results), "rating": placement.rating, "lower": placement.lower,
            "upper": placement.upper, "rank": placement.rank, "rank_best": placement.rank_best,
            "rank_worst": placement.rank_worst, "percentile": placement.percentile,
            "percentile_lower": placement.percentile_lower, "percentile_upper": placement.percentile_upper,
            "nash_score": float(nash_scores[-1]), "nash_mass": float(nash_p[-1]), "level": placement.level,
            "job_id": ctx.job.id, "seconds": round(time.perf_counter() - start, 3), "opponents": opponents}


def _nash_of(rows: list[dict[str, Any]], agents: list[str], nash_averaging) -> tuple[np.ndarray, np.ndarray]:
    from arena_league.rating import PSEUDO_COUNT, OutcomeTable

    counts = OutcomeTable.from_rows(rows, agents=agents).pair_counts()
    return nash_averaging(counts.logit_payoff(pseudo_count=PSEUDO_COUNT))


# --- leaderboards ----------------------------------------------------------------------------------

def leaderboard(league: League, game_id: str, method: str = "bt", *, population: str | None = None,
                rounds: int = 100, seed: int = 0, save: bool = True):
    """The leaderboard of ``game_id`` from its stored matches (all agents, or one population's
    members), by ``method``: bt, elo, openskill, nash or alpharank. The ratings are kept as a
    snapshot in the registry."""
    from arena_league.league.leaderboards import compute_leaderboard

    game_spec(game_id)
    with league.reading() as session:
        if reg.get_game(session, game_id) is None:
            raise ValueError(f"no matches of {game_id} in this league yet; play some with "
                             f"`arena-league evaluate {game_id}`")
        if population is not None:
            _, names, _ = base_population(league, game_id, "", population)
            agents = [reg.require_agent(session, n) for n in names]
        else:
            agents = [a for a in reg.list_agents(session, game_id=game_id) if a.status in ("active", "retired")]
        info = {a.name: {"kind": a.kind, "owner": a.owner, "status": a.status} for a in agents}
        ids = {a.name: a.id for a in agents}
        rows = reg.match_seat_rows(session, game_id, agents=list(info))
    board = compute_leaderboard(rows, info, game_id, method, rounds=rounds, seed=seed)
    if save:
        with league.transaction() as session:
            reg.write_rating_snapshot(session, game_id, method, [
                reg.RatingRow(ids[r.agent], r.rating, r.lower, r.upper, r.rank, r.rank_worst, r.matches)
                for r in board.rows if r.rating is not None and np.isfinite(r.rating)],
                scope=population or "all", params={"rounds": rounds, "seed": seed})
    return board


# --- matches -------------------------------------------------------------------------------------

def recent_matches(league: League, game_id: str, *, agent: str | None = None, limit: int = 20) -> list[dict[str, Any]]:
    """The last ``limit`` matches of a game (optionally those of one agent), newest first."""
    with league.reading() as session:
        agent_id = reg.require_agent(session, agent).id if agent else None
        matches = reg.list_matches(session, game_id, agent_id=agent_id)[-limit:]
        return [{"match_key": m.match_key, "seed": m.seed, "replay": m.replay_path,
                 "created_at": m.created_at.isoformat(timespec="seconds"),
                 "seats": [{"seat": s.seat, "agent": s.agent.name, "team": s.team, "score": s.score,
                            "outcome": s.outcome, "position": s.position} for s in m.seats]}
                for m in reversed(matches)]


# --- populations -----------------------------------------------------------------------------------

POPULATION_MANIFEST = "population.json"


def list_populations(league: League, game_id: str | None = None) -> list[dict[str, Any]]:
    """Every population of the league (or of ``game_id``): name, version, game, frozen, member count."""
    with league.reading() as session:
        return [{"name": p.name, "version": p.version, "game_id": p.game_id, "frozen": p.frozen,
                 "members": len(p.members)} for p in reg.list_populations(session, game_id=game_id)]


def export_population(league: League, population: str, destination: str | Path) -> Path:
    """Write a population to a folder: ``population.json`` (name, version, game, provenance, members
    with their metadata) and each member's artifact under ``agents/``."""
    name, _, version = population.partition(":")
    dest = Path(destination)
    with league.reading() as session:
        found = reg.get_population(session, name, int(version) if version else None)
        if found is None:
            raise ValueError(f"no population {population!r}; see `arena-league population list`")
        if dest.exists() and any(dest.iterdir()):
            raise ValueError(f"{dest} exists and is not empty; export into a new folder")
        (dest / "agents").mkdir(parents=True, exist_ok=True)
        members = []
        for member in found.members:
            agent = member.agent
            entry = {"name": agent.name, "kind": agent.kind, "metadata": member.meta or {},
                     "agent_metadata": agent.meta or {}}
            if agent.artifact is not None:
                source = reg.artifact_path(league.home, agent.artifact)
                target = dest / "agents" / (agent.name + (".onnx" if agent.artifact.format == "onnx" else ""))
                if source.is_dir():
                    shutil.copytree(source, target)
                else:
                    shutil.copy2(source, target)
                entry["artifact"] = str(target.relative_to(dest))
                entry["format"] = agent.artifact.format
            members.append(entry)
        manifest = {"name": found.name, "version": found.version, "game_id": found.game_id, "frozen": found.frozen,
                    "provenance": found.provenance or {}, "members": members}
    (dest / POPULATION_MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n")
    return dest


#: Where the base populations shipped with the package lie: ``checkpoints/<game>/<name>/``.
SHIPPED_POPULATIONS = Path(__file__).resolve().parents[2] / "checkpoints"


def shipped_population(game_id: str, name: str = "base-v1") -> Path | None:
    """The folder of the population ``name`` shipped for ``game_id``, or None."""
    folder = SHIPPED_POPULATIONS / game_id / name
    return folder if (folder / POPULATION_MANIFEST).is_file() else None


def _population_of(session: Any, game_id: str, population: str) -> reg.Population | None:
    """``name:version`` (whatever its game), or, for a bare ``name``, this game's latest version of it:
    every game's import of ``base-v1`` takes the same name with a new version."""
    name, _, version = population.partition(":")
    if version:
        if not version.isdigit():
            raise ValueError(f"population {population!r}: the version after ':' must be a number, e.g. {name}:1")
        return reg.get_population(session, name, int(version))
    return next((p for p in reversed(reg.list_populations(session, game_id=game_id)) if p.name == name), None)


def ensure_population(league: League, game_id: str, population: str = "base-v1") -> tuple[str, bool]:
    """``population`` (``name`` or ``name:version``) of ``game_id`` in ``league``; a shipped one
    (:func:`shipped_population`) is imported when the league lacks it. Returns (``name:version``,
    whether it was imported now); a population neither registered nor shipped raises, naming the fix."""
    name, _, version = population.partition(":")
    with league.reading() as session:
        found = _population_of(session, game_id, population)
        known = ", ".join(f"{p.name}:{p.version}" for p in reg.list_populations(session, game_id=game_id))
    if found is not None:
        if found.game_id != game_id:
            raise ValueError(f"population {population} is of {found.game_id}, not {game_id}")
        return f"{found.name}:{found.version}", False
    folder = shipped_population(game_id, name) if not version else None
    if folder is None:
        raise ValueError(f"no population {population!r} for {game_id}; known: {known or 'none'}. Import one with "
                         f"`arena-league population import FOLDER` or build it with `arena-league population build "
                         f"{game_id}`")
    return import_population(league, folder), True


def import_population(league: League, source: str | Path, *, name: str | None = None) -> str:
    """Register a population folder written by :func:`export_population` (or shipped under
    ``checkpoints/<game>/<name>/``): its members become agents of kind ``base`` and the population is
    frozen. Members already registered with the same bytes are reused. Returns ``name:version``."""
    src = Path(source)
    manifest_path = src / POPULATION_MANIFEST
    if not manifest_path.is_file():
        raise ValueError(f"{src} has no {POPULATION_MANIFEST}; point at a folder made by `population export`")
    manifest = json.loads(manifest_path.read_text())
    game_id = manifest["game_id"]
    register_game(league, game_id)
    label = name or manifest["name"]
    with league.transaction() as session:
        population = reg.create_population(session, label, game_id, provenance=manifest.get("provenance") or {})
        for member in manifest["members"]:
            agent = reg.get_agent(session, member["name"])
            if agent is None:
                sha = None
                if member.get("artifact"):
                    stored = reg.store_artifact(session, league.home, src / member["artifact"], member["format"])
                    sha = stored.sha256
                kind = "scripted" if member["kind"] == "scripted" else "base"
                agent = reg.create_agent(session, member["name"], game_id, kind, owner=manifest.get("name"),
                                         artifact_sha256=sha, status="active",
                                         metadata=member.get("agent_metadata") or {})
            reg.add_population_member(session, population, agent, member.get("metadata") or {})
        reg.freeze_population(session, population)
        return f"{population.name}:{population.version}"


# --- worker ----------------------------------------------------------------------------------------

def job_handlers(progress: Progress | None = None) -> dict[str, Callable[[reg.JobContext], Any]]:
    """The job kinds a league worker runs."""
    from arena_league.policies.threads import torch_threads

    def on_one_thread(handler: Callable[[reg.JobContext, Progress | None], Any]) -> Callable[[reg.JobContext], Any]:
        # a job runs many tiny batched forwards: one thread beats OpenMP's hand-offs
        def run(ctx: reg.JobContext) -> Any:
            with torch_threads(1):
                return handler(ctx, progress)
        return run

    return {"evaluate": on_one_thread(handle_evaluate), "rank": on_one_thread(handle_rank)}
