"""League operations: the library calls the ``arena-league`` command (and any web front end) are
thin layers over. They join the layers below: the registry (SQL), agent artifacts and
validation (policies/), the match engine (matchmaking/), the rating engine (rating/) and
replays, after Arena's "ranking among the base population" (Song et al., AAAI 2020).

Every match is played by a job (kind ``evaluate`` or ``rank``), queued for workers or run by the
command that queued it, which follows it wherever it runs (:func:`~arena_league.league.jobs.follow_job`).
An evaluation's matches get ids ``job_id * MATCH_IDS_PER_JOB + k``, so its match seeds (derived
from the match id and the seed) never repeat within a league. A placement's matches get ids
``0, 1, 2, ...`` under each seed it was given (see :func:`rank`), so its matches depend on the seed,
the entrant and the base only. Match keys are ``job:<job id>:<match id>``: unique in the league,
and a retried job stores each match once.

Submitted agents play inside the worker's inference sandbox (:mod:`arena_league.policies.sandbox`),
within the league's budgets (:mod:`arena_league.league.settings`); built-in scripted agents and
the members of frozen base populations play in the worker itself. A sandboxed agent whose call
fails forfeits the matches it has in flight (each stored as a loss, with the reason on its seat);
once it has forfeited ``forfeits.suspend_after`` matches in all, it is *suspended*, with the
reason its owner sees, and the job goes on without it (its remaining matches are skipped).
"""

from __future__ import annotations

import functools
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from arena_league import registry as reg
from arena_league.envs import game_spec
from arena_league.league.agents import latest_placements
from arena_league.league.home import did_you_mean, register_game
from arena_league.league.jobs import PROGRESS_EVERY, evaluation_payload, follow_job
from arena_league.league.leaderboards import (
    EntrantPlacement,
    FrozenRating,
    Leaderboard,
    compute_leaderboard,
    population_leaderboard,
)
from arena_league.league.populations import (
    base_to_import,
    ensure_population,
    game_population,
    require_population,
    shipped_populations,
)
from arena_league.league.quotas import enqueue_owned, live_job_limit
from arena_league.matchmaking import (
    AgentRef,
    MatchResult,
    MatchSpec,
    play_adaptive,
    play_matches,
    round_robin,
    specs_for_seatings,
)
from arena_league.registry import League
from arena_league.registry.errors import ArtifactTakenError
from arena_league.registry.jobs import live_jobs, lock_game, set_job_payload
from arena_league.replay import ReplayRecording

if TYPE_CHECKING:
    from arena_league.league.tokens import Identity

MATCH_IDS_PER_JOB = 2**20
#: Matches per pair of the round robin that rates a league-wide base before a placement.
BASE_ROUND_ROBIN_PER_PAIR = 4
#: ``rank(population=LEAGUE_WIDE)`` ranks against every other active agent of the game.
LEAGUE_WIDE = "league"
SCRIPTED_AGENTS = ("random", "heuristic")
_RECORD_EVERY = 256  # matches per registry write while a job plays

Progress = Callable[[int, int], None]


# --- league and games ------------------------------------------------------------------------------

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


def agent_ref(league: League, agent: reg.Agent, *, trusted: bool = False) -> AgentRef:
    """A reference the match engine can load in any process: sandboxed unless the agent is a
    built-in scripted one or ``trusted`` (a member of a frozen base population, see :func:`agent_refs`)."""
    action_type = (agent.meta or {}).get("action_type")
    if agent.kind == "scripted":
        return AgentRef("scripted", agent.meta["scripted"], agent.game_id, action_type)
    if agent.artifact is None:
        raise ValueError(f"agent {agent.name} ({agent.kind}) has no artifact to play with")
    path = reg.artifact_path(league.home, agent.artifact)
    kind = "onnx" if agent.artifact.format == "onnx" else "arena-policy"
    return AgentRef(kind, str(path), agent.game_id, action_type, sandboxed=not trusted)


def agent_refs(session: Any, league: League, agents: Sequence[reg.Agent]) -> dict[str, AgentRef]:
    """Name -> :func:`agent_ref` of each agent; members of the game's frozen populations (which
    passed the import gate at full size) are trusted to run in the worker, every other artifact
    runs in the sandbox."""
    games = {a.game_id for a in agents}
    frozen = {m.agent_id for game_id in games for population in reg.list_populations(session, game_id=game_id)
              if population.frozen for m in population.members}
    return {a.name: agent_ref(league, a, trusted=a.id in frozen and a.kind == "base") for a in agents}


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
    """What became of a submission. ``agent`` is the agent the bytes belong to: the name asked
    for when ``created``, else the agent that was already registered with the same bytes (which
    may have another name than ``requested``)."""

    agent: str
    game_id: str
    status: str
    created: bool
    digest: str
    reason: str | None = None
    log: str = ""
    seconds: float = 0.0
    requested: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "note": self.note}

    @property
    def note(self) -> str:
        """One line on what happened to the name asked for."""
        if self.created:
            if self.requested and self.requested != self.agent:
                return f"registered as {self.agent}: new bytes under {self.requested} make its next version"
            return "registered"
        if self.requested and self.requested != self.agent:
            return (f"these bytes are already agent {self.agent}; nothing new was registered as {self.requested} "
                    f"(rank {self.agent} instead, or submit different bytes)")
        return "already registered (same bytes)"


def reserved_name_reason(name: str) -> str | None:
    """Why ``name`` is kept for the league, or None when anyone may submit under it.

    Reserved: the built-in scripted agents of every game (``random@<game>``, ``heuristic@<game>``,
    see :func:`scripted_agent_name`), the members of the populations shipped under
    ``checkpoints/`` (registered when the league imports them), by their full names and by the
    short names boards show (``random``, a member without ``@<game>``), and the names of the agents
    people play as (``<owner>@<game>``, ``guest-...``) and any of a member's shape (``base-v<N>.``;
    see :mod:`arena_league.league.names`). The
    league itself still creates them (:func:`ensure_scripted_agents`, importing a shipped
    population, a person's first match); :func:`submit` refuses them.
    """
    from arena_league.envs import list_games
    from arena_league.league.names import human_name_reason, member_name_reason
    from arena_league.league.populations import shipped_member_names

    scripted, at, game = name.partition("@")
    if at and scripted in SCRIPTED_AGENTS and game in list_games():
        return f"{name} is the league's built-in {scripted} agent of {game}"
    if name in SCRIPTED_AGENTS:
        return f"{name} is the name boards show for the league's built-in {name} agents ({name}@<game>)"
    members = shipped_member_names()
    if name in members:
        return f"{name} is a member of a base population shipped with arena-league"
    # boards show members without @<game>: that short name would otherwise mean two agents
    if any(member.rpartition("@")[0] == name for member in members):
        return f"{name} is the name boards show for a member of a base population shipped with arena-league"
    return member_name_reason(name) or human_name_reason(name, list_games())


def _agent_with_bytes(league: League, game_id: str, digest: str, requested: str, start: float
                      ) -> SubmitResult | None:
    """The result of a submission whose bytes already are an agent of the game, or None."""
    with league.reading() as session:
        for existing in reg.find_agents_by_artifact(session, digest, game_id=game_id):
            return SubmitResult(existing.name, game_id, existing.status, False, digest, existing.reject_reason,
                                existing.validation_log or "", time.perf_counter() - start, requested=requested)
    return None


