"""Playing in the browser: the play pages and the WebSocket that steps a person's game.

``/play`` lists the games a person can play; ``/play/{game}`` is the page (``static/play.js``
draws the frames and sends the moves); ``/ws/play/{game}`` is the socket behind it, one
:class:`~arena_league.league.live.LivePlay` per connection (its messages are documented there).
A signed-in browser plays as its token's owner (the cookie comes with the socket's handshake, and
the session's CSRF token in its ``csrf`` query parameter; a page of another origin is refused);
anyone else gives a guest name (``?guest=NAME``) and plays as ``guest-NAME``.

The server steps a paced game by itself (the person's newest move holding) and waits for the
person in the others. Leaving a match, or being idle past the league's ``web.live_idle_seconds``,
resigns it (a loss); at most ``web.live_games`` people play on one server at once.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from typing import Any

from fastapi import APIRouter, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import HTMLResponse

from arena_league import league as ops
from arena_league.web.auth import optional_identity, token_of
from arena_league.web.csrf import socket_problem
from arena_league.web.deps import Viewer, league_of
from arena_league.web.pages import _page

__all__ = ["router"]

router = APIRouter(include_in_schema=False)
log = logging.getLogger("arena_league.web")
#: WebSocket close codes: a policy refusal (bad input) and "try again later" (the server is full).
_POLICY, _TRY_LATER = 1008, 1013


def _playable(request: Request) -> list[dict[str, Any]]:
    return [g for g in ops.games_view(league_of(request))
            if g["teams"] == 2 and (g["base_shipped"] or g["base_imported"])]


@router.get("/play", response_class=HTMLResponse)
def play_index(request: Request, viewer: Viewer) -> HTMLResponse:
    return _page(request, "play_index.html", {"games": _playable(request)}, viewer, "/play.json")


@router.get("/play.json")
def play_index_json(request: Request) -> dict[str, Any]:
    return {"games": _playable(request)}


@router.get("/play/{game}", response_class=HTMLResponse)
def play_page(request: Request, game: str, viewer: Viewer) -> HTMLResponse:
    ops.check_game(game)  # an unknown game is a 400 naming the valid ones
    importing = ops.base_import(league_of(request), game)
    return _page(request, "play.html", {"game_id": game, "importing": importing}, viewer, "/play.json")


@router.websocket("/ws/play/{game}")
async def play_socket(websocket: WebSocket, game: str) -> None:
    app = websocket.app
    league = app.state.league
    await websocket.accept()
    forged = socket_problem(websocket)  # a page of another origin, or the cookie without its CSRF token
    if forged is not None:
        await _refuse(websocket, _POLICY, forged)
        return
    settings = await asyncio.to_thread(ops.league_settings, league)
    limit = int(settings["web.live_games"]["value"])
    idle = float(settings["web.live_idle_seconds"]["value"])
    if app.state.live_games >= limit:
        await _refuse(websocket, _TRY_LATER, f"this server already has {limit} game(s) in play (the league's "
                      "web.live_games); try again in a few minutes")
        return
    app.state.live_games += 1
    try:
        await _session(websocket, league, game, idle)
    finally:
        app.state.live_games -= 1


async def _session(websocket: WebSocket, league: Any, game: str, idle: float) -> None:
    # headers and cookies, as a request's; the token lookup reads the database: off the event loop
    identity = await asyncio.to_thread(optional_identity, websocket)  # type: ignore[arg-type]
    if identity is None and token_of(websocket) is not None:  # type: ignore[arg-type]
        await _refuse(websocket, _POLICY, "this token is not valid (unknown or revoked); sign in again, or play "
                      "as a guest")
        return
    try:
        ops.check_game(game)
        importing = await asyncio.to_thread(ops.base_import, league, game)
        if importing is not None:  # importing validates agent code: a worker's job, never this connection's
            job = f"job {importing['job']}, /jobs/{importing['job']}"
            await _refuse(websocket, _TRY_LATER, importing["error"] if importing["state"] == "missing" else (
                f"the import of {game}'s base population {importing['population']} failed ({job}): "
                f"{importing['error']}; an administrator imports it again" if importing["state"] == "failed" else
                f"{game}'s base population {importing['population']} is being imported ({job}); play once it is "
                "done"))
            return
        player, owner = ops.player_of(identity.owner if identity else None, websocket.query_params.get("guest"))
        live = await asyncio.to_thread(ops.LivePlay, league, game, player=player, owner=owner)
    except ops.USER_ERRORS as error:
        await _refuse(websocket, _POLICY, str(error))
        return
    log.info("play %s starts %s", player, game)
    await websocket.send_json(live.hello())
    inbox: asyncio.Queue[str | None] = asyncio.Queue(maxsize=64)
    reader = asyncio.create_task(_read(websocket, inbox))
    next_tick: float | None = None
    try:
        while True:
            pace = live.pace
            if pace:
                next_tick = next_tick or time.monotonic() + 1.0 / pace
                wait = max(0.0, next_tick - time.monotonic())
            else:
                next_tick, wait = None, idle
            try:
                text = await asyncio.wait_for(inbox.get(), timeout=wait)
            except TimeoutError:
                if pace:
                    out = await asyncio.to_thread(live.tick)
                    next_tick = max(time.monotonic(), next_tick + 1.0 / pace)
                    await _send(websocket, out)
                    continue
                await _send(websocket, await asyncio.to_thread(live.resign))
                await _refuse(websocket, _POLICY, f"no move for {idle:.0f} s: the match is resigned and the game "
                              "closed; reload the page to play again")
                return
            if text is None:  # the page went away
                break
            await _send(websocket, await _answer(live, text))
    except WebSocketDisconnect:
        pass
    finally:
        reader.cancel()
        if live.playing:
            await asyncio.to_thread(live.resign)
            log.info("play %s left %s mid-match: resigned", player, game)


async def _read(websocket: WebSocket, inbox: asyncio.Queue) -> None:
    """Put every message of the page in ``inbox`` (a binary one as ``""``, which is no JSON; None
    when the page goes away); messages beyond what the game can use (the inbox full) are dropped."""
    while True:
        message = await websocket.receive()
        if message["type"] == "websocket.disconnect":
            await inbox.put(None)
            return
        if not inbox.full():
            inbox.put_nowait(message.get("text") or "")


async def _answer(live: Any, text: str) -> list[dict[str, Any]]:
    """What to send back for one message from the page."""
    try:
        message = json.loads(text)
    except json.JSONDecodeError:
        return [{"type": "error", "detail": "a message is one JSON object such as {\"type\": \"act\", \"text\": \"w\"}"}]
    kind = message.get("type") if isinstance(message, dict) else None
    try:
        if kind == "act":
            return await asyncio.to_thread(live.act, message)
        if kind == "next":
            return await asyncio.to_thread(live.start)
        if kind == "resign":
            return await asyncio.to_thread(live.resign)
    except ValueError as error:
        return [{"type": "error", "detail": str(error)}]
    return [{"type": "error", "detail": f"unknown message type {kind!r}; send act, next or resign"}]


async def _send(websocket: WebSocket, messages: list[dict[str, Any]]) -> None:
    for message in messages:
        await websocket.send_text(json.dumps(message, separators=(",", ":"), allow_nan=False))


async def _refuse(websocket: WebSocket, code: int, detail: str) -> None:
    await websocket.send_json({"type": "error", "detail": detail})
    await websocket.close(code=code, reason=detail[:120])
