"""The names people choose: agents, token owners, guests and saved trees, under one policy.

A name shows on public pages next to others, so it must look like what it is and like no one
else's:

* **one form**: a name is refused unless it already is its Unicode NFKC form (``alice`` with a
  fullwidth ``a`` is refused, naming ``alice``), so two spellings never show as the same name;
* **nothing hidden**: no control, format (zero-width, right-to-left override), private-use,
  unassigned or space character anywhere (only a saved tree's name may hold plain spaces between
  words); a name starts with a letter or digit of any script and holds letters, digits and
  ``. _ @ + -``;
* **no look-alike**: a new agent name may not share its UTS #39 skeleton (ICU's
  ``SpoofChecker.getSkeleton``: ``a1ice`` and ``alice`` with a Cyrillic ``a`` both read
  ``alice``) with another name of the same game, nor a new owner with another owner;
* **the human namespace**: a person who plays in the browser is the agent ``<owner>@<game>``, a
  guest ``guest-<name>@<game>``. No upload may take a name of that shape (``@`` then a game id,
  or one starting ``guest-``, look-alikes included), and no owner may be named ``guest-...`` or
  hold an ``@``, so a guest, an owner and a submission can never share an agent. The game part
  is compared casefolded (``alice@gobang-2t1p-v1`` is refused too);
* **the league's members**: a member of a base population is ``base-v<N>.<member>@<game>``, so no
  upload may start ``base-v<N>.``;
* **a clean end**: an agent or owner name ends in a letter or digit, so ``alice@GoBang-2T1P-v1.``
  cannot pass for ``alice@GoBang-2T1P-v1``; and no owner may be another owner in other case
  (``ALICE`` beside ``alice``).

Names already stored keep working; the policy applies where a name enters the league.
"""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Iterable
from functools import lru_cache
from typing import Any

from arena_league.league.errors import ForbiddenError

__all__ = ["GUEST_PREFIX", "agent_name_problem", "check_guest_name", "check_owner_name", "check_tree_name",
           "confusable_twin", "human_name_reason", "member_name_reason", "refuse_confusable", "skeleton",
           "suggested_name"]

#: Guests play under ``guest-<name>``, a prefix no owner and no upload can take.
GUEST_PREFIX = "guest-"
#: Unicode categories no name may hold: controls, format characters (zero-width, bidi overrides),
#: surrogates, private use, unassigned, and every kind of space or line separator.
_HIDDEN = {"Cc": "a control character", "Cf": "an invisible format character", "Cs": "a surrogate",
           "Co": "a private-use character", "Cn": "an unassigned character", "Zs": "a space",
           "Zl": "a line separator", "Zp": "a paragraph separator"}
_AGENT_PUNCTUATION = "._@+-"
_OWNER_PUNCTUATION = "._+-"
_GUEST_PUNCTUATION = "._-"
_TREE_PUNCTUATION = " ._-"
#: The head of a base population's member name, ``base-v<N>`` (before its ``.``).
_POPULATION_HEAD = re.compile(r"(.*?)(\d+)")


def _describe(char: str) -> str:
    return f"U+{ord(char):04X} {unicodedata.name(char, '').lower()}".rstrip()


def _form_problem(name: object, what: str, punctuation: str, longest: int, later: str = "",
                  clean_end: bool = False) -> str | None:
    """Why ``name`` is not a well-formed name (one line naming the fix), or None; characters of
    ``later`` pass here for the caller to refuse with its own reason; ``clean_end``: it must end
    in a letter or digit too."""
    allowed = (f"use 1 to {longest} letters, digits and {' '.join(p if p != ' ' else 'spaces' for p in punctuation)}"
               f", starting {'and ending ' if clean_end else ''}with a letter or digit")
    if not isinstance(name, str) or not name:
        return f"{what} is empty: {allowed}"
    if len(name) > 4 * longest:  # no normal form shortens a name this much: refused before reading it
        return f"{what} {name[:24]!r}... is {len(name)} characters long: {allowed}"
    normal = unicodedata.normalize("NFKC", name)
    for index, char in enumerate(name):
        category = unicodedata.category(char)
        if category in _HIDDEN and not (char == " " and " " in punctuation):
            return (f"{what} {name!r} holds {_HIDDEN[category]} ({_describe(char)}) at position {index + 1}, "
                    f"which would not show on a page: {allowed}")
    if normal != name:
        return (f"{what} {name!r} is not in Unicode normal form (NFKC), so it would show like {normal!r}; write it "
                f"{normal!r} instead")
    if len(name) > longest:
        return f"{what} {name[:24]!r}... is {len(name)} characters long: {allowed}"
    if not name[0].isalnum():
        return f"{what} {name!r} does not start with a letter or digit: {allowed}"
    for char in name:
        if not (char.isalnum() or char in punctuation or char in later):
            return f"{what} {name!r} holds {char!r} ({_describe(char)}), which names may not hold: {allowed}"
    if punctuation.startswith(" ") and name.endswith(" "):
        return f"{what} {name!r} ends in a space: {allowed}"
    if clean_end and not name[-1].isalnum():
        return (f"{what} {name!r} ends in {name[-1]!r}: a name must end in a letter or digit (so it cannot pass "
                "for another name); drop the trailing punctuation or end the name with a letter or digit")
    return None


