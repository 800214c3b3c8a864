"""Request bodies in JSON checked before anything parses them: a body that nests arrays and objects
deeper than the league takes (:func:`arena_league.league.check_json_nesting`) is refused with 400
naming the depth, so no request can spend the parser's recursion.

FastAPI parses a body as JSON when it says it is JSON (``application/json``, ``…+json``) or says
nothing; those are the bodies checked here. Their size is bounded by the application's body limit
(outside this middleware), so holding one whole while it is checked costs at most that much.
"""

from __future__ import annotations

from typing import Any

from fastapi.responses import JSONResponse

from arena_league import league as ops

__all__ = ["JsonNesting"]

#: The most a JSON request body may hold while it is checked; the application's own limit is lower.
_MAX_BYTES = 8 << 20


def _is_json(headers: list[tuple[bytes, bytes]]) -> bool:
    kind = dict(headers).get(b"content-type")
    if kind is None:
        return True
    media = kind.split(b";", 1)[0].strip().lower()
    return media == b"application/json" or media.endswith(b"+json")


class JsonNesting:
    """ASGI middleware: read a JSON request body whole, refuse it (400) when it nests too deep or
    is over :data:`_MAX_BYTES` (413), and hand it on unchanged otherwise."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http" or scope["method"] not in ("POST", "PUT", "PATCH", "DELETE") or \
                not _is_json(scope.get("headers") or []):
            await self.app(scope, receive, send)
            return
        chunks: list[bytes] = []
        size = 0
        while True:
            message = await receive()
            if message["type"] != "http.request":  # the client went away
                return
            chunks.append(message.get("body", b""))
            size += len(chunks[-1])
            if size > _MAX_BYTES:
                await JSONResponse({"detail": f"the request body is over {_MAX_BYTES >> 20} MiB, the most a JSON body "
                                              "may carry"}, status_code=413)(scope, receive, send)
                return
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        try:
            ops.check_json_nesting(body, "the request body", max_bytes=_MAX_BYTES)
        except ValueError as error:
            await JSONResponse({"detail": str(error)}, status_code=400)(scope, receive, send)
            return
        sent = False

        async def replay() -> dict:
            nonlocal sent
            if sent:
                return await receive()  # after the body: the disconnect, when it comes
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}

        await self.app(scope, replay, send)