def submit(league: League, path: str | Path, game_id: str, name: str, *, owner: str | None = None,
           kind: str = "submission", metadata: Mapping[str, Any] | None = None) -> SubmitResult:
    """Validate an agent artifact and register it under ``name``, or its next version.

    Names follow :mod:`arena_league.league.versions`, as web uploads do: the game, the name and the
    file are checked before anything is read or stored (the name well formed, without a version
    suffix, not reserved, not another owner's; the file not empty). New bytes under a name
    ``owner`` already holds become its next version (``name:v2`` ...); the same bytes submitted
    again return the agent already registered for them (idempotent by content hash). An artifact
    that cannot be read safely (pickle, TorchScript, .pt2, over the size limit) or at all
    (truncated, corrupt) is refused with an error and nothing is stored. One that reads but fails
    validation (wrong spaces, non-finite outputs, a crash in its validation match) is stored and
    registered as *rejected*, with the reason and the validation log. Storing and registering are
    one transaction: when it fails (a database error, a full disk) the file it stored is removed again.
    """
    from arena_league.league.settings import sandbox_limits
    from arena_league.league.versions import artifact_files, check_submitted_name, refuse_empty, version_name
    from arena_league.policies import CorruptArtifactError, read_artifact, validate_submission
    from arena_league.policies.errors import artifact_error_class

    start = time.perf_counter()
    register_game(league, game_id)
    check_submitted_name(name)
    with league.reading() as session:
        version_name(session, name, game_id, owner)  # another owner's name is refused before reading
    refuse_empty(artifact_files(path))
    artifact = read_artifact(path)  # refuses unsafe, over-size and unreadable files before storing
    existing = _agent_with_bytes(league, game_id, artifact.digest, name, start)
    if existing is not None:
        return existing
    verdict = validate_submission(artifact, game_id, sandbox_limits=sandbox_limits(league))
    refusal = artifact_error_class(verdict.error, CorruptArtifactError)
    if refusal is not None:
        raise refusal(verdict.reason)  # unreadable (truncated, corrupt): refused, nothing stored
    status = "active" if verdict.ok else "rejected"
    try:
        with league.transaction() as session:
            # named under the write lock: a version submitted meanwhile makes this one the next
            versioned, version = version_name(session, name, game_id, owner)
            sha256 = store_validated(session, league, artifact)
            agent = reg.create_agent(session, versioned, game_id, kind, owner=owner, artifact_sha256=sha256,
                                     status="pending", metadata={**agent_metadata(metadata, artifact, verdict),
                                                                 "series": name, "version": version})
            reg.set_agent_status(session, agent, status, reason=verdict.reason, log=verdict.log)
    except ArtifactTakenError:
        # the same bytes were registered under another name meanwhile: answer as for a resubmission
        raced = _agent_with_bytes(league, game_id, artifact.digest, name, start)
        if raced is None:
            raise
        return raced
    return SubmitResult(versioned, game_id, status, True, artifact.digest, verdict.reason, verdict.log,
                        time.perf_counter() - start, requested=name)


def agent_metadata(metadata: Mapping[str, Any] | None, artifact: Any, verdict: Any) -> dict[str, Any]:
    """What an agent's row keeps of its artifact and validation (its kind, the action type)."""
    info = verdict.spec.as_dict() if verdict.spec else {}
    return {**dict(metadata or {}), "artifact_kind": artifact.kind,
            **({"action_type": info["action_type"]} if info.get("action_type") else {})}


def store_validated(session: Any, league: League, artifact: Any) -> str:
    """Store the bytes that were validated (not the file as it may be by now) in the league's
    artifact store; returns their address. A failure later in the transaction rolls it back, and
    the store removes the file it placed."""
    from arena_league.policies import write_artifact

    fmt = "onnx" if artifact.kind == "onnx" else "arena-policy"
    with tempfile.TemporaryDirectory() as scratch:
        source = artifact.content if fmt == "onnx" else write_artifact(artifact, Path(scratch) / "agent")
        return reg.store_artifact(session, league.home, source, fmt).sha256


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
    #: Matches not played because an agent in them was past its forfeits.
    skipped: int = 0
    #: Agent -> matches it forfeited in this evaluation.
    forfeits: dict[str, int] = field(default_factory=dict)
    #: Agent -> why this evaluation suspended it.
    suspended: dict[str, str] = field(default_factory=dict)
    #: Matches not played because the job reached its wall-time bound (``jobs.max_seconds``).
    not_played: int = 0
    #: Why the evaluation stopped before its plan was played (empty when it played it all).
    stop_reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class EvaluationPlan:
    """What an evaluation will play: each pair of ``agents`` topped up to ``matches_per_pair``
    matches (``already`` were played before, ``reserved`` more are planned by unfinished evaluation
    jobs), ``to_play`` matches in all, at most ``max_matches``."""

    game_id: str
    agents: list[str]
    matches_per_pair: int
    already: int
    to_play: int
    max_matches: int | None = None
    reserved: int = 0

    def describe(self) -> str:
        """One line saying what will be played and why."""
        n = len(self.agents)
        pairs = n * (n - 1) // 2
        others = f", {self.reserved} more planned by unfinished jobs" if self.reserved else ""
        why = (f"{pairs} pairs of {n} agents topped up to {self.matches_per_pair} matches per pair "
               f"({self.already} played before{others})")
        if self.to_play == 0:
            return (f"nothing to play on {self.game_id}: {why}; raise --matches-per-pair to play more (only the "
                    "matches played now are recorded)")
        capped = f", capped at {self.max_matches} by --max-matches" if self.max_matches is not None else ""
        return f"{self.to_play} matches to play on {self.game_id}: {why}{capped}"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _seatings_to_play(names: list[str], matches_per_pair: int, rows: list[dict[str, Any]],
                      max_matches: int | None, reserved: Mapping[tuple[str, ...], int] | None = None
                      ) -> list[tuple[str, ...]]:
    """The seatings that bring each pair of ``names`` to ``matches_per_pair``, counting the matches
    stored (``rows``) and those other jobs have planned and not stored yet (``reserved``)."""
    counts = _played_seatings(rows)
    for seating, n in (reserved or {}).items():
        counts[seating] = counts.get(seating, 0) + n
    seatings = round_robin(names, matches_per_pair, counts)
    return seatings if max_matches is None else seatings[:max_matches]


def _reserved_seatings(session: Any, game_id: str, names: list[str], rows: list[dict[str, Any]],
                       exclude_job_id: int | None = None) -> dict[tuple[str, ...], int]:
    """Matches per seating among ``names`` that the unfinished (queued or running) evaluation jobs
    of ``game_id`` have planned and not stored yet: their plan less what they stored (``rows``
    holds every stored match among ``names``, with its job)."""
    by_job: dict[int, list[dict[str, Any]]] = {}
    for row in rows:
        if row["job_id"] is not None:
            by_job.setdefault(row["job_id"], []).append(row)
    wanted = set(names)
    reserved: dict[tuple[str, ...], int] = {}
    for job in live_jobs(session, "evaluate", exclude_job_id=exclude_job_id):
        planned = _plan_of(job.payload or {}) if (job.payload or {}).get("game_id") == game_id else []
        counts: dict[tuple[str, ...], int] = {}
        for seating in planned:
            counts[seating] = counts.get(seating, 0) + 1
        stored = _played_seatings(by_job.get(job.id, []))
        for seating, n in counts.items():
            left = n - stored.get(seating, 0)
            if left > 0 and wanted.issuperset(seating):
                reserved[seating] = reserved.get(seating, 0) + left
    return reserved


