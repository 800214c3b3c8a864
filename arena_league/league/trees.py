"""Social trees as a league resource: what the tree editor offers, checks, keeps, verifies and previews.

Arena (Song et al., AAAI 2020) builds a new social problem by editing a game's social tree: each
node groups agents (or smaller groups) under one of five schemes (NL, IS, CP, CL, CC) with a
reward function. Here a tree is a JSON/YAML spec that :func:`arena_league.envs.make` takes as
``tree=`` (see :mod:`arena_league.envs.social.tree`); this module gives the web editor:

* :func:`tree_catalog`: a game's seats, the schemes, the reward functions each scheme may use in
  that game (those whose measures the game emits) with their parameters, the default tree and the
  game's example trees (the paper's Crossroads case study);
* :func:`check_spec`: the library's own check, as ``{"ok", "nodes"}`` or ``{"ok": False, "error",
  "path"}`` (the node the message names), after bounds that keep a hostile spec small;
* :func:`save_tree`, :func:`tree_view`, :func:`list_tree_views`, :func:`delete_saved_tree`: trees
  kept in the registry, owned like agents (only the owner or an administrator deletes one; an
  owner keeps at most ``trees.per_owner``, a listing returns a page of the newest);
  :func:`tree_text` writes one as YAML or JSON;
* jobs, run by a league worker: ``verify`` (the paper's sampling verification,
  :func:`handle_verify`) and ``preview`` (one recorded match of the game's scripted players under
  the tree, :func:`handle_preview`, whose replay :func:`preview_replay` serves).
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import yaml

from arena_league import registry as reg
from arena_league.league.errors import ForbiddenError, NotFoundError, RateLimitedError
from arena_league.league.home import register_game
from arena_league.league.names import check_tree_name
from arena_league.league.quotas import enqueue_owned, live_job_limit
from arena_league.league.tokens import Identity
from arena_league.registry import League

__all__ = [
    "MAX_BOARD", "MAX_DEPTH", "MAX_LISTED", "MAX_NODES", "MAX_SPEC_BYTES", "MAX_TEXT", "MIN_SAMPLES", "PREVIEWS", "check_spec", "delete_saved_tree", "handle_preview",
    "handle_verify", "list_tree_views", "preview_replay", "queue_preview", "queue_verify", "save_tree",
    "tree_catalog", "tree_text", "tree_view",
]

#: Bounds on a spec from outside, checked before the library builds it: nesting, nodes and leaves
#: in all, and floats on one node's broadcast board.
MAX_DEPTH = 16
MAX_NODES = 256
MAX_BOARD = 64
#: A spec's size as compact JSON, and the characters of any one string in it (a node's name, a
#: reward, a parameter and their keys): a saved tree is served to anyone who lists trees.
MAX_SPEC_BYTES = 64 * 1024
MAX_TEXT = 64
#: Samples a verification may ask for: fewer than 4 pairs cannot estimate a sign.
MIN_SAMPLES = 4
MAX_SAMPLES = 512
#: Saved trees one listing returns at most (newest first), and by default.
MAX_LISTED = 500
LISTED = 100
#: Folder of the league home that keeps preview replays.
PREVIEWS = "previews"
_NODE_PATH = re.compile(r"^social tree node (\S+): ")


def tree_catalog(game_id: str) -> dict[str, Any]:
    """What the editor offers for ``game_id``: seats (``player_i``), their teams and the teams'
    colours (as drawn everywhere else), the schemes with
    a line each, per scheme the reward functions of this game, its default tree, example trees and
    the game's options (``options_catalog`` records)."""
    from arena_league.envs import default_tree, example_trees, game_options, game_spec, reward_catalog
    from arena_league.envs.options import options_catalog
    from arena_league.envs.social.rewards import SCHEMES
    from arena_league.league.replays import team_hex

    spec = game_spec(game_id)
    agents = [f"player_{i}" for i in range(spec.n_agents)]
    return {"game_id": game_id, "agents": agents,
            "teams": [i // spec.players_per_team for i in range(spec.n_agents)],
            "colors": [team_hex(team) for team in range(spec.n_teams)],
            "schemes": [{"name": name, "doc": doc} for name, doc in SCHEMES.items()],
            "rewards": reward_catalog(game_id), "default": default_tree(game_id),
            "examples": example_trees(game_id), "options": options_catalog(game_options(game_id)),
            "match_format": _match_format(spec),
            "limits": {"depth": MAX_DEPTH, "nodes": MAX_NODES, "board": MAX_BOARD, "bytes": MAX_SPEC_BYTES,
                       "text": MAX_TEXT}}


def _match_format(spec: Any) -> dict[str, Any]:
    """Whether the game is played in pairs, and what that means for a tree, in a sentence."""
    if not spec.paired:
        return {"paired": False, "note": None}
    return {"paired": True, "note": (
        f"{spec.game_id} is played in pairs: the league's matches are two halves from the same start with the "
        "teams' agents swapped, so every agent plays each team's role once per pair. A tree's rewards shape each "
        "team's role (team 0's seats, then team 1's); the preview plays one half.")}


def check_spec(game_id: str, spec: Any) -> dict[str, Any]:
    """The tree ``spec`` of ``game_id`` checked: ``{"ok": True, "nodes": [...]}`` (every node's path,
    scheme, reward, scale, seats and board), or ``{"ok": False, "error": message, "path": node}``
    with the library's message and the path of the node it names (None when it names none)."""
    from arena_league.envs import TreeSpecError, check_tree

    try:
        _bound(spec)
        return {"ok": True, "nodes": check_tree(game_id, spec)}
    except TreeSpecError as exc:
        message = str(exc)
        found = _NODE_PATH.match(message)
        return {"ok": False, "error": message, "path": found.group(1) if found else None}


def _checked(game_id: str, spec: Any) -> Any:
    """``spec`` when it builds for ``game_id``; else the check's message as a ValueError."""
    outcome = check_spec(game_id, spec)
    if not outcome["ok"]:
        raise ValueError(outcome["error"])
    return spec


def _bound(spec: Any) -> None:
    """Refuse a spec deeper, larger or with wider boards than the editor's limits (a hostile spec
    would otherwise cost the builder's recursion or an env's memory)."""
    from arena_league.envs import TreeSpecError

    if not isinstance(spec, dict):
        raise TreeSpecError(f"a social tree is a node (a JSON object with 'scheme' and 'children'), not "
                            f"{type(spec).__name__}")
    stack: list[tuple[Any, int]] = [(spec, 1)]
    count = 0
    while stack:
        node, depth = stack.pop()
        count += 1
        if depth > MAX_DEPTH or count > MAX_NODES:
            raise TreeSpecError(f"social tree is too {'deep' if depth > MAX_DEPTH else 'large'}: at most "
                                f"{MAX_DEPTH} levels and {MAX_NODES} nodes and leaves in all")
        if isinstance(node, dict):
            board = node.get("board", 0)
            if isinstance(board, int) and not isinstance(board, bool) and board > MAX_BOARD:
                raise TreeSpecError(f"a node's board of {board} floats is over the limit of {MAX_BOARD}; a "
                                    "broadcast board is a few numbers each agent below the node may write")
            children = node.get("children")
            if isinstance(children, list):
                stack.extend((child, depth + 1) for child in children)
            if "agent" in node:
                stack.append((node["agent"], depth + 1))
    try:
        size = len(json.dumps(spec, separators=(",", ":"), allow_nan=True).encode())
    except (TypeError, ValueError, RecursionError) as exc:
        raise TreeSpecError(f"social tree cannot be written as JSON ({type(exc).__name__}); write it as plain "
                            "objects, lists, strings and numbers") from None
    if size > MAX_SPEC_BYTES:
        raise TreeSpecError(f"social tree is {size} bytes as JSON, over the limit of {MAX_SPEC_BYTES}; a tree of "
                            f"{MAX_NODES} nodes fits well within it")
    _bound_text(spec)


def _bound_text(spec: Any) -> None:
    """Refuse a spec with a string (a value or a key) over :data:`MAX_TEXT` characters."""
    from arena_league.envs import TreeSpecError

    stack = [spec]
    while stack:
        item = stack.pop()
        texts: list[Any] = []
        if isinstance(item, dict):
            texts, values = list(item), list(item.values())
        else:
            values = list(item) if isinstance(item, list) else [item]
        for text in [*texts, *(v for v in values if isinstance(v, str))]:
            if isinstance(text, str) and len(text) > MAX_TEXT:
                raise TreeSpecError(f"social tree holds a string of {len(text)} characters ({text[:24]!r}...), over "
                                    f"the limit of {MAX_TEXT}; shorten the node's name or field")
        stack.extend(v for v in values if isinstance(v, (dict, list)))


# --- saved trees ----------------------------------------------------------------------------------

def save_tree(league: League, who: Identity, name: str, game_id: str, spec: Any) -> dict[str, Any]:
    """Keep ``spec`` (checked) as ``who``'s tree ``name`` of ``game_id``; its view. An owner keeps
    at most ``trees.per_owner`` trees (administrators are not limited): past it,
    :class:`RateLimitedError` names the setting and the fix."""
    from arena_league.league.settings import league_settings

    check_tree_name(name)
    _checked(game_id, spec)
    register_game(league, game_id)
    limit = int(league_settings(league)["trees.per_owner"]["value"])
    with league.transaction() as session:
        reg.lock_owner(session, who.owner)  # the count and the insert in one step, as for jobs
        kept = reg.count_trees(session, who.owner)
        if not who.admin and kept >= limit:
            raise RateLimitedError(f"{who.owner} already keeps {kept} saved trees, the most this league allows (the "
                                   "setting trees.per_owner); delete some before saving another")
        tree = reg.create_tree(session, name, game_id, who.owner, spec)
        return _view(tree)


def tree_view(league: League, tree_id: int) -> dict[str, Any]:
    """A saved tree: id, name, game, owner, when, spec, and the spec as YAML."""
    with league.reading() as session:
        return _view(_tree(session, tree_id))


def list_tree_views(league: League, game_id: str | None = None, owner: str | None = None,
                    limit: int = LISTED) -> list[dict[str, Any]]:
    """The newest ``limit`` saved trees (1 to :data:`MAX_LISTED`; of one game or owner when given),
    newest first, without their YAML."""
    if isinstance(limit, bool) or not isinstance(limit, int) or not 1 <= limit <= MAX_LISTED:
        raise ValueError(f"limit must be a whole number from 1 to {MAX_LISTED}, not {limit!r}")
    with league.reading() as session:
        return [_view(t, yaml=False) for t in reg.list_trees(session, game_id=game_id, owner=owner, limit=limit)]


def delete_saved_tree(league: League, who: Identity, tree_id: int) -> dict[str, Any]:
    """Remove a saved tree (its owner or an administrator)."""
    with league.transaction() as session:
        tree = _tree(session, tree_id)
        if not who.may_manage(tree.owner):
            raise ForbiddenError(f"tree {tree_id} belongs to {tree.owner}; only its owner may delete it")
        reg.delete_tree(session, tree)
    return {"deleted": tree_id}


def tree_text(spec: Any, fmt: str = "yaml") -> str:
    """``spec`` as YAML (keys in the order written) or JSON, as ``make(game, tree=path)`` reads it."""
    if fmt == "json":
        return json.dumps(spec, indent=2) + "\n"
    if fmt == "yaml":
        return yaml.safe_dump(spec, sort_keys=False, default_flow_style=False)
    raise ValueError(f"unknown format {fmt!r}; yaml or json")


def _tree(session: Any, tree_id: int) -> reg.Tree:
    tree = reg.get_tree(session, tree_id)
    if tree is None:
        raise NotFoundError(f"there is no saved tree {tree_id}")
    return tree


def _view(tree: reg.Tree, *, yaml: bool = True) -> dict[str, Any]:
    view = {"id": tree.id, "name": tree.name, "game_id": tree.game_id, "owner": tree.owner,
            "created_at": tree.created_at.isoformat(timespec="seconds"), "spec": tree.spec}
    return {**view, "yaml": tree_text(tree.spec)} if yaml else view


# --- jobs -----------------------------------------------------------------------------------------

def queue_verify(league: League, game_id: str, spec: Any, *, samples: int = 64, seed: int = 0,
                 who: Identity | None = None) -> int:
    """Queue the sampling verification of ``spec`` (checked first) for ``who`` (within their quota,
    :mod:`arena_league.league.quotas`; None: the league's own); the job id."""
    if isinstance(samples, bool) or not isinstance(samples, int) or not MIN_SAMPLES <= samples <= MAX_SAMPLES:
        raise ValueError(f"samples must be a whole number from {MIN_SAMPLES} to {MAX_SAMPLES} (verification needs at "
                         f"least {MIN_SAMPLES} paired samples to estimate a sign), not {samples!r}")
    _checked(game_id, spec)
    register_game(league, game_id)
    limit = live_job_limit(league) if who is not None else None
    with league.transaction() as session:
        return enqueue_owned(session, who, "verify", {"game_id": game_id, "tree": spec, "samples": samples,
                                                      "seed": int(seed)}, priority=60, limit=limit).id


def handle_verify(ctx: reg.JobContext, progress: Any = None) -> dict[str, Any]:
    """Job handler: verify the tree by paired sampling; every node's declared and verified scheme."""
    from arena_league.envs.social.verify import verify

    p = ctx.job.payload
    report = verify(p["game_id"], p["tree"], samples=int(p["samples"]), seed=int(p["seed"]), progress=progress)
    return report.to_dict()


def queue_preview(league: League, game_id: str, spec: Any, *, seed: int = 0, who: Identity | None = None) -> int:
    """Queue one recorded match of the game's scripted players under ``spec`` for ``who`` (within
    their quota; None: the league's own); the job id."""
    _checked(game_id, spec)
    register_game(league, game_id)
    limit = live_job_limit(league) if who is not None else None
    with league.transaction() as session:
        return enqueue_owned(session, who, "preview", {"game_id": game_id, "tree": spec, "seed": int(seed)},
                             priority=60, limit=limit).id


def handle_preview(ctx: reg.JobContext, progress: Any = None) -> dict[str, Any]:
    """Job handler: play one match of ``scripted:heuristic`` in every seat under the tree, recorded;
    the steps, outcome and every seat's summed reward under the tree."""
    from arena_league.envs import game_spec
    from arena_league.matchmaking import MatchSpec, play_matches
    from arena_league.policies import scripted_policy
    from arena_league.replay import ReplayRecording, iter_messages
    from arena_league.replay.schemas import TOPICS

    p = ctx.job.payload
    game_id = p["game_id"]
    folder = Path(ctx.league.home) / PREVIEWS / str(ctx.job.id)
    folder.mkdir(parents=True, exist_ok=True)
    n_agents = game_spec(game_id).n_agents
    spec = MatchSpec(ctx.job.id, game_id, ("heuristic",) * n_agents, int(p["seed"]))
    [result] = play_matches([spec], {"heuristic": scripted_policy("heuristic", game_id)}, env_kwargs={"tree": p["tree"]},
                            recording=ReplayRecording(folder), heartbeat=ctx.heartbeat)
    totals = [0.0] * n_agents
    for _, message in iter_messages(result.replay_path, [TOPICS["rewards"]]):
        for seat, value in enumerate(message.get("rewards", ())):
            totals[seat] += float(value)
    return {"game_id": game_id, "steps": result.steps, "scores": list(result.scores), "outcomes": list(result.outcomes),
            "rewards": [round(v, 4) for v in totals], "replay": f"/api/trees/previews/{ctx.job.id}"}


def preview_replay(league: League, job_id: int) -> dict[str, Any]:
    """The replay document (:func:`~arena_league.league.replays.replay_document`) of a finished
    ``preview`` job."""
    from arena_league.league.replays import replay_document

    with league.reading() as session:
        job = reg.get_job(session, job_id)
        if job is None or job.kind != "preview":
            raise NotFoundError(f"there is no preview job {job_id}")
        if job.status != "done":
            raise NotFoundError(f"preview job {job_id} is {job.status}; its replay comes when it is done")
    files = sorted((Path(league.home) / PREVIEWS / str(job_id)).glob("*.mcap"))
    if not files:
        raise NotFoundError(f"preview job {job_id}'s replay is gone (previews are removed by `arena-league gc`)")
    return replay_document(files[0])
