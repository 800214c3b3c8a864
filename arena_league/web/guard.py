"""The front door: what a write request must pass before the application reads a byte of its body.

:class:`FrontDoor` is ASGI middleware. For a write (``POST``, ``PUT``, ``PATCH``, ``DELETE``) to a
route that needs a token (every write but :data:`OPEN_WRITES`) it authenticates the token the
headers carry (``Authorization: Bearer``, or the sign-in cookie) off the event loop and refuses a
missing or bad one at once: 401 on the API, a redirect to the sign-in page on the pages. An upload
then has its declared size checked against the league's ``web.upload_mib`` (413) and must find a
free slot among the uploads in flight on this server, per owner (``web.uploads_in_flight_per_owner``)
and in all (``web.uploads_in_flight``), or is refused with 429 and ``Retry-After``. Only then does
the application read the body, counted as it streams: past the limit (an upload's, or
:data:`JSON_BODY_BYTES` for any other body) the request is answered 413, chunked or not. An upload
whose body stalls (no bytes for ``web.body_idle_seconds``), or arrives slower on average than
``web.body_min_kib_per_second`` once it has streamed that long, is abandoned with 408, so a client
that sends headers and then nothing (or a trickle) cannot hold a slot in flight; the slot is given
back however the request ends (answered, refused, stalled, disconnected, failed).

The identity found here is handed to the routes (:func:`arena_league.web.auth.optional_identity`
reads it), so a write is authenticated once.
"""

from __future__ import annotations

import asyncio
import logging
from collections import Counter
from collections.abc import Callable
from typing import Any
from urllib.parse import quote

from fastapi import Request
from fastapi.exceptions import HTTPException
from fastapi.responses import JSONResponse, RedirectResponse, Response

from arena_league.league import Identity, authenticate
from arena_league.league.errors import DatabaseFullError, DatabaseStateError
from arena_league.league.uploads import upload_admission
from arena_league.web.auth import IDENTITY_KEY, missing_token_message, token_in_headers

__all__ = ["DATABASE_FULL", "FORM_SLACK_BYTES", "FULL_RETRY_SECONDS", "JSON_BODY_BYTES", "OPEN_WRITES", "UPLOAD_PATHS",
           "FrontDoor"]

logger = logging.getLogger("arena_league.web")

#: Methods that may change something: each needs a token unless its route is in :data:`OPEN_WRITES`.
WRITE_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})
#: Writes anyone may send: signing in and out, and checking a social tree (nothing is kept).
OPEN_WRITES = frozenset({("POST", "/signin"), ("POST", "/signout"), ("POST", "/api/trees/check")})
#: The routes that take an agent's files.
UPLOAD_PATHS = frozenset({"/api/agents", "/submit"})
#: Room a multipart form needs beyond the files it carries.
FORM_SLACK_BYTES = 1 << 20
#: The most any other request body (a JSON document, a form) may hold.
JSON_BODY_BYTES = 1 << 20
#: Seconds a client refused for too many uploads in flight is asked to wait.
RETRY_IN_FLIGHT_SECONDS = 10
#: Seconds a client refused for a full disk (or a database out of reach) is asked to wait.
FULL_RETRY_SECONDS = 300
#: The answer to a write the database's full disk refused (its file's path stays in the server's log).
DATABASE_FULL = ("the disk holding the league's database is full: the league's operator must free space on it (the "
                 "server's log names the file); the write was rolled back, try again later")
#: The answer to a write the database could not take for another known cause (read-only, unreachable).
DATABASE_DOWN = ("the league's database cannot take writes now (the server's log says why); the league's operator "
                 "must fix it, try again later")

#: How a refusal is answered: (the request, status, one line, headers) -> a response; the
#: application's own error answer, so that pages get a page and the API gets ``{"detail": ...}``.
Answer = Callable[[Request, int, str, "dict[str, str] | None"], Response]


