"""The errors that describe a user's input, each raised with the fix in its message.

Front ends show these as one line (and an exit code, or an HTTP 4xx), never as a traceback:
``ValueError`` (a bad option or name), ``FileNotFoundError``, the registry's errors (an unknown
agent, a duplicate name) and the artifact errors of a refused submission. Three of them say more
to a web client: :class:`NotFoundError` (404), :class:`ForbiddenError` (403) and
:class:`RateLimitedError` (429); a full disk (:class:`DiskFullError`, :class:`DatabaseFullError`,
:func:`disk_full_error` for an ``OSError``) is the machine's state, named with its fix (507).
"""

from __future__ import annotations

from arena_league.policies.errors import ArtifactError
from arena_league.registry.errors import (
    DatabaseFullError,
    DatabaseStateError,
    DiskFullError,
    RegistryError,
    disk_full_error,
)

__all__ = ["USER_ERRORS", "DatabaseFullError", "DatabaseStateError", "DiskFullError", "ForbiddenError",
           "JobCancelledError", "JobFailedError", "JobInterrupted", "NotFoundError", "RateLimitedError", "disk_full_error"]


class NotFoundError(ValueError):
    """What was asked for does not exist (or is not this caller's to see)."""


class ForbiddenError(ValueError):
    """The caller may not do this (another owner's agent, an administrator's task)."""


class RateLimitedError(ValueError):
    """The caller has done this too often lately; the message says when to try again."""


class JobFailedError(ValueError):
    """A job a command waited for failed (here or in another worker); the message is its error's last line."""


class JobCancelledError(ValueError):
    """A job a command waited for was cancelled by someone else (``jobs cancel``, the web)."""


class JobInterrupted(KeyboardInterrupt):
    """Ctrl-C while a command waited for its job: the job is cancelled; the message says which."""


USER_ERRORS: tuple[type[BaseException], ...] = (ValueError, FileNotFoundError, RegistryError, ArtifactError)