def _plan_of(payload: Mapping[str, Any]) -> list[tuple[str, ...]]:
    """The seatings an evaluation job planned when it first ran (none before it ran)."""
    plan = payload.get("plan")
    if not plan:
        return []
    agents = plan["agents"]
    return [tuple(agents[i] for i in seating) for seating in plan["seatings"]]


def _evaluation_agents(session: Any, game_id: str, agents: Sequence[str] | None) -> list[str]:
    names = [a.name for a in _active_agents(session, game_id, agents)]
    if len(names) < 2:
        raise ValueError(f"{game_id} has {len(names)} active agent(s); an evaluation needs two. Submit agents "
                         f"with `arena-league submit PATH --game {game_id} --name NAME`")
    return names


def evaluation_plan(league: League, game_id: str, agents: Sequence[str] | None = None, *,
                    matches_per_pair: int = 10, max_matches: int | None = None) -> EvaluationPlan:
    """What :func:`evaluate` with these options would play now."""
    evaluation_payload(game_id, agents, matches_per_pair=matches_per_pair, max_matches=max_matches)
    register_game(league, game_id)
    with league.reading() as session:
        names = _evaluation_agents(session, game_id, agents)
        rows = reg.match_seat_rows(session, game_id, agents=names)
        reserved = _reserved_seatings(session, game_id, names, rows)
    to_play = len(_seatings_to_play(names, matches_per_pair, rows, max_matches, reserved))
    return EvaluationPlan(game_id, names, int(matches_per_pair), sum(_played_seatings(rows).values()), to_play,
                          max_matches, sum(reserved.values()))


def queue_evaluation(league: League, game_id: str, agents: Sequence[str] | None = None, *,
                     matches_per_pair: int = 10, seed: int = 0, backend: str = "inprocess",
                     workers: int | None = None, record: bool = False, max_matches: int | None = None,
                     priority: int = 0) -> int:
    """Queue a round robin among ``agents`` (default: every active agent of the game) that brings
    each pair to ``matches_per_pair`` matches (at most ``max_matches`` of them); returns the job id.

    The job plans its matches when it first runs (see :func:`handle_evaluate`), not here, so that
    jobs queued together and run one after the other each top up what the ones before played."""
    evaluation_payload(game_id, agents, matches_per_pair=matches_per_pair,
                       max_matches=max_matches)  # bad options fail before any write
    register_game(league, game_id)
    with league.transaction() as session:
        names = _evaluation_agents(session, game_id, agents)
        job = reg.enqueue(session, "evaluate", evaluation_payload(game_id, names, matches_per_pair=matches_per_pair,
                                                                  seed=seed, backend=backend, workers=workers,
                                                                  record=record, max_matches=max_matches),
                          priority=priority)
        return job.id


def evaluate(league: League, game_id: str, agents: Sequence[str] | None = None, *, matches_per_pair: int = 10,
             seed: int = 0, backend: str = "inprocess", workers: int | None = None, record: bool = False,
             max_matches: int | None = None, progress: Progress | None = None,
             log: Callable[[str], None] | None = None) -> EvaluationReport:
    """Queue an evaluation and wait for it (see :func:`queue_evaluation`): run here, or followed in
    the worker that took it (:func:`~arena_league.league.jobs.follow_job`); ``log`` first gets what
    will be played and why (:class:`EvaluationPlan`)."""
    if log is not None:
        log(evaluation_plan(league, game_id, agents, matches_per_pair=matches_per_pair,
                            max_matches=max_matches).describe())
    job_id = queue_evaluation(league, game_id, agents, matches_per_pair=matches_per_pair, seed=seed,
                              backend=backend, workers=workers, record=record, max_matches=max_matches,
                              priority=100)
    return EvaluationReport(**follow_job(league, job_id, job_handlers(progress), progress=progress, log=log))


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
        self.forfeits: dict[str, int] = {}
        with ctx.league.reading() as session:
            self.ids = {a.name: a.id for a in reg.list_agents(session, game_id=game_id)}

    def __call__(self, result: MatchResult) -> None:
        self.pending.append(result)
        self.played += 1
        self.steps += result.steps
        for agent in result.forfeit_of:
            self.forfeits[agent] = self.forfeits.get(agent, 0) + 1
        if len(self.pending) >= _RECORD_EVERY or result.forfeits:
            self.flush()  # a forfeit is stored at once: it may suspend its agent
        if self.progress is not None:
            self.progress(self.played, self.total)

    def flush(self) -> None:
        if not self.pending:
            return
        self.ctx.raise_if_lease_lost()
        records = [reg.MatchRecord(match_key(self.ctx.job.id, r.match_id), r.seed, [
            reg.SeatResult(self.ids[agent], team, score, outcome, None if r.positions is None else r.positions[i],
                           r.forfeit_of.get(agent))
            for i, (agent, team, score, outcome) in enumerate(zip(r.seats, r.teams, r.scores, r.outcomes))],
            r.replay_path, r.halves_summary()) for r in self.pending]
        with self.ctx.league.transaction() as session:
            stored = reg.record_matches(session, self.game_id, records, job_id=self.ctx.job.id)
        self.stored += sum(1 for s in stored if s.created)
        self.pending = []


