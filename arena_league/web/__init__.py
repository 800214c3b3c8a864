"""The league as a web service: a FastAPI application over :mod:`arena_league.league`.

``arena-league serve`` runs it with uvicorn (:func:`serve`); tests and deployments may build it
with :func:`create_app` for a league home or database URL. It holds no league logic: every route
parses, calls the league layer, and presents the result, as JSON (the API under ``/api``, and a
``.json`` twin of every page) or as a server-rendered page (Jinja2, plain JavaScript for the
replay player and live progress).
"""

from arena_league.web.app import create_app
from arena_league.web.serve import serve

__all__ = ["create_app", "serve"]
