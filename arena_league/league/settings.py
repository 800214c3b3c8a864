"""League settings: the budgets submitted agents play within, kept in the registry.

Every setting has a default; a league stores only the ones its operator changed
(``arena-league settings set KEY VALUE``), so every worker and web server of the league reads the
same values. The budgets of the inference sandbox (:class:`~arena_league.policies.sandbox.SandboxLimits`)
take their defaults from that class, the one place they are written.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

from arena_league import registry as reg
from arena_league.league.home import did_you_mean
from arena_league.policies.sandbox import SandboxLimits
from arena_league.registry import League

__all__ = ["SETTINGS", "Setting", "check_rank_budget", "job_max_seconds", "league_settings", "reset_setting",
           "sandbox_limits", "set_setting", "suspend_after"]

_DEFAULT_LIMITS = SandboxLimits()


@dataclass(frozen=True)
class Setting:
    """One setting: its key, type, default, bounds and what it does."""

    key: str
    kind: type
    default: Any
    low: float
    high: float
    help: str

    def parse(self, text: str | int | float) -> int | float:
        """``text`` as this setting's value; ``ValueError`` naming the key, the bounds and an example."""
        try:
            value = self.kind(text) if not isinstance(text, str) else self.kind(text.strip())
        except (TypeError, ValueError):
            kind = "a whole number" if self.kind is int else "a number"
            raise ValueError(f"{self.key} takes {kind}, not {text!r} (e.g. `arena-league settings set {self.key} "
                             f"{self.default}`)") from None
        if not self.low <= value <= self.high:
            raise ValueError(f"{self.key} must lie in [{self.low:g}, {self.high:g}], not {value:g} "
                             f"(default {self.default})")
        return value


def _sandbox_setting(name: str, low: float, high: float, help_text: str) -> Setting:
    default = getattr(_DEFAULT_LIMITS, name)
    return Setting(f"sandbox.{name}", type(default), default, low, high, help_text)


#: Every setting a league has, by key.
SETTINGS: dict[str, Setting] = {s.key: s for s in (
    _sandbox_setting("memory_mib", 256, 1 << 20, "address space (MiB) a worker's inference sandbox may add to "
                     "its runtime, for every submitted agent it holds; an allocation past it fails the agent's call"),
    _sandbox_setting("call_seconds", 0.05, 600, "wall-clock seconds one submitted agent's forward may take in a "
                     "step (all its seats); over it, the agent forfeits its matches in flight"),
    _sandbox_setting("load_seconds", 1, 3600, "wall-clock seconds loading one submitted agent may take"),
    _sandbox_setting("step_seconds", 0.001, 600, "wall-clock seconds a submitted agent may take each step of a "
                     "match; what it takes beyond them is drawn from its overage bank for that match"),
    _sandbox_setting("overage_seconds", 0, 86400, "seconds over the step allowance a submitted agent may spend "
                     "in all of one match; past them, it forfeits that match"),
    _sandbox_setting("agent_memory_mib", 16, 1 << 20, "memory (MiB) an agent may use in validation: loaded, "
                     "plus a forward at the largest batch; over it, the submission is rejected"),
    Setting("forfeits.suspend_after", int, 3, 1, 10**6, "forfeits after which an agent is suspended (it plays no "
            "more until an operator makes it active again)"),
    Setting("jobs.live_per_owner", int, 10, 1, 10**6, "jobs one owner may have queued or running at once "
            "(uploads' validations, placements, tree verifications and previews, replays; administrators are not "
            "limited); past it, requests are refused until some finish or are cancelled"),
    Setting("jobs.max_seconds", int, 3600, 1, 7 * 86400, "wall-clock seconds an evaluation or placement job may "
            "play; past them it stops, and reports the matches it did not play"),
    Setting("rank.max_budget", int, 5000, 2, 10**7, "the most matches one placement may play (`rank --budget`, "
            "a placement queued on the web); a larger budget is refused"),
    Setting("trees.per_owner", int, 100, 1, 10**6, "social trees one owner may keep saved (administrators are not "
            "limited); past it, saving another is refused until some are deleted"),
    Setting("web.upload_mib", int, 300, 1, 1 << 16, "the most an upload to the web service may hold (MiB); the "
            "artifact's own limits apply as well"),
    Setting("web.uploads_per_hour", int, 30, 1, 10**6, "uploads one owner may make to the web service in an hour "
            "(administrators are not limited)"),
    Setting("web.uploads_in_flight_per_owner", int, 2, 1, 10**4, "uploads one owner may be sending to one web "
            "server at once; another is refused (429) before its body is read"),
    Setting("web.uploads_in_flight", int, 8, 1, 10**5, "uploads one web server receives at once, from everyone; "
            "another is refused (429) before its body is read"),
    Setting("web.body_idle_seconds", int, 30, 1, 3600, "seconds an upload's body may stall (no bytes arrive) "
            "before the web server abandons it (408) and gives its slot in flight back"),
    Setting("web.body_min_kib_per_second", int, 16, 0, 10**6, "the slowest an upload's body may arrive on "
            "average (KiB/s), checked once it has streamed for web.body_idle_seconds; slower, it is abandoned (408) "
            "and its slot given back; 0 checks no rate"),
    Setting("web.live_games", int, 8, 0, 10**4, "people one web server lets play in the browser at once (each "
            "steps a game on the server); 0 turns /play off"),
    Setting("web.live_idle_seconds", int, 600, 10, 86400, "seconds a browser game waits for its player's move "
            "(nothing else counts) before it resigns the match and closes"),
    Setting("web.live_matches_per_minute", int, 6, 1, 600, "matches one browser game may start in a minute (each "
            "played match is stored and ranked); past it the next waits"),
    Setting("web.live_games_per_owner", int, 2, 1, 10**4, "browser games one owner (a guest: one guest name) may "
            "have open on one web server at once"),
    Setting("web.live_games_per_address", int, 4, 1, 10**4, "browser games one network address may have open on "
            "one web server at once (guests and owners together)"),
)}