class _BodyTooLarge(HTTPException):
    """Raised from ``receive`` once a body streamed past its limit; the application's body parser
    lets an ``HTTPException`` through, so the answer is this 413 and not a parse error."""

    def __init__(self, detail: str) -> None:
        super().__init__(413, detail)


class _BodyStalled(HTTPException):
    """Raised from ``receive`` once an upload's body sent nothing for its idle time, or came too
    slowly; an ``HTTPException`` for the same reason as :class:`_BodyTooLarge`."""

    def __init__(self, detail: str) -> None:
        super().__init__(408, detail)


class FrontDoor:
    """ASGI middleware: authenticate a write, bound its size and the uploads in flight, all before
    its body is read (see the module docstring)."""

    def __init__(self, app: Any, league: Any, answer: Answer | None = None) -> None:
        self.app = app
        self.league = league
        self.answer = answer
        self.owners_in_flight: Counter[str] = Counter()
        self.in_flight = 0

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http" or scope["method"] not in WRITE_METHODS:
            await self.app(scope, receive, send)
            return
        path = scope["path"]
        upload = scope["method"] == "POST" and path in UPLOAD_PATHS
        identity: Identity | None = None
        limit = JSON_BODY_BYTES
        per_owner = in_all = 0
        pace: tuple[int, int] | None = None
        if (scope["method"], path) not in OPEN_WRITES:
            token = token_in_headers(scope.get("headers") or [])
            try:
                identity, upload_bytes, per_owner, in_all, pace = await asyncio.to_thread(self._admit, token,
                                                                                          upload)
            except DatabaseStateError as error:  # a token's first use is a write: the database may refuse it
                logger.error("%s %s: %s", scope["method"], path, error)
                full = isinstance(error, DatabaseFullError)
                await self._answer(scope, send, 507 if full else 503, DATABASE_FULL if full else DATABASE_DOWN,
                                   {"Retry-After": str(FULL_RETRY_SECONDS)})
                return
            if identity is None:
                await self._refuse_anonymous(scope, send, token is not None)
                return
            scope.setdefault("state", {})[IDENTITY_KEY] = identity
            if upload:
                limit = upload_bytes + FORM_SLACK_BYTES
        declared = _content_length(scope)
        if declared is not None and declared > limit:
            await self._answer(scope, send, 413, _too_large(limit, upload))
            return
        if not upload or identity is None:
            await self._limited(scope, receive, send, limit, upload)
            return
        owner = identity.owner
        if self.owners_in_flight[owner] >= per_owner:
            await self._answer(scope, send, 429, f"{owner} has {self.owners_in_flight[owner]} uploads in flight on "
                               f"this server, the most one owner may have at once (the setting "
                               f"web.uploads_in_flight_per_owner); wait for one to finish and try again",
                               {"Retry-After": str(RETRY_IN_FLIGHT_SECONDS)})
            return
        if self.in_flight >= in_all:
            await self._answer(scope, send, 429, f"this server is receiving {self.in_flight} uploads, the most it "
                               "takes at once (the setting web.uploads_in_flight); try again in a few seconds",
                               {"Retry-After": str(RETRY_IN_FLIGHT_SECONDS)})
            return
        # counted and released on the event loop, between awaits: no two requests race for a slot
        self.owners_in_flight[owner] += 1
        self.in_flight += 1
        try:
            await self._limited(scope, receive, send, limit, upload, pace)
        finally:
            self.in_flight -= 1
            self.owners_in_flight[owner] -= 1
            if not self.owners_in_flight[owner]:
                del self.owners_in_flight[owner]

    def _admit(self, token: str | None, upload: bool) -> tuple[Identity | None, int, int, int, tuple[int, int] | None]:
        """(the token's identity, the upload size limit, uploads in flight per owner, in all, its
        body's pace); the limits only for an upload, read from the league's settings now."""
        identity = authenticate(self.league, token)
        if identity is None or not upload:
            return identity, 0, 0, 0, None
        return (identity, *upload_admission(self.league))

    async def _limited(self, scope: dict, receive: Any, send: Any, limit: int, upload: bool,
                       pace: tuple[int, int] | None = None) -> None:
        """Run the application with the body counted as it streams in: past ``limit``, 413; with
        ``pace`` (idle seconds, bytes a second), a wait of more than the idle seconds for its next
        bytes, or an average under the rate once it has streamed that long, is a 408."""
        loop = asyncio.get_running_loop()
        began: float | None = None
        received = 0
        refusal: HTTPException | None = None
        started = replaced = ended = False

        async def counted() -> dict:
            nonlocal received, refusal, ended, began
            # only the body's bytes are waited for with a bound: after it, a receive waits for the disconnect
            if pace is None or ended or started:
                message = await receive()
            else:
                began = loop.time() if began is None else began
                try:
                    message = await asyncio.wait_for(receive(), pace[0])
                except TimeoutError:
                    refusal = _BodyStalled(_stalled(pace[0]))
                    raise refusal from None
            if message["type"] == "http.request":
                ended = not message.get("more_body", False)
                received += len(message.get("body", b""))
                if received > limit:
                    refusal = _BodyTooLarge(_too_large(limit, upload))
                    raise refusal
                if pace is not None and began is not None and not ended:
                    streamed = loop.time() - began
                    if streamed > pace[0] and received < pace[1] * streamed:
                        refusal = _BodyStalled(_too_slow(pace[1]))
                        raise refusal
            return message

        async def watched(message: dict) -> None:
            nonlocal started, replaced
            if replaced:
                return
            if message["type"] == "http.response.start":
                started = True
                # whatever the body's parser made of it, it is the front door's refusal
                if refusal is not None and message["status"] != refusal.status_code:
                    replaced = True
                    await self._answer(scope, send, refusal.status_code, refusal.detail)
                    return
            await send(message)

        try:
            await self.app(scope, counted, watched)
        except (_BodyTooLarge, _BodyStalled) as error:
            if not started:
                await self._answer(scope, send, error.status_code, error.detail)

    async def _refuse_anonymous(self, scope: dict, send: Any, presented: bool) -> None:
        if scope["path"].startswith("/api/"):
            await self._answer(scope, send, 401, missing_token_message(presented), {"WWW-Authenticate": "Bearer"})
            return
        # a page's form: sign in first, then come back to the page the form was on
        back = scope["path"] if scope["path"] in UPLOAD_PATHS else scope["path"].rsplit("/", 1)[0] or "/"
        await RedirectResponse(f"/signin?next={quote(back)}", status_code=303)(scope, _no_body, send)

    async def _answer(self, scope: dict, send: Any, status: int, detail: str,
                      headers: dict[str, str] | None = None) -> None:
        if self.answer is not None:
            response = self.answer(Request(scope, _no_body), status, detail, headers)
        else:
            response = JSONResponse({"detail": detail}, status_code=status, headers=headers)
        await response(scope, _no_body, send)


def _content_length(scope: dict) -> int | None:
    for name, value in scope.get("headers") or []:
        if name == b"content-length" and value.isdigit():
            return int(value)
    return None


def _too_large(limit: int, upload: bool) -> str:
    if upload:
        return (f"the upload is over {(limit - FORM_SLACK_BYTES) >> 20} MiB, the most this league takes (the "
                "setting web.upload_mib)")
    return f"the request body is over {limit >> 20} MiB, the most a request other than an upload may carry"


def _stalled(idle: int) -> str:
    return (f"the upload stalled: no bytes for {idle} s (the setting web.body_idle_seconds); send it "
            "again")


def _too_slow(rate: int) -> str:
    return (f"the upload arrived slower than {rate >> 10} KiB/s on average (the setting "
            "web.body_min_kib_per_second); send it again over a faster link")


async def _no_body() -> dict:
    return {"type": "http.disconnect"}
