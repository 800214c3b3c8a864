"""Candidates besides the training runs' snapshots: an earlier population's members and built-in
agents (search agents at their budgets, tuned heuristics), and how the provenance names them."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from arena_league.league.population.loading import bundle_weights
from arena_league.league.population.records import (
    REFERENCES,
    SCRIPTED_SCHEME,
    TUNED_SCHEME,
    Candidate,
    jsonable,
)


def base_manifest(folder: Path, game_id: str) -> dict[str, Any]:
    """The ``population.json`` of the base population at ``folder``, which must be ``game_id``'s."""
    path = folder / "population.json"
    if not path.is_file():
        raise ValueError(f"base {folder} holds no population.json; give a frozen population folder such as "
                         f"checkpoints/{game_id}/base-v1")
    manifest = json.loads(path.read_text())
    if manifest.get("game_id") != game_id:
        raise ValueError(f"base {folder} is a population of {manifest.get('game_id')}, not of {game_id}")
    return manifest


def base_candidates(folder: Path, manifest: Mapping[str, Any], retire: Sequence[str] = ()) -> list[Candidate]:
    """The members of the frozen population at ``folder`` as candidates (keys and records as built),
    but for those whose keys ``retire`` names."""
    weights = {member: (arch, params) for arch, members, stacked in bundle_weights(folder)
               for member, params in zip(members, stacked)}
    prefix = f"{manifest['name']}."
    candidates = []
    for entry in manifest["members"]:
        meta = entry["metadata"]
        key = entry["name"].removeprefix(prefix).rsplit("@", 1)[0]
        scripted = (entry.get("agent_metadata") or {}).get("scripted") if entry.get("kind") == "scripted" else None
        arch, params = weights.get(entry["name"], (None, {}))
        if scripted is None and arch is None:
            raise ValueError(f"base {folder}: member {entry['name']} is in no bundle; the folder is damaged")
        candidates.append(Candidate(key, meta["scheme"], int(meta["steps"]), int(meta["seed"]), meta["learner"],
                                    arch, dict(params), meta.get("warm_start"), scripted))
    retired = set(retire)
    unknown = sorted(retired - {c.key for c in candidates})
    if unknown:
        raise ValueError(f"retire names {', '.join(map(repr, unknown))}, not a member of base {folder}; name members "
                         f"by their keys, as in its population.json without `{prefix}` and `@{manifest['game_id']}` "
                         f"(e.g. {candidates[-1].key!r})")
    if len(retired) != len(retire):
        raise ValueError(f"retire names a member twice: {list(retire)!r}")
    return [c for c in candidates if c.key not in retired]


def scripted_names(game_id: str, names: Sequence[str]) -> list[str]:
    """The built-in agents that join the candidates (search agents at their budgets, tuned
    heuristics), without the ``scripted:`` prefix, checked before any training."""
    from arena_league.policies.scripted import SCRIPTED_PREFIX, scripted_policy

    bare = [n.removeprefix(SCRIPTED_PREFIX) for n in names]
    if len(set(bare)) != len(bare) or set(bare) & set(REFERENCES):
        raise ValueError(f"scripted members must be distinct and not the references {REFERENCES}, got {list(names)}")
    for n in bare:
        scripted_policy(n, game_id)  # unknown names, bad budgets and games without search fail here
    return bare


def scripted_scheme(name: str) -> str:
    """The scheme recorded for built-in member ``name``: ``search`` or ``tuned``."""
    from arena_league.policies.scripted import search_budget

    return SCRIPTED_SCHEME if search_budget(name) is not None else TUNED_SCHEME


def origin_of(base: str | Path | None, manifest: Mapping[str, Any] | None, scripted: list[str],
            top: Sequence[Mapping[str, Any]], retire: Sequence[str] = ()) -> dict[str, Any] | None:
    """Where candidates other than the schemes' runs came from, for the provenance."""
    if manifest is None and not scripted and not top:
        return None
    origin: dict[str, Any] = {"scripted": scripted, "top_runs": jsonable(list(top))}
    if manifest is not None:
        origin["base"] = {"name": manifest["name"], "version": manifest.get("version", 1),
                          "build_id": manifest.get("provenance", {}).get("build", {}).get("build_id"),
                          "members": len(manifest["members"]) - len(retire), "path": str(base)}
        if retire:  # absent otherwise, so that earlier builds' ids stay what they were
            origin["base"]["retired"] = sorted(retire)
    return origin