def _require(key: str) -> Setting:
    if key not in SETTINGS:
        raise ValueError(f"there is no setting {key!r}.{did_you_mean(key, SETTINGS)} The settings are: "
                         f"{', '.join(SETTINGS)}")
    return SETTINGS[key]


def league_settings(league: League) -> dict[str, dict[str, Any]]:
    """Every setting: ``value`` (what applies), ``default``, ``changed`` and ``help``, by key."""
    with league.reading() as session:
        stored = reg.read_settings(session)
    out = {}
    for key, setting in SETTINGS.items():
        value = setting.parse(stored[key]) if key in stored else setting.default
        out[key] = {"value": value, "default": setting.default, "changed": key in stored, "help": setting.help}
    return out


def set_setting(league: League, key: str, value: str | int | float) -> int | float:
    """Store ``value`` for ``key`` (checked first); returns it as stored."""
    setting = _require(key)
    parsed = setting.parse(value)
    with league.transaction() as session:
        reg.write_setting(session, key, parsed)
    return parsed


def reset_setting(league: League, key: str) -> Any:
    """Forget the league's value of ``key``; returns the default that applies again."""
    setting = _require(key)
    with league.transaction() as session:
        reg.delete_setting(session, key)
    return setting.default


def sandbox_limits(league: League, values: Mapping[str, Mapping[str, Any]] | None = None) -> SandboxLimits:
    """The league's inference-sandbox budgets (from ``values``, :func:`league_settings` already read,
    when given)."""
    values = values if values is not None else league_settings(league)
    return SandboxLimits(**{f.name: values[f"sandbox.{f.name}"]["value"] for f in fields(SandboxLimits)})


def suspend_after(league: League, values: Mapping[str, Mapping[str, Any]] | None = None) -> int:
    """Forfeits after which an agent is suspended (from ``values`` when given)."""
    values = values if values is not None else league_settings(league)
    return int(values["forfeits.suspend_after"]["value"])


def job_max_seconds(league: League, values: Mapping[str, Mapping[str, Any]] | None = None) -> int:
    """Wall-clock seconds an evaluation or placement job may play (from ``values`` when given)."""
    values = values if values is not None else league_settings(league)
    return int(values["jobs.max_seconds"]["value"])


def check_rank_budget(league: League, budget: Any, more: Any = None) -> None:
    """Refuse a placement's budget that is not a whole number of matches from 2 to the league's
    ``rank.max_budget``, or ``more`` matches that are not a whole number from 1 to that limit,
    with the same message whichever front end asked."""
    if isinstance(budget, bool) or not isinstance(budget, int) or budget < 2:
        raise ValueError(f"a placement's budget is a whole number of matches, at least 2, not {budget!r}; give "
                         "--budget 200 (the default), for example")
    if more is not None and (isinstance(more, bool) or not isinstance(more, int) or more < 1):
        raise ValueError(f"more must be a whole number of matches, at least 1, not {more!r}; give --more 50, "
                         "for example")
    limit = int(league_settings(league)["rank.max_budget"]["value"])
    flag, asked = ("--budget", budget) if more is None else ("--more", more)  # with more, the budget is not played
    if asked > limit:
        raise ValueError(f"{flag} {asked} is over {limit}, the most matches one placement may play in this "
                         f"league (the setting rank.max_budget); give {flag} {limit} or less, or raise the "
                         "setting with `arena-league settings set rank.max_budget N`")
