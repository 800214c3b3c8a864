"""The errors that describe a user's input, each raised with the fix in its message.

Front ends show these as one line (and an exit code, or an HTTP 4xx), never as a traceback:
``ValueError`` (a bad option or name), ``FileNotFoundError``, the registry's errors (an unknown
agent, a duplicate name) and the artifact errors of a refused submission.
"""

from __future__ import annotations

from arena_league.policies.errors import ArtifactError
from arena_league.registry.errors import RegistryError

__all__ = ["USER_ERRORS"]

USER_ERRORS: tuple[type[BaseException], ...] = (ValueError, FileNotFoundError, RegistryError, ArtifactError)