@dataclass
class _Sandboxing:
    """How one job's agents play: the league's sandbox budgets, how many matches each sandboxed
    agent could still forfeit before it is suspended when the job began (its recorder counts the
    job's own forfeits), and the job's wall-time bound (``deadline``, a ``time.time()``)."""

    limits: Any
    suspend_after: int
    allowance: dict[str, int]
    max_seconds: int = 3600
    deadline: float = float("inf")

    @classmethod
    def of(cls, league: League, refs: Mapping[str, AgentRef], ids: Mapping[str, int]) -> _Sandboxing:
        """For the agents ``refs`` of one game, ``ids`` their registry ids."""
        from arena_league.league.settings import (
            job_max_seconds,
            league_settings,
            sandbox_limits,
            suspend_after,
        )

        values = league_settings(league)
        max_seconds = job_max_seconds(league, values)
        limit = suspend_after(league, values)
        sandboxed = [name for name, ref in refs.items() if ref.sandboxed]
        with league.reading() as session:
            counts = reg.forfeit_counts(session, [ids[name] for name in sandboxed])
        return cls(sandbox_limits(league, values), limit,
                   {name: max(0, limit - counts.get(ids[name], 0)) for name in sandboxed}, max_seconds,
                   time.time() + max_seconds)

    def play(self, specs: Sequence[MatchSpec], refs: Mapping[str, AgentRef], ctx: reg.JobContext,
             recorder: _Recorder, **options: Any) -> list[MatchResult]:
        """``play_matches`` under the budgets, storing through ``recorder``, beating the job's heart;
        each agent may forfeit what it had left when the job began, less the job's forfeits so far."""
        if self.out_of_time():
            return []
        return play_matches(specs, refs, sandbox_limits=self.limits, forfeit_limit=self.left(recorder),
                            heartbeat=ctx.heartbeat, on_result=recorder, deadline=self.deadline, **options)

    def left(self, recorder: _Recorder) -> dict[str, int]:
        """Forfeits each sandboxed agent may still make in this job."""
        return {name: self.allowance.get(name, 0) - recorder.forfeits.get(name, 0)
                for name in {*self.allowance, *recorder.forfeits}}

    def out_of_time(self) -> bool:
        """Whether the job has passed its wall-time bound."""
        return time.time() > self.deadline

    def not_played(self, specs: Sequence[MatchSpec], results: Sequence[MatchResult], recorder: _Recorder
                   ) -> tuple[int, str]:
        """The matches of ``specs`` without a result that the wall-time bound left unplayed (those of
        an agent past its forfeits were skipped for that), and why, in words."""
        if not self.out_of_time():
            return 0, ""
        done = {result.match_id for result in results}
        spent = {name for name, left in self.left(recorder).items() if left <= 0}
        count = sum(1 for spec in specs if spec.match_id not in done and not spent.intersection(spec.seats))
        if not count:
            return 0, ""
        return count, (f"the job reached its wall-time bound of {self.max_seconds} s (the setting jobs.max_seconds) "
                       f"after {len(done)} matches; {count} were not played")

    def suspend(self, league: League, forfeits: Mapping[str, int]) -> dict[str, str]:
        """Suspend each agent of ``forfeits`` that reached the limit; returns name -> reason."""
        suspended: dict[str, str] = {}
        if not forfeits:
            return suspended
        with league.transaction() as session:
            agents = [reg.require_agent(session, name) for name in forfeits]
            counts = reg.forfeit_counts(session, [agent.id for agent in agents])
            for agent in agents:
                count = counts.get(agent.id, 0)
                if count < self.suspend_after or agent.status != "active":
                    continue
                last = reg.agent_forfeits(session, agent, limit=1)
                reason = (f"suspended after forfeiting {count} matches (the league suspends at "
                          f"{self.suspend_after}); the last: it {last[0]['reason'] if last else 'failed'}")
                reg.set_agent_status(session, agent, "suspended", reason=reason)
                suspended[agent.name] = reason
        return suspended


def match_key(job_id: int, match_id: int) -> str:
    return f"job:{job_id}:{match_id}"


def _recording(league: League, payload: Mapping[str, Any]) -> ReplayRecording | None:
    if not payload.get("record"):
        return None
    path = Path(league.home) / "replays" / payload["game_id"]
    path.mkdir(parents=True, exist_ok=True)
    return ReplayRecording(path)


def handle_evaluate(ctx: reg.JobContext, progress: Progress | None = None,
                    play: MatchBackend | None = None) -> dict[str, Any]:
    """Job handler: play the round robin of the job's payload and store its matches.

    Overlapping evaluations agree: the first run of a job plans its seatings under the game's lock
    (:func:`_plan_seatings`), counting the matches stored and those other unfinished evaluation
    jobs planned and have not stored yet, and keeps the plan in its payload. So two jobs over the
    same pairs, run at once by two workers or one after the other, never give a pair more than it
    was asked; a retry replays its plan, the same matches under the same match ids and seeds.
    """
    start = time.perf_counter()
    payload = ctx.job.payload
    game_id = payload["game_id"]
    planned = payload.get("plan")
    with ctx.league.reading() as session:
        # a scheduled evaluation names no agents: every agent active when it first runs
        agents = _active_agents(session, game_id, planned["agents"] if planned else payload.get("agents"))
        if len(agents) < 2:
            raise ValueError(f"{game_id} has {len(agents)} active agent(s); an evaluation needs two")
        names = [a.name for a in agents]
        refs = agent_refs(session, ctx.league, agents)
        done_keys = reg.match_keys_of_job(session, ctx.job.id)
    seatings = _plan_of(payload) if planned else _plan_seatings(ctx, game_id, names)
    specs = specs_for_seatings(game_id, seatings, int(payload["seed"]), ctx.job.id * MATCH_IDS_PER_JOB)
    specs = [s for s in specs if match_key(ctx.job.id, s.match_id) not in done_keys]
    recorder = _Recorder(ctx, game_id, len(specs), progress)
    sandboxing = _Sandboxing.of(ctx.league, refs, recorder.ids)
    results = sandboxing.play(specs, refs, ctx, recorder, recording=_recording(ctx.league, payload),
                              **(play or MatchBackend()).options(payload))
    recorder.flush()
    suspended = sandboxing.suspend(ctx.league, recorder.forfeits)
    not_played, why = sandboxing.not_played(specs, results, recorder)
    return {"job_id": ctx.job.id, "game_id": game_id, "agents": names,
            "matches_per_pair": int(payload["matches_per_pair"]), "played": recorder.played,
            "stored": recorder.stored, "steps": recorder.steps, "seconds": round(time.perf_counter() - start, 3),
            "skipped": len(specs) - recorder.played - not_played, "forfeits": recorder.forfeits,
            "suspended": suspended, "not_played": not_played, "stop_reason": why}


def _plan_seatings(ctx: reg.JobContext, game_id: str, names: list[str]) -> list[tuple[str, ...]]:
    """Plan the job's seatings once, under the game's lock, and keep the plan in its payload."""
    payload = ctx.job.payload
    with ctx.league.transaction() as session:
        lock_game(session, game_id)  # planners of one game take turns, each seeing the plans before it
        rows = reg.match_seat_rows(session, game_id, agents=names, exclude_job_id=ctx.job.id)
        reserved = _reserved_seatings(session, game_id, names, rows, exclude_job_id=ctx.job.id)
        seatings = _seatings_to_play(names, int(payload["matches_per_pair"]), rows, payload.get("max_matches"),
                                     reserved)
        index = {name: i for i, name in enumerate(names)}
        set_job_payload(session, ctx.job, {**payload, "plan": {
            "agents": names, "seatings": [[index[a] for a in seating] for seating in seatings]}})
    return seatings


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
    """1 + the base agents rated above the entrant (:func:`~arena_league.rating.competition_ranks`)."""
    rank_lower: int
    """The best place its interval allows."""
    rank_upper: int
    """The worst place its interval allows."""
    percentile: float
    percentile_lower: float
    percentile_upper: float
    nash_score: float
    nash_mass: float
    level: float
    job_id: int
    seconds: float
    opponents: dict[str, dict[str, float]] = field(default_factory=dict)
    #: Matches the entrant forfeited in this placement (its calls failed in the sandbox).
    forfeits: int = 0
    #: Why the entrant was suspended by this placement, or None.
    suspended: str | None = None
    #: Matches this call played (0 when the placement was stored already); ``matches`` counts them all.
    played: int = 0
    #: Seed -> the placement's matches played under it (see :func:`rank`).
    seeds: dict[str, int] = field(default_factory=dict)
    #: True when the placement was read back from an earlier job (``job_id``) without playing.
    stored: bool = False
    #: Why the placement stopped: ``target`` (the rank interval narrowed to the target half-width),
    #: ``budget`` (the budget ran out first), ``more`` (the matches --more asked for were played),
    #: ``suspended`` (the entrant was suspended, or is past its forfeits) or ``time`` (the job reached
    #: its wall-time bound, ``jobs.max_seconds``; the placement is that of the matches played);
    #: ``stop_reason`` says it in words.
    stopped: str = ""
    stop_reason: str = ""
    #: What ``matches`` counts: ``"pairs"`` in a game played in pairs (two matches each, roles swapped),
    #: else ``"matches"``.
    unit: str = "matches"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def of(cls, result: Mapping[str, Any], *, stored: bool = False) -> RankReport:
        """The report of a rank job's result (which also keeps the placement's evidence)."""
        known = {f.name for f in fields(cls)}
        report = cls(**{key: value for key, value in result.items() if key in known})
        if stored:
            report.stored, report.played = True, 0
        return report


