"""The JSON API under ``/api``: games, leaderboards, agents and their uploads, placements, jobs and
their live progress, matches and their replays, social trees (checked, verified, previewed and
kept), and an administrator's schedules and populations.

Reads are open to anyone; every write needs a bearer token (:mod:`.auth`) and queues a job (agent
code never runs in a request). Errors are ``{"detail": "..."}`` with 400 (bad input), 401 (no or a
bad token), 403 (not yours), 404 (no such thing, or another owner's private data), 413 (an upload
over the size limit) or 429 (too many uploads).
"""

from __future__ import annotations

import asyncio
import json
import time
from typing import Annotated, Any

from fastapi import APIRouter, Body, File, Form, Query, Request, UploadFile
from fastapi.responses import Response, StreamingResponse
from pydantic import BaseModel, Field

from arena_league import league as ops
from arena_league.league import Identity
from arena_league.web.deps import Method, RowId, Viewer, Writer, league_of

__all__ = ["router"]

class Error(BaseModel):
    detail: str = Field(description="what went wrong, and the fix, in one line")


#: Every error the API answers, documented with its one-line body.
ERRORS: dict[int | str, dict[str, Any]] = {
    status: {"model": Error, "description": text} for status, text in (
        (400, "bad input (a bad name, game or file set)"), (401, "no token, or an unknown or revoked one"),
        (403, "another owner's agent, or an administrator's task"),
        (404, "no such thing, or another owner's private data"), (413, "an upload over the size limit"),
        (422, "a request that does not fit this schema"), (429, "too many uploads lately"))}

router = APIRouter(prefix="/api", responses=ERRORS)
#: Longest a progress stream stays open.
EVENTS_SECONDS = 3600.0
_EVENTS_POLL = 0.5


class Game(BaseModel):
    game_id: str
    teams: int
    players_per_team: int
    action_types: list[str]
    summary: str
    base_shipped: bool = Field(description="a base population of this game ships with arena-league")
    base_imported: list[dict[str, Any]] = Field(description="the game's frozen populations in this league")
    options: list[dict[str, Any]] = Field(description="the keyword options the game takes: name, type, bounds "
                                                      "(low, high, open_ends) or choices, default, meaning, accepts")


class Queued(BaseModel):
    job: int = Field(description="the queued job; follow it at /api/jobs/{job}")


class Uploaded(BaseModel):
    name: str = Field(description="the version reserved: NAME for the first upload, NAME:vK after (when the bytes "
                                  "are an agent already, the job drops it and its result names that agent)")
    version: int
    status: str = Field(description="pending until its validation job has run")
    job: int


class JobState(BaseModel):
    id: int
    kind: str
    state: str = Field(description="queued, running, done, failed or cancelled")
    progress: dict[str, Any] | None = Field(description="{'done': n, 'total': m, 'label': text}: while it runs, how "
                                                         "far it got; once it finished, a full bar and a label "
                                                         "saying where it stopped and why")
    result: Any = None
    error: str | None = None
    what: str = ""
    game_id: str | None = None
    agent: str | None = None
    finished: bool
    summary: str = Field("", description="what the job found or made, in words")
    links: list[dict[str, str]] = Field([], description="{'text', 'href'} of what the job made: the agent's page, "
                                                         "the match and its replay, the board")


class RankRequest(BaseModel):
    budget: int = Field(200, description="at most this many matches: from 2 to the league's setting rank.max_budget "
                                         "(5000 unless its operator changed it)")
    seed: int = Field(0, ge=0, le=2**31, description="a seed the agent's stored placement holds returns it without "
                                                     "playing; another adds evidence to it")
    more: int | None = Field(None, ge=1, description="play this many more matches under the seed after the stored "
                                                     "placement: its matches only grow")


class TreeSpec(BaseModel):
    game: str = Field(description="the game id the tree is for")
    spec: dict[str, Any] = Field(description="the social tree: a node with 'scheme', 'reward', 'children' ...")


class TreeSave(TreeSpec):
    name: str = Field(min_length=1, max_length=64, description="a name for the tree")


class TreeVerify(TreeSpec):
    samples: int = Field(64, ge=4, le=512, description="paired episodes to sample (at least 4 to estimate a sign)")
    seed: int = Field(0, ge=0, le=2**31)


class TreePreview(TreeSpec):
    seed: int = Field(0, ge=0, le=2**31)


class ScheduleRequest(BaseModel):
    name: str = Field(min_length=1, max_length=128)
    game: str
    every: int | None = Field(None, ge=60, description="seconds between runs (or give cron)")
    cron: str | None = Field(None, description="5 fields, UTC (or give every)")
    matches_per_pair: int = Field(10, ge=1, le=1000)


def _admin(who: Identity) -> None:
    if not who.admin:
        raise ops.ForbiddenError("only an administrator's token may do this")


@router.get("/me", summary="who the presented token belongs to")
def me(who: Writer) -> dict[str, Any]:
    return {"owner": who.owner, "admin": who.admin}


