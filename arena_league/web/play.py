"""Playing in the browser: the play pages and the WebSocket that steps a person's game.

``/play`` lists the games a person can play; ``/play/{game}`` is the page (``static/play.js``
draws the frames and sends the moves); ``/ws/play/{game}`` is the socket behind it, one
:class:`~arena_league.league.live.LivePlay` per connection (its messages are documented there).
A signed-in browser plays as its token's owner (the cookie comes with the socket's handshake, and
the session's CSRF token in its ``csrf`` query parameter; a page of another origin is refused);
anyone else gives a guest name (``?guest=NAME``) and plays as ``guest-NAME``.

The server steps a paced game by itself (the person's newest move holding) and waits for the
person in the others. Leaving a match, or being idle past the league's ``web.live_idle_seconds``,
resigns it (a loss): only moves the game takes count, not other messages (``next`` and ``resign``
included), and one socket starts at most ``web.live_matches_per_minute`` matches a minute. At most
``web.live_games`` people play on one server at once, ``web.live_games_per_owner`` sockets per
owner (a guest's owner is its guest name) and ``web.live_games_per_address`` per client address.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from collections import Counter
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
    per_minute = int(settings["web.live_matches_per_minute"]["value"])
    if app.state.live_games >= limit:
        await _refuse(websocket, _TRY_LATER, f"this server already has {limit} game(s) in play (the league's "
                      "web.live_games); try again in a few minutes")
        return
    address = ("address", websocket.client.host if websocket.client else "")
    if not await _hold(websocket, address, int(settings["web.live_games_per_address"]["value"]),
                       "web.live_games_per_address", "from your address"):
        return
    app.state.live_games += 1
    try:
        await _session(websocket, league, game, idle, int(settings["web.live_games_per_owner"]["value"]),
                       per_minute)
    finally:
        app.state.live_games -= 1
        _release(websocket, address)


def _holders(websocket: WebSocket) -> Counter:
    """Open play sockets per ``("owner", name)`` and ``("address", host)`` on this server."""
    state = websocket.app.state
    if not hasattr(state, "live_holders"):
        state.live_holders = Counter()
    return state.live_holders


async def _hold(websocket: WebSocket, holder: tuple[str, str], limit: int, key: str, whose: str) -> bool:
    """Count one more socket for ``holder``; False (the socket refused, naming ``key``) when it
    already holds ``limit``."""
    holders = _holders(websocket)
    if holders[holder] >= limit:
        await _refuse(websocket, _TRY_LATER, f"{limit} game(s) already open {whose} (the league's {key}); close one "
                      "to play here")
        return False
    holders[holder] += 1
    return True


def _release(websocket: WebSocket, holder: tuple[str, str]) -> None:
    holders = _holders(websocket)
    holders[holder] -= 1
    if holders[holder] <= 0:
        del holders[holder]


async def _session(websocket: WebSocket, league: Any, game: str, idle: float, per_owner: int,
                   per_minute: int) -> None:
    # headers and cookies, as a request's; the token lookup reads the database: off the event loop
    identity = await asyncio.to_thread(optional_identity, websocket)  # type: ignore[arg-type]
    if identity is None and token_of(websocket) is not None:  # type: ignore[arg-type]
        await _refuse(websocket, _POLICY, "this token is not valid (unknown or revoked); sign in again, or play "
                      "as a guest")
        return
    try:
        ops.check_game(game)
        player, owner = ops.player_of(identity.owner if identity else None, websocket.query_params.get("guest"))
    except ops.USER_ERRORS as error:
        await _refuse(websocket, _POLICY, str(error))
        return
    if not await _hold(websocket, ("owner", owner), per_owner, "web.live_games_per_owner", f"as {owner}"):
        return
    try:
        await _start(websocket, league, game, idle, player, owner, per_minute)
    finally:
        _release(websocket, ("owner", owner))


async def _start(websocket: WebSocket, league: Any, game: str, idle: float, player: str, owner: str,
                 per_minute: int) -> None:
    try:
        importing = await asyncio.to_thread(ops.base_import, league, game)
        if importing is not None:  # importing validates agent code: a worker's job, never this connection's
            job = f"job {importing['job']}, /jobs/{importing['job']}"
            await _refuse(websocket, _TRY_LATER, importing["error"] if importing["state"] == "missing" else (
                f"the import of {game}'s base population {importing['population']} failed ({job}): "
                f"{importing['error']}; an administrator imports it again" if importing["state"] == "failed" else
                f"{game}'s base population {importing['population']} is being imported ({job}); play once it is "
                "done"))
            return
        live = await asyncio.to_thread(ops.LivePlay, league, game, player=player, owner=owner,
                                     matches_per_minute=per_minute)
    except ops.USER_ERRORS as error:
        await _refuse(websocket, _POLICY, str(error))
        return
    log.info("play %s starts %s", player, game)
    await websocket.send_json(live.hello())
    await _play(websocket, live, player, game, idle)


async def _play(websocket: WebSocket, live: Any, player: str, game: str, idle: float) -> None:
    """Answer the page's messages and step a paced game, until the page goes away or ``idle``
    seconds pass without a move (other messages, ``next`` and ``resign`` included, do not count)."""
    inbox: asyncio.Queue[str | None] = asyncio.Queue(maxsize=64)
    reader = asyncio.create_task(_read(websocket, inbox))
    next_tick: float | None = None
    idle_at = time.monotonic() + idle
    try:
        while True:
            now = time.monotonic()
            if now >= idle_at:
                await _send(websocket, await asyncio.to_thread(live.resign))
                await _refuse(websocket, _POLICY, f"no move for {idle:.0f} s: the match is resigned and the game "
                              "closed; reload the page to play again")
                return
            pace = live.pace
            if pace:
                next_tick = next_tick or now + 1.0 / pace
                wait = min(max(0.0, next_tick - now), idle_at - now)
            else:
                next_tick, wait = None, idle_at - now
            try:
                text = await asyncio.wait_for(inbox.get(), timeout=wait)
            except TimeoutError:
                if pace and next_tick is not None and time.monotonic() >= next_tick:
                    out = await asyncio.to_thread(live.tick)
                    next_tick = max(time.monotonic(), next_tick + 1.0 / pace)
                    await _send(websocket, out)
                continue
            if text is None:  # the page went away
                break
            out, moved = await _answer(live, text)
            if moved:
                idle_at = time.monotonic() + idle
            await _send(websocket, out)
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


async def _answer(live: Any, text: str) -> tuple[list[dict[str, Any]], bool]:
    """What to send back for one message from the page, and whether it was a move the game took
    (the only messages that keep a game open: starting and resigning matches cost the server a
    stored match each, so they must not hold a socket open)."""
    try:
        message = ops.read_message(text)
    except ValueError as error:
        return [{"type": "error", "detail": str(error)}], False
    kind = message.get("type") if isinstance(message, dict) else None
    try:
        if kind == "act":
            out = await asyncio.to_thread(live.act, message)
        elif kind == "next":
            return await asyncio.to_thread(live.start), False
        elif kind == "resign":
            return await asyncio.to_thread(live.resign), False
        else:
            return [{"type": "error", "detail": f"unknown message type {kind!r}; send act, next or resign"}], False
    except ValueError as error:
        return [{"type": "error", "detail": str(error)}], False
    return out, not any(m.get("type") == "refused" for m in out)  # only act gets here


async def _send(websocket: WebSocket, messages: list[dict[str, Any]]) -> None:
    for message in messages:
        await websocket.send_text(json.dumps(message, separators=(",", ":"), allow_nan=False))


async def _refuse(websocket: WebSocket, code: int, detail: str) -> None:
    await websocket.send_json({"type": "error", "detail": detail})
    await websocket.close(code=code, reason=detail[:120])