def base_population(league: League, game_id: str, entrant: str, population: str | None = None
                    ) -> tuple[str, list[str], np.ndarray | None]:
    """The base an entrant is ranked against: the population ``name`` or ``name:version`` of the
    game (its members' stored ratings when it is frozen with ratings), by default the game's own
    (:func:`~arena_league.league.populations.game_population`); a named population the league lacks
    but the package ships is imported first. ``population="league"`` takes every other active agent
    of the game instead. Returns (label, names, ratings or None)."""
    if population is None:
        population = game_population(league, game_id)
        if population is None:
            raise ValueError(f"{game_id} has no base population in this league and none is shipped; import or "
                             f"build one (`arena-league population import FOLDER`, `arena-league population "
                             f"build {game_id}`), or rank against every agent of the league with --league-wide")
    if population == LEAGUE_WIDE:
        with league.reading() as session:
            names = [a.name for a in reg.list_agents(session, game_id=game_id, status="active") if a.name != entrant]
        return "all active agents", names, None
    population, _ = ensure_population(league, game_id, population)
    with league.reading() as session:
        found = require_population(session, game_id, population)
        members = [(m.agent.name, (m.meta or {}).get("rating")) for m in found.members]
        names = [n for n, _ in members if n != entrant]
        ratings = [r for n, r in members if n != entrant]
        label = f"{found.name}:{found.version}"
        if found.frozen and all(r is not None for r in ratings):
            return label, names, np.asarray(ratings, dtype=float)
        return label, names, None


def _unmet_pairs(league: League, game_id: str, names: list[str]) -> int:
    """How many pairs of ``names`` have never met in a stored match."""
    with league.reading() as session:
        rows = reg.match_seat_rows(session, game_id, agents=names)
    met = {frozenset(k) for k in _played_seatings(rows)}
    return sum(frozenset((a, b)) not in met for i, a in enumerate(names) for b in names[i + 1:])


def _base_ratings(league: League, game_id: str, names: list[str], seed: int, progress: Progress | None,
                  unmet: int) -> np.ndarray:
    """Bradley-Terry ratings of the base agents from their stored matches among themselves,
    playing a short round robin first when ``unmet`` pairs have never met."""
    from arena_league.rating import OutcomeTable, bradley_terry

    if unmet:
        evaluate(league, game_id, names, matches_per_pair=BASE_ROUND_ROBIN_PER_PAIR, seed=seed, progress=progress)
    with league.reading() as session:
        rows = reg.match_seat_rows(session, game_id, agents=names)
    table = OutcomeTable.from_rows(rows, agents=names)
    counts = table.pair_counts()
    return np.asarray(bradley_terry(counts.wins, counts.draws), dtype=float)


def _entrant_game(league: League, agent: str, who: Identity | None = None,
                  missing: type[ValueError] = ValueError) -> str:
    """The game of the active agent ``agent`` that a placement is asked for (a two-team game);
    with ``who``, refused unless it is theirs to rank. An unknown agent raises ``missing``."""
    from arena_league.league.errors import ForbiddenError

    with league.reading() as session:
        found = reg.get_agent(session, agent)
        if found is None:
            every = [a.name for a in reg.list_agents(session)]
            raise missing(f"there is no agent {agent!r}.{did_you_mean(agent, every)} See `arena-league agents`")
        if who is not None and not who.may_manage(found.owner):
            raise ForbiddenError(f"{agent} is not yours to rank")
        game_id = _active_agents(session, found.game_id, [agent])[0].game_id
    if game_spec(game_id).n_teams != 2:
        raise ValueError(f"{game_id} has more than two teams; placement is for two-team games. Use "
                         f"`arena-league evaluate {game_id}` and an openskill leaderboard")
    return game_id


def rank(league: League, agent: str, *, budget: int = 200, population: str | None = None, seed: int = 0,
         target_half_width: float = 3.0, backend: str = "inprocess", more: int | None = None,
         progress: Progress | None = None, log: Callable[[str], None] | None = None) -> RankReport:
    """Place ``agent`` against its game's base population with adaptive opponent choice, storing
    every match; the rating has a 95% interval, the rank and percentile their intervals.

    The base is the game's own population by default (the league's newest frozen one, or the newest
    shipped, imported on first use), or ``population`` (``name[:version]``; a shipped one is
    imported on first use too), or, with
    ``population="league"``, every other active agent of the game: those are first rated by a
    round robin of :data:`BASE_ROUND_ROBIN_PER_PAIR` matches for each pair that never met, which
    counts against ``budget`` and is announced through ``log`` before it starts.

    Same seed, same result. A placement's matches depend on the seed, the entrant and the base only
    (the match with index ``k`` under seed ``s`` has the env seed of match ``k`` of seed ``s``; not
    the job id, nor the league's other matches), and the entrant's placement against a base (same
    label, members and ratings) is kept and grows:

    - the first ``rank`` plays under ``seed`` until the rank interval's half-width is at most
      ``target_half_width`` places (looked at from the 20th match on) or ``budget`` matches;
    - ``rank`` again with a seed the placement already holds returns the stored placement without
      playing (``stored`` is True, ``job_id`` the job that played it);
    - ``rank`` with a seed it does not hold adds evidence: the stored matches (every seed, in the
      order they were played) are replayed into the opponent chooser, then new matches are played
      under the new seed (indices from 0), at least 20 and at most ``budget``, stopping once the
      interval over all the matches reaches the target;
    - ``more=N`` plays exactly ``N`` more matches under ``seed`` (continuing its indices), also
      after the replayed evidence, whatever the interval: matches only grow.

    So the placement is a function of the entrant, the base and the seeds and ``more`` counts asked
    for, in their order; the leaderboard shows the newest. The Nash score is computed over every
    stored match of the entrant and the base. The job is followed wherever it runs (a server's
    worker may take it, see :func:`~arena_league.league.jobs.follow_job`); a queued or running
    placement asking the same is followed rather than queued twice."""
    from arena_league.league.settings import check_rank_budget

    check_rank_budget(league, budget, more)
    say = log or (lambda line: None)
    game_id = _entrant_game(league, agent)
    label, names, ratings = base_population(league, game_id, agent, population)
    if not names:
        raise ValueError(f"{game_id} has no base agents to rank {agent} against; import a base population "
                         "(`arena-league population import FOLDER`) or submit more agents")
    stored = None if ratings is None else _stored_placement(league, game_id, agent, label, names, ratings, seed, more)
    if stored is not None:
        return stored
    plays = f"{more} more matches" if more is not None else f"at most {budget} matches"
    say(f"ranking {agent} against {label} ({len(names)} agents), {plays}")
    if ratings is None:
        unmet = _unmet_pairs(league, game_id, names)
        round_robin = unmet * BASE_ROUND_ROBIN_PER_PAIR
        if round_robin >= budget and more is None:
            raise ValueError(f"ranking against {label} first needs a round robin of {round_robin} matches "
                             f"({unmet} pairs of its {len(names)} agents never met, {BASE_ROUND_ROBIN_PER_PAIR} "
                             f"matches each) before any placement match, over the budget of {budget}. Rank "
                             f"against the game's base population (leave out --league-wide), or raise --budget "
                             f"above {round_robin}")
        if round_robin:
            say(f"first a round robin of {round_robin} matches among {len(names)} agents ({unmet} pairs never "
                f"met), then {plays if more is not None else f'up to {budget - round_robin} placement matches'}")
            budget -= round_robin if more is None else 0
        ratings = _base_ratings(league, game_id, names, seed, progress, unmet)
        stored = _stored_placement(league, game_id, agent, label, names, ratings, seed, more)
        if stored is not None:
            return stored
    payload = {"game_id": game_id, "agent": agent, "population": population, "base": names, "base_label": label,
               "base_ratings": [float(r) for r in ratings], "budget": int(budget),
               "target_half_width": float(target_half_width), "seed": int(seed), "more": more, "backend": backend}
    with league.reading() as session:  # a lookup: no write lock, which a busy worker may hold
        job_id = _live_placement(session, payload)
    if job_id is None:
        with league.transaction() as session:
            job_id = reg.enqueue(session, "rank", payload, priority=100).id
    else:
        say(f"job {job_id} already places {agent} against {label} with seed {seed}; waiting for it")
    return RankReport.of(follow_job(league, job_id, job_handlers(progress), progress=progress, log=say))