@router.get("/health", summary="the league's health: its job workers (alive, restarts) and the queue's length")
def health(request: Request) -> dict[str, Any]:
    workers = request.app.state.workers.health()
    return {"ok": workers["alive"] == workers["started_here"], "workers": workers,
            "jobs": ops.waiting_jobs(league_of(request))}


@router.get("/games", response_model=list[Game], summary="every game, and its base populations")
def games(request: Request) -> list[dict[str, Any]]:
    return ops.games_view(league_of(request))


@router.get("/games/{game}/leaderboard", summary="the game's leaderboard (the `leaderboard --json` document)",
            response_class=Response, responses={200: {"content": {"application/json": {"schema": {"type": "object"}}},
                                                      "description": "the board: rows with rating and rank "
                                                                     "intervals; while the game's shipped base "
                                                                     "population is being imported, `importing` "
                                                                     "names the job"}})
def game_leaderboard(request: Request, game: str,
                     method: Method = "bt"
                     ) -> Response:
    league = league_of(request)
    importing = ops.base_import(league, game) if method == "bt" and game in ops.game_ids() else None
    if importing is not None:  # the board the league has, and the import of the shipped base under way
        board = request.app.state.boards.board(league, game, method)
        return Response(json.dumps({**board, "importing": importing}, allow_nan=False), media_type="application/json")
    # computed once per state of the game, encoded once: a cached board is bytes off the shelf
    return Response(request.app.state.boards.board_json(league, game, method), media_type="application/json")


@router.post("/games/{game}/population", response_model=Queued, status_code=202,
             summary="import the game's shipped base population (administrators)")
def import_population(request: Request, game: str, who: Writer) -> dict[str, int]:
    _admin(who)
    return {"job": ops.queue_import(league_of(request), game, who=who)}


@router.post("/agents", response_model=Uploaded, status_code=202,
             summary="upload an agent: one .onnx (with its .onnx.data), or an arena-policy folder's files")
def upload(request: Request, who: Writer, game: Annotated[str, Form(description="the game id it plays")],
           name: Annotated[str, Form(description="the agent's name (new bytes under it make NAME:v2 ...)")],
           file: Annotated[list[UploadFile], File(description="model.onnx (+ model.onnx.data), or manifest.json "
                                                               "+ weights.safetensors (+ README.md)")]
           ) -> dict[str, Any]:
    return ops.upload_agent(league_of(request), who, game, name, [(f.filename or "", f.file) for f in file])


@router.get("/agents/{name}", summary="an agent: status, reason, kind, owner, versions, placements")
def agent(request: Request, name: str, viewer: Viewer) -> dict[str, Any]:
    view = ops.agent_view(league_of(request), name, viewer=viewer, boards=request.app.state.boards)
    return {k: v for k, v in view.items() if k not in ("validation_log", "forfeits")}


@router.get("/agents/{name}/log", summary="the validation log and forfeits (the owner and administrators)")
def agent_log(request: Request, name: str, viewer: Viewer) -> dict[str, Any]:
    return ops.agent_log(league_of(request), name, viewer)


@router.post("/agents/{name}/rank", response_model=Queued, status_code=202,
             summary="queue a placement against the game's base population (the owner)")
def rank(request: Request, name: str, who: Writer, options: Annotated[RankRequest | None, Body()] = None
         ) -> dict[str, int]:
    options = options or RankRequest()
    league = league_of(request)
    return {"job": ops.queue_rank(league, ops.resolve_agent(league, name), budget=options.budget, seed=options.seed,
                                  more=options.more, who=who)}


@router.post("/agents/{name}/reinstate", summary="let a suspended agent play again (administrators)")
def reinstate(request: Request, name: str, who: Writer) -> dict[str, Any]:
    _admin(who)
    return ops.reinstate_agent(league_of(request), name)


@router.get("/jobs/{job_id}", response_model=JobState, summary="a job's state, progress and result")
def job(request: Request, job_id: RowId) -> dict[str, Any]:
    return ops.job_view(league_of(request), job_id)


@router.get("/jobs/{job_id}/events", summary="a job's progress as server-sent events, until it ends",
            response_class=StreamingResponse,
            responses={200: {"content": {"text/event-stream": {}}, "description": "`progress` events, then `done`"}})
async def job_events(request: Request, job_id: RowId) -> StreamingResponse:
    league = league_of(request)
    first = await asyncio.to_thread(ops.job_view, league, job_id)  # 404 before the stream starts

    async def events() -> Any:
        view, last, started = first, None, time.monotonic()
        while True:
            state = (view["state"], json.dumps(view["progress"], sort_keys=True))
            if state != last:
                last = state
                yield f"event: progress\ndata: {json.dumps(view)}\n\n"
            if view["finished"]:
                yield f"event: done\ndata: {json.dumps(view)}\n\n"
                return
            if await request.is_disconnected() or time.monotonic() - started > EVENTS_SECONDS:
                return
            await asyncio.sleep(_EVENTS_POLL)
            view = await asyncio.to_thread(ops.job_view, league, job_id)

    return StreamingResponse(events(), media_type="text/event-stream", headers={"Cache-Control": "no-cache"})


