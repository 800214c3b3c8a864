"""Errors raised by the league registry.

Every refusal names its cause and, where one exists, the fix. Nothing already stored changes when
one of these is raised: the registry raises before it writes, and the caller's transaction rolls
back on the way out.

Arena's league service (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for
Multi-Agent Intelligence", AAAI 2020) keeps results for good; these errors are how it refuses
input that would corrupt them.
"""

from __future__ import annotations

import errno
import os

#: The errors a write meets when its disk (or the process's file size limit) has no room.
DISK_FULL_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


class RegistryError(Exception):
    """Base class of every error the registry raises on purpose."""


class DatabaseStateError(RegistryError):
    """The database cannot be used as it is now (unreachable, read-only, full, corrupt); the
    message says which, and what to do about it."""


class DatabaseUnreachableError(DatabaseStateError):
    """The database URL could not be connected to."""


class ReadOnlyDatabaseError(DatabaseStateError):
    """The league database (or the folder holding it) cannot be written: file permissions, an
    immutable file, a read-only mount, or a PostgreSQL read-only transaction or replica."""


class DatabaseFullError(DatabaseStateError):
    """The disk holding the database is full (or the database reached its size limit)."""


class CorruptDatabaseError(DatabaseStateError):
    """The SQLite file fails its integrity check: a page is damaged. Nothing is written to it."""


class DiskFullError(RegistryError):
    """A file of the league (an upload, an artifact, a replay) could not be written: its disk is
    full, or the process's file size limit was reached. The message names where, and the fix."""


def disk_full_error(error: BaseException, where: str) -> DiskFullError | None:
    """The :class:`DiskFullError` naming ``where`` (words, such as "the league home's uploads/
    folder") for an ``OSError`` of a full disk, or None for any other error."""
    if not isinstance(error, OSError) or error.errno not in DISK_FULL_ERRNOS:
        return None
    if error.errno == errno.EFBIG:
        return DiskFullError(f"a file under {where} reached the most this process may write ({os.strerror(error.errno)}: "
                             "its file size limit, `ulimit -f`); raise that limit and try again")
    return DiskFullError(f"the disk holding {where} is full ({os.strerror(error.errno)}): free space on it (old "
                         "replays under the league home's replays/ folder are safe to delete, and `arena-league gc` "
                         "removes artifact files no agent uses), then try again")


class WorkerGaveUpError(DatabaseStateError):
    """A worker stopped after repeated database errors instead of retrying for ever."""


class NotADatabaseError(RegistryError):
    """The league database path holds a file that is not an SQLite database."""


class ForeignDatabaseError(RegistryError):
    """The database holds tables but was never set up by arena-league."""


class SchemaTooNewError(RegistryError):
    """The database was migrated by a newer arena-league than this one."""


class SchemaOutOfDateError(RegistryError):
    """The database is behind this code's schema and the caller asked not to migrate."""


class InvalidRecordError(RegistryError, ValueError):
    """A value does not fit the registry's schema (unknown status, negative seed, ...)."""


class UnknownGameError(RegistryError, LookupError):
    """The game is not registered in this league."""


class GameMismatchError(RegistryError):
    """A game id is already registered with other team sizes."""


class UnknownAgentError(RegistryError, LookupError):
    """No agent of that name is registered."""


class NameTakenError(RegistryError):
    """A unique name (agent, schedule) is already in use.

    Attributes:
        what: the kind of record ("agent", "schedule").
        name: the name that was asked for.
        existing: a one-line description of the record that holds the name.
        suggestion: a free name close to the one asked for.
    """

    def __init__(self, what: str, name: str, existing: str, suggestion: str) -> None:
        self.what = what
        self.name = name
        self.existing = existing
        self.suggestion = suggestion
        super().__init__(
            f"{what} name {name!r} is already taken by {existing}; "
            f"choose another name, for example {suggestion!r}"
        )


class ArtifactTakenError(RegistryError):
    """The artifact is already the agent of another name in that game: one agent per (game, bytes).

    Attributes:
        agent: the name of the agent that holds the bytes.
        requested: the name that was asked for (nothing was registered under it).
        game_id: the game.
        sha256: the artifact's digest.
    """

    def __init__(self, agent: str, requested: str, game_id: str, sha256: str) -> None:
        self.agent = agent
        self.requested = requested
        self.game_id = game_id
        self.sha256 = sha256
        super().__init__(
            f"these bytes (artifact {sha256[:12]}) are already agent {agent!r} of {game_id}; nothing "
            f"was registered as {requested!r}. Rank {agent!r} instead, or submit different bytes"
        )


class ArtifactError(RegistryError):
    """An artifact cannot be stored (missing file, symlink inside a folder, ...)."""


class ArtifactTooLargeError(ArtifactError):
    """An artifact is larger than the caller's size limit; it was not read."""


class PopulationFrozenError(RegistryError):
    """A frozen population cannot gain members."""


class MatchKeyConflictError(RegistryError):
    """A match key is already stored for a different match (other game, seed or agents)."""


class LeaseLostError(RegistryError):
    """A worker's lease on a job expired and the job was claimed again (or finished)."""


class InvalidScheduleError(RegistryError, ValueError):
    """A schedule's interval or cron expression is not usable."""