def _stored_placement(league: League, game_id: str, agent: str, label: str, names: list[str], ratings: Any,
                      seed: int, more: int | None) -> RankReport | None:
    """The entrant's stored placement against this base when it already holds ``seed`` and no
    ``more`` is asked for (see :func:`rank`), else None."""
    if more is not None:
        return None
    with league.reading() as session:
        prior = _placement_evidence(session, game_id, agent, label, names, ratings)
    if prior is None or str(int(seed)) not in prior[1].get("seeds", {}):
        return None
    return RankReport.of(prior[1], stored=True)


def _placement_evidence(session: Any, game_id: str, agent: str, label: str, names: Sequence[str], ratings: Any,
                        exclude_job_id: int | None = None) -> tuple[int, dict[str, Any]] | None:
    """(job id, result) of the entrant's newest finished placement against the base ``label``, when
    that placement kept its evidence and was made against these members at these ratings; None when
    there is none (the next placement starts afresh)."""
    wanted = [float(r) for r in ratings]
    for job in reg.list_jobs(session, status="done", kind="rank"):  # newest first
        payload, result = job.payload or {}, job.result or {}
        if (job.id == exclude_job_id or payload.get("agent") != agent or payload.get("game_id") != game_id
                or payload.get("base_label") != label):
            continue
        same_base = list(payload.get("base") or []) == list(names) and payload.get("base_ratings") == wanted
        return (job.id, result) if same_base and "evidence" in result else None
    return None


def _live_placement(session: Any, payload: Mapping[str, Any]) -> int | None:
    """A queued or running rank job that asks for the same placement as ``payload`` (queued from the
    web, or by another terminal), or None."""
    same = ("agent", "game_id", "seed", "more", "budget", "target_half_width")
    for job in live_jobs(session, "rank"):
        other = job.payload or {}
        base_same = (other.get("base_label") == payload["base_label"] if "base_label" in other
                     else other.get("population") == payload["population"])
        if base_same and all(other.get(key) == payload[key] for key in same):
            return job.id
    return None


def queue_rank(league: League, agent: str, *, budget: int = 200, population: str | None = None, seed: int = 0,
               target_half_width: float = 3.0, more: int | None = None, who: Identity | None = None) -> int:
    """Queue a placement of ``agent`` against its game's base population (or ``population``, a
    frozen one with ratings) for a worker; returns the job id. The job finds the base when it runs
    (importing the shipped one on first use, which validates its members: agent code, never run in
    the caller's request). ``seed`` and ``more`` as in :func:`rank`: a seed the stored placement
    holds gives it back without playing. With ``who``, only the agent's owner (or an administrator) may,
    and the job counts against ``who``'s quota (:mod:`arena_league.league.quotas`)."""
    from arena_league.league.errors import NotFoundError
    from arena_league.league.settings import check_rank_budget

    check_rank_budget(league, budget, more)
    game_id = _entrant_game(league, agent, who, NotFoundError)
    limit = live_job_limit(league) if who is not None else None
    payload = {"game_id": game_id, "agent": agent, "population": population, "budget": int(budget),
               "target_half_width": float(target_half_width), "seed": int(seed), "more": more, "backend": "inprocess"}
    with league.transaction() as session:
        return enqueue_owned(session, who, "rank", payload, priority=60, limit=limit).id


def _resolve_base(ctx: reg.JobContext) -> dict[str, Any]:
    """A queued placement's base population, found (and imported, the first time) when it runs and
    kept in its payload, so that a retry places against the same base."""
    p = ctx.job.payload
    label, names, ratings = base_population(ctx.league, p["game_id"], p["agent"], p.get("population"))
    if ratings is None:
        raise ValueError(f"{label} has no frozen ratings to place {p['agent']} against; rank against the game's "
                         "base population, or from the command line with --league-wide")
    payload = {**p, "base": names, "base_label": label, "base_ratings": [float(r) for r in ratings],
               "base_seat_advantage": base_seat_advantage(ctx.league, p["game_id"], label)}
    with ctx.league.transaction() as session:
        set_job_payload(session, ctx.job, payload)
    return payload


def base_seat_advantage(league: League, game_id: str, label: str) -> list[float] | None:
    """The seat term (rating points per side) the base population ``label`` (``name:version``) was
    rated with, when its build fitted one; its members' ratings mean nothing without it."""
    from arena_league.league.populations import find_population

    with league.reading() as session:
        found = find_population(session, game_id, label)
        term = ((found.provenance or {}).get("figures") or {}).get("seat_term") if found is not None else None
    return None if term is None else [float(v) for v in term["advantage"]]