@router.get("/matches/{match_id}", summary="a match: game, seats, outcome, whether it has a replay")
def match(request: Request, match_id: RowId) -> dict[str, Any]:
    return ops.match_view(league_of(request), match_id)


@router.get("/matches/{match_id}/replay", summary="the match's recorded replay, as frames of its top-down scene")
def match_replay(request: Request, match_id: RowId,
                 half: Annotated[int | None, Query(ge=0, le=1, description="a pair's half: 0 or 1")] = None
                 ) -> dict[str, Any]:
    return ops.match_replay(league_of(request), match_id, half)


@router.post("/matches/{match_id}/replay", response_model=Queued, status_code=202,
             summary="queue a job that plays the match again and records its replay")
def record_replay(request: Request, match_id: RowId, who: Writer) -> dict[str, int]:
    return {"job": ops.queue_replay(league_of(request), match_id, who=who)}


@router.get("/games/{game}/tree-catalog", summary="what a social tree of the game may hold: seats, schemes, "
            "reward functions with their parameters, the default and example trees")
def tree_catalog(game: str) -> dict[str, Any]:
    return ops.tree_catalog(game)


@router.post("/trees/check", summary="check a social tree with the library's own messages (nothing is kept)")
def check_tree(tree: TreeSpec) -> dict[str, Any]:
    return ops.check_spec(tree.game, tree.spec)


@router.post("/trees/verify", response_model=Queued, status_code=202,
             summary="queue the sampling verification of a social tree; its result paints every node")
def verify_tree(request: Request, tree: TreeVerify, who: Writer) -> dict[str, int]:
    return {"job": ops.queue_verify(league_of(request), tree.game, tree.spec, samples=tree.samples, seed=tree.seed,
                                      who=who)}


@router.post("/trees/preview", response_model=Queued, status_code=202,
             summary="queue one recorded match of the game's scripted players under a social tree")
def preview_tree(request: Request, tree: TreePreview, who: Writer) -> dict[str, int]:
    return {"job": ops.queue_preview(league_of(request), tree.game, tree.spec, seed=tree.seed, who=who)}


@router.get("/trees/previews/{job_id}", summary="a finished preview's replay, as frames of its top-down scene")
def tree_preview_replay(request: Request, job_id: RowId) -> dict[str, Any]:
    return ops.preview_replay(league_of(request), job_id)


@router.get("/trees", summary="saved social trees, the newest `limit` of them, newest first")
def trees(request: Request, game: str | None = None, owner: str | None = None,
          limit: Annotated[int, Query(ge=1, le=500, description="how many of the newest trees")] = 100,
          ) -> list[dict[str, Any]]:
    return ops.list_tree_views(league_of(request), game_id=game, owner=owner, limit=limit)


@router.post("/trees", status_code=201, summary="save a social tree (checked first); yours to delete")
def save_tree(request: Request, tree: TreeSave, who: Writer) -> dict[str, Any]:
    return ops.save_tree(league_of(request), who, tree.name, tree.game, tree.spec)


@router.get("/trees/{tree_id}", summary="a saved tree: its spec, and the same as YAML")
def tree(request: Request, tree_id: RowId) -> dict[str, Any]:
    return ops.tree_view(league_of(request), tree_id)


@router.get("/trees/{tree_id}/download", summary="a saved tree as a YAML or JSON file for make(game, tree=...)",
            response_class=Response,
            responses={200: {"content": {"application/yaml": {}, "application/json": {}}, "description": "the file"}})
def tree_download(request: Request, tree_id: RowId,
                  format: Annotated[str, Query(pattern="^(yaml|json)$")] = "yaml") -> Response:
    view = ops.tree_view(league_of(request), tree_id)
    name = f"tree-{tree_id}.{format}"
    text = view["yaml"] if format == "yaml" else ops.tree_text(view["spec"], format)
    return Response(text, media_type=f"application/{format}",
                    headers={"Content-Disposition": f'attachment; filename="{name}"'})


@router.delete("/trees/{tree_id}", summary="delete a saved tree (its owner)")
def delete_tree(request: Request, tree_id: RowId, who: Writer) -> dict[str, int]:
    return ops.delete_saved_tree(league_of(request), who, tree_id)


@router.get("/schedules", summary="recurring evaluations (administrators)")
def schedules(request: Request, who: Writer) -> list[dict[str, Any]]:
    _admin(who)
    return ops.list_schedules(league_of(request))


@router.post("/schedules", status_code=201, summary="add a recurring evaluation (administrators)")
def add_schedule(request: Request, who: Writer, schedule: ScheduleRequest) -> dict[str, Any]:
    _admin(who)
    return ops.add_evaluation_schedule(league_of(request), schedule.name, schedule.game, every=schedule.every,
                                       cron=schedule.cron, matches_per_pair=schedule.matches_per_pair)


@router.delete("/schedules/{name}", summary="remove a recurring evaluation (administrators)")
def remove_schedule(request: Request, name: str, who: Writer) -> dict[str, str]:
    _admin(who)
    ops.remove_schedule(league_of(request), name)
    return {"removed": name}