@lru_cache(maxsize=1)
def _checker() -> Any:  # built once: building it reads ICU's confusables data
    import icu

    return icu.SpoofChecker()


@lru_cache(maxsize=1 << 16)
def skeleton(name: str) -> str:
    """The UTS #39 skeleton of ``name``: equal skeletons mean the names can be mistaken for each other."""
    return _checker().getSkeleton(0, name)


def confusable_twin(name: str, existing: Iterable[str]) -> str | None:
    """The first of ``existing`` that differs from ``name`` but shares its skeleton, or None."""
    mark = skeleton(name)
    return next((other for other in existing if other != name and skeleton(other) == mark), None)


def refuse_confusable(name: str, existing: Iterable[str], what: str, where: str) -> None:
    """Raise :class:`ForbiddenError` when ``name`` can be mistaken for one of ``existing``."""
    twin = confusable_twin(name, existing)
    if twin is not None:
        raise ForbiddenError(f"{what} {name!r} can be mistaken for {twin!r}, already {where} (they look alike under "
                             "Unicode's confusables table, UTS #39); choose a name that looks like no other")


def suggested_name(name: str) -> str:
    """A name near ``name`` outside the human namespace: ``guest-`` dropped, each ``@`` a ``-``."""
    bare = name[len(GUEST_PREFIX):] if name.casefold().startswith(GUEST_PREFIX) else name
    return ("my-" + bare.replace("@", "-")).strip("-")[:128]


def human_name_reason(name: str, game_ids: Iterable[str]) -> str | None:
    """Why ``name`` is in the namespace of the agents people play as, or None: ``guest-...``, or
    ``...@<game>`` for a game of ``game_ids`` (look-alikes of either included)."""
    if skeleton(name.casefold()).startswith(skeleton(GUEST_PREFIX)):
        return f"{name} starts with {GUEST_PREFIX!r}, which names the agents of guests who play in the browser"
    if "@" in name:
        games = {skeleton(game.casefold()): game for game in game_ids}
        for part in name.split("@")[1:]:
            game = games.get(skeleton(part.casefold()))
            if game is not None:
                return (f"{name} has the shape <player>@{game}, which names the agent a person plays as in the "
                        "browser")
    return None


def member_name_reason(name: str) -> str | None:
    """Why ``name`` has the shape of a base population's member, ``base-v<N>.<member>`` (look-alikes
    and other case included), or None."""
    head, dot, _ = name.partition(".")
    found = _POPULATION_HEAD.fullmatch(head)
    if dot and found and skeleton(found[1].casefold()) == skeleton("base-v"):
        return (f"{name} starts with {head + dot!r}, the shape of a member of the league's base population "
                f"{head} (base-v<N>.<member>)")
    return None


def agent_name_problem(name: object) -> str | None:
    """Why ``name`` is no well-formed agent name to submit under (one line), or None."""
    problem = _form_problem(name, "agent name", _AGENT_PUNCTUATION, 128, later=":", clean_end=True)
    if problem is None and ":" in str(name):
        problem = (f"agent name {name!r} is not allowed: it holds ':', and versions are named for you (name:v2, "
                   "name:v3 ...); submit under the name alone")
    return problem


def check_owner_name(owner: object, existing: Iterable[str] = ()) -> None:
    """Refuse an owner name that is malformed (``ValueError``), in the guests' namespace or
    holding ``@``, or a look-alike of an owner of ``existing`` in any case (:class:`ForbiddenError`)."""
    if isinstance(owner, str) and "@" in owner:
        raise ForbiddenError(f"owner {owner!r} holds '@', which the league keeps for the agents people play as "
                             f"(<owner>@<game>); name the owner e.g. {owner.replace('@', '-')!r}")
    problem = _form_problem(owner, "owner", _OWNER_PUNCTUATION, 128, clean_end=True)
    if problem is not None:
        raise ValueError(problem + " (it names who owns the agents uploaded with the token)")
    assert isinstance(owner, str)
    if skeleton(owner.casefold()).startswith(skeleton(GUEST_PREFIX)):
        raise ForbiddenError(f"owner {owner!r} starts with {GUEST_PREFIX!r}, which the league keeps for guests who "
                             f"play in the browser; name the owner e.g. {suggested_name(owner)!r}")
    mark = skeleton(owner.casefold())
    twin = next((other for other in existing if other != owner and skeleton(other.casefold()) == mark), None)
    if twin is not None:
        raise ForbiddenError(f"owner {owner!r} can be mistaken for {twin!r}, already an owner of this league (they "
                             "look alike in other case or under Unicode's confusables table, UTS #39); choose a "
                             "name that looks like no other")


def check_guest_name(guest: object) -> None:
    """Refuse (``ValueError``) a guest name that is not well formed."""
    problem = _form_problem(guest, "guest name", _GUEST_PUNCTUATION, 32)
    if problem is not None:
        raise ValueError(problem + " (or sign in to play as yourself)")


def check_tree_name(name: object) -> None:
    """Refuse (``ValueError``) a saved tree's name that is not well formed."""
    problem = _form_problem(name, "tree name", _TREE_PUNCTUATION, 64)
    if problem is not None:
        raise ValueError(problem)