def handle_rank(ctx: reg.JobContext, progress: Progress | None = None,
                play: MatchBackend | None = None) -> dict[str, Any]:
    """Job handler: adaptive placement of an entrant, continuing its stored placement against the
    same base (see :func:`rank`); re-played from the start on a retry, which the engine's
    determinism makes exact and the match keys make idempotent. The result keeps the placement's
    evidence (seed, match index, opponent, the entrant's score of every match, in order) for the
    next placement to continue from."""
    from arena_league.rating import MIN_PLACEMENT_MATCHES, AdaptivePlacement, nash_averaging

    start = time.perf_counter()
    p = ctx.job.payload if "base" in ctx.job.payload else _resolve_base(ctx)
    game_id, agent, names = p["game_id"], p["agent"], list(p["base"])
    seed, more, target = int(p["seed"]), p.get("more"), float(p["target_half_width"])
    with ctx.league.reading() as session:
        prior = _placement_evidence(session, game_id, agent, p["base_label"], names, p["base_ratings"],
                                    exclude_job_id=ctx.job.id)
    if prior is not None and more is None and str(seed) in prior[1].get("seeds", {}):
        return {**prior[1], "stored": True, "played": 0, "seconds": round(time.perf_counter() - start, 3)}
    evidence = [list(e) for e in prior[1]["evidence"]] if prior is not None else []
    with ctx.league.reading() as session:
        refs = agent_refs(session, ctx.league, _active_agents(session, game_id, [agent, *names]))
    cap = int(more) if more is not None else int(p["budget"])
    chooser = AdaptivePlacement(np.asarray(p["base_ratings"]), budget=len(evidence) + cap, target_half_width=target,
                                min_matches=len(evidence) + (cap if more is not None else MIN_PLACEMENT_MATCHES),
                                seat_advantage=p.get("base_seat_advantage"))
    index = {name: k for k, name in enumerate(names)}
    for entry in evidence:  # (seed, match id, opponent, score[, the entrant's side])
        chooser.record(index[entry[2]], float(entry[3]), int(entry[4]) if len(entry) > 4 else 0)
    recorder = _Recorder(ctx, game_id, cap, progress)
    sandboxing = _Sandboxing.of(ctx.league, refs, recorder.ids)

    where = (play or MatchBackend()).options(p)

    def play_specs(specs):
        return sandboxing.play(specs, refs, ctx, recorder, **where)

    first = sum(1 for e in evidence if e[0] == seed)  # this seed's matches so far: its next index
    results = play_adaptive(agent, names, chooser, play_specs, game_id, league_seed=seed, first_match_id=first,
                            max_matches=cap + 1)
    recorder.flush()
    suspended = sandboxing.suspend(ctx.league, recorder.forfeits)
    for r in results:
        side = r.teams[r.seats.index(agent)]
        evidence.append([seed, r.match_id, next(s for s in r.seats if s != agent), float(r.team_scores()[side]), side])
    placement = chooser.placement
    stopped, why = _stop_reason(chooser, len(results), cap, more, target, suspended.get(agent),
                                sandboxing.max_seconds if sandboxing.out_of_time() else None)
    # Nash score of the entrant in the meta-game of base + entrant (logit win rates, smoothed by PSEUDO_COUNT)
    everyone = [*names, agent]
    with ctx.league.reading() as session:
        rows = reg.match_seat_rows(session, game_id, agents=everyone)
    nash_p, nash_scores = _nash_of(rows, everyone, nash_averaging)
    opponents: dict[str, dict[str, float]] = {}
    seeds: dict[str, int] = {}
    for used, _, other, score, *_ in evidence:
        entry = opponents.setdefault(other, {"matches": 0, "score": 0.0})
        entry["matches"] += 1
        entry["score"] += score
        seeds[str(used)] = seeds.get(str(used), 0) + 1
    return {"agent": agent, "game_id": game_id, "base": p["base_label"], "base_size": len(names),
            "matches": len(evidence), "rating": placement.rating, "lower": placement.lower,
            "upper": placement.upper, "rank": placement.rank, "rank_lower": placement.rank_lower,
            "rank_upper": placement.rank_upper, "percentile": placement.percentile,
            "percentile_lower": placement.percentile_lower, "percentile_upper": placement.percentile_upper,
            "nash_score": float(nash_scores[-1]), "nash_mass": float(nash_p[-1]), "level": placement.level,
            "job_id": ctx.job.id, "seconds": round(time.perf_counter() - start, 3), "opponents": opponents,
            "forfeits": recorder.forfeits.get(agent, 0), "suspended": suspended.get(agent), "played": len(results),
            "seeds": seeds, "stored": False, "stopped": stopped, "stop_reason": why, "evidence": evidence,
            "unit": "pairs" if game_spec(game_id).paired else "matches"}


def _stop_reason(chooser: Any, played: int, cap: int, more: int | None, target: float, suspended: str | None,
                 out_of_time: int | None = None) -> tuple[str, str]:
    """Why a placement stopped, as a code and in words (see :attr:`RankReport.stopped`);
    ``out_of_time``: the job's wall-time bound, when it was reached."""
    total = chooser.matches
    if played < cap and not chooser.done:
        if out_of_time is not None and not suspended:
            return "time", (f"the job reached its wall-time bound of {out_of_time} s (the setting jobs.max_seconds) "
                            f"after {played} new matches; {cap - played} more of its {cap} were not played, and the "
                            f"placement is that of the {total} matches played")
        if suspended:
            return "suspended", f"the entrant was suspended after {played} new matches ({suspended})"
        return "suspended", (f"the entrant's matches were skipped after {played} new matches: it is past its "
                             "forfeits (see `arena-league agent NAME`)")
    if more is not None:
        return "more", f"played the {cap} more matches asked for (--more {cap}), {total} in all"
    if chooser.matches >= chooser.min_matches and chooser.rank_half_width <= target:
        return "target", (f"the rank interval reached the target half-width of {target:g} places after {total} "
                          "matches")
    return "budget", (f"the budget of {cap} matches ran out before the rank interval reached the target half-width "
                      f"of {target:g} places (it is {chooser.rank_half_width:g})")


def _nash_of(rows: list[dict[str, Any]], agents: list[str], nash_averaging) -> tuple[np.ndarray, np.ndarray]:
    from arena_league.rating import PSEUDO_COUNT, OutcomeTable

    counts = OutcomeTable.from_rows(rows, agents=agents).pair_counts()
    return nash_averaging(counts.logit_payoff(pseudo_count=PSEUDO_COUNT))


# --- leaderboards ----------------------------------------------------------------------------------

def leaderboard(league: League, game_id: str, method: str = "bt", *, population: str | None = None,
                rounds: int = 100, seed: int = 0, save: bool = True, import_shipped: bool = True,
                log: Callable[[str], None] | None = None) -> Leaderboard:
    """The leaderboard of ``game_id`` by ``method`` (bt, elo, openskill, nash or alpharank); its
    ratings are kept as a snapshot in the registry.

    ``population`` says whose board it is:

    - None: with ``method="bt"``, the game's base population
      (:func:`~arena_league.league.populations.game_population`, which imports the shipped
      ``base-v1`` on first use unless ``import_shipped`` is False); with another method, or for a
      game without a base, every agent;
    - ``"league"`` (:data:`LEAGUE_WIDE`): every agent of the game, re-rated from the stored matches;
    - ``name`` or ``name:version``: that population of the game.

    The board of a population frozen with its members' ratings, by ``"bt"``, is Arena's ranking
    against it (:func:`~arena_league.league.leaderboards.population_leaderboard`): the members at
    their frozen ratings and intervals, every other active or retired agent of the game at its
    latest placement against that population (the result of its newest finished ``rank`` job
    against it), or pending until it has one. Any other board re-rates its agents (the
    population's members, or every agent) from the matches stored among them. ``log`` hears of a
    shipped population imported first.
    """
    game_spec(game_id)
    imports = population is None and method == "bt" and import_shipped
    with league.reading() as session:
        known = reg.get_game(session, game_id) is not None
    if not known and not (imports and shipped_populations(game_id)):
        raise ValueError(_no_board(game_id, method))
    if population is None and method == "bt":
        if imports and log is not None and (shipped := base_to_import(league, game_id)) is not None:
            log(f"importing {shipped} of {game_id}, shipped with arena-league (first use: every member is "
                "validated once)")
        population = game_population(league, game_id, import_shipped=import_shipped)
    scope = None if population in (None, LEAGUE_WIDE) else population
    with league.reading() as session:
        found = require_population(session, game_id, scope) if scope is not None else None
        frozen = _frozen_ratings(found) if found is not None and method == "bt" else None
        if found is not None:
            scope = f"{found.name}:{found.version}"
        if found is not None and frozen is None:
            agents = [m.agent for m in found.members]
        else:
            agents = [a for a in reg.list_agents(session, game_id=game_id) if a.status in ("active", "retired")]
            if frozen is not None:
                listed = {a.name for a in agents}
                agents += [m.agent for m in found.members if m.agent.name not in listed]
        info = {a.name: {"kind": a.kind, "owner": a.owner, "status": a.status} for a in agents}
        ids = {a.name: a.id for a in agents}
        rows = reg.match_seat_rows(session, game_id, agents=list(info))
        placements = _placements(session, game_id, scope, set(info)) if frozen is not None else {}
        population_id = found.id if found is not None else None
        seat_term = ((found.provenance or {}).get("figures") or {}).get("seat_term") if found is not None else None
    if frozen is not None:
        board = population_leaderboard(rows, info, game_id, scope, frozen, placements, seat_term=seat_term)
    else:
        board = compute_leaderboard(rows, info, game_id, method, rounds=rounds, seed=seed, population=scope)
    if save:
        with league.transaction() as session:
            snapshot_population = (session.get(reg.Population, population_id)
                                   if board.basis == "population" else None)
            reg.write_rating_snapshot(session, game_id, method, [
                reg.RatingRow(ids[r.agent], r.rating, r.lower, r.upper, r.rank_lower, r.rank_upper, r.matches,
                              extra={"status": r.status, "rank": r.rank})
                for r in board.rows if r.rating is not None and np.isfinite(r.rating)],
                population=snapshot_population, scope="placements" if snapshot_population else scope or "all",
                params={"rounds": rounds, "seed": seed, "basis": board.basis})
    return board


def _no_board(game_id: str, method: str) -> str:
    """Why a game the league has never seen has no board, and what makes one."""
    shipped = shipped_populations(game_id)
    if shipped:
        return (f"{game_id} has no agents in this league yet, so its {method} board is empty; `arena-league "
                f"leaderboard {game_id}` imports the shipped base population {shipped[-1]} and shows it")
    return (f"{game_id} has no agents in this league yet and no base population ships for it; submit agents "
            f"(`arena-league submit PATH --game {game_id} --name NAME`), then play them (`arena-league evaluate "
            f"{game_id}`)")


def _frozen_ratings(population: reg.Population) -> dict[str, FrozenRating] | None:
    """The members' ratings (and intervals, where stored) of a frozen population whose every member
    carries a rating in its membership metadata; None otherwise."""
    if not population.frozen:
        return None
    ratings = {}
    for member in population.members:
        meta = member.meta or {}
        if meta.get("rating") is None:
            return None
        lower, upper = meta.get("rating_lower"), meta.get("rating_upper")
        ratings[member.agent.name] = FrozenRating(float(meta["rating"]), None if lower is None else float(lower),
                                                  None if upper is None else float(upper))
    return ratings


def _placements(session: Any, game_id: str, population: str, agents: set[str]) -> dict[str, EntrantPlacement]:
    """Agent -> the result of its newest finished ``rank`` job against ``population`` of ``game_id``."""
    from arena_league.rating import Placement

    fields = ("rating", "lower", "upper", "rank", "rank_lower", "rank_upper", "percentile", "percentile_lower",
              "percentile_upper", "matches", "level")
    return {agent: EntrantPlacement(Placement(**{k: result[k] for k in fields}), job_id)
            for agent, (result, job_id) in latest_placements(session, game_id, base=population).items()
            if agent in agents and all(k in result for k in fields)}


# --- matches -------------------------------------------------------------------------------------

# --- worker ----------------------------------------------------------------------------------------

class _JobProgress:
    """A job's progress callback: the caller's (a progress bar) and, at most every
    :data:`PROGRESS_EVERY` seconds and at the end, the job's row, where any web server sees it."""

    def __init__(self, ctx: reg.JobContext, progress: Progress | None) -> None:
        self.ctx = ctx
        self.progress = progress
        self.written = 0.0

    def __call__(self, done: int, total: int) -> None:
        if self.progress is not None:
            self.progress(done, total)
        now = time.monotonic()
        if now - self.written >= PROGRESS_EVERY or done >= total:
            self.written = now
            try:
                reg.set_job_progress(self.ctx.league, self.ctx.job, {"done": int(done), "total": int(total)})
            except reg.LeaseLostError:
                self.ctx.lease_lost.set()  # cancelled, or taken by another worker: stop now
                raise


@dataclass(frozen=True)
class MatchBackend:
    """Where a worker plays its jobs' matches: ``"inprocess"`` (the default: as each job asks),
    ``"process"`` (a process pool of ``workers``) or ``"ray"`` (the tasks of a Ray cluster at
    ``address``, default ``RAY_ADDRESS`` or a local instance). A job stores its matches exactly once
    whatever plays them (match keys), and a submitted agent plays in the inference sandbox on
    whichever process or node plays its matches."""

    backend: str = "inprocess"
    address: str | None = None
    workers: int | None = None

    def __post_init__(self) -> None:
        from arena_league.matchmaking import BACKENDS

        if self.backend not in BACKENDS:
            raise ValueError(f"unknown match backend {self.backend!r}; valid: {', '.join(BACKENDS)}")
        if self.address is not None and self.backend != "ray":
            raise ValueError("a Ray address is for --backend ray; add it, or leave --address out")

    def options(self, payload: Mapping[str, Any]) -> dict[str, Any]:
        """``play_matches`` options for a job: the worker's backend when it names one beyond the
        default, else the job's own (``payload["backend"]``)."""
        if self.backend == "inprocess":
            return {"backend": payload.get("backend", "inprocess"), "workers": payload.get("workers")}
        return {"backend": self.backend, "workers": self.workers, "ray_address": self.address}


def job_handlers(progress: Progress | None = None, play: MatchBackend | None = None
                 ) -> dict[str, Callable[[reg.JobContext], Any]]:
    """The job kinds a league worker runs: evaluations, placements, uploads to validate, replays
    to record, shipped populations to import, social trees to verify and to preview; ``play`` says
    where evaluations and placements play their matches (default: as each job asks)."""
    from arena_league.league.matches import handle_replay
    from arena_league.league.populations import handle_import
    from arena_league.league.trees import handle_preview, handle_verify
    from arena_league.league.uploads import handle_validate
    from arena_league.policies.threads import torch_threads

    def on_one_thread(handler: Callable[[reg.JobContext, Progress | None], Any]) -> Callable[[reg.JobContext], Any]:
        # a job runs many tiny batched forwards: one thread beats OpenMP's hand-offs
        def run(ctx: reg.JobContext) -> Any:
            with torch_threads(1):
                return handler(ctx, _JobProgress(ctx, progress))
        return run

    where = play or MatchBackend()
    return {"evaluate": on_one_thread(functools.partial(handle_evaluate, play=where)),
            "rank": on_one_thread(functools.partial(handle_rank, play=where)),
            "validate": on_one_thread(handle_validate), "replay": on_one_thread(handle_replay),
            "import": on_one_thread(handle_import), "verify": on_one_thread(handle_verify),
            "preview": on_one_thread(handle_preview)}
