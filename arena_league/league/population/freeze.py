"""Freezing a built population: its folder (population.json, the stacked bundles, a folder per
member, the README), written whole or not at all, and its registration in a league."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
from collections.abc import Mapping
from dataclasses import asdict
from pathlib import Path
from typing import Any

import torch
from safetensors.torch import save_file

from arena_league.league.population.options import BuildOptions
from arena_league.league.population.readme import population_readme
from arena_league.league.population.recipes import DEFAULT_FLOOR_MARGIN, Recipe
from arena_league.league.population.records import BuildReport, Candidate, MemberRecord, jsonable, write_json
from arena_league.league.population.runs import TrainingPlan
from arena_league.policies.architecture import Architecture, check_parameters
from arena_league.policies.artifacts import save_arena_policy

POPULATION_FORMAT = "arena-population"
BUNDLE_FORMAT = "arena-population-bundle"
FORMAT_VERSION = 1


def build_id_of(game_id: str, name: str, schemes: list[str], steps: Mapping[str, int], seed: int, snapshots: int,
              size: int, matches_per_pair: int, digest: str, runs: Mapping[str, int],
              warm: Mapping[str, Any] | None = None, origin: Mapping[str, Any] | None = None,
              floor_margin: float = DEFAULT_FLOOR_MARGIN) -> str:
    """The id of a build: the digest of what decides its members, so that a rebuild knows its own folder."""
    parts: list[Any] = [game_id, name, schemes, dict(steps), seed, snapshots, size, matches_per_pair, digest]
    if any(n != 1 for n in runs.values()):
        parts.append(dict(runs))
    if warm:
        parts.append(jsonable(warm))
    if origin:
        parts.append({**origin, "base": {k: v for k, v in (origin.get("base") or {}).items() if k != "path"}})
    if floor_margin != DEFAULT_FLOOR_MARGIN:
        parts.append({"floor_margin": floor_margin})
    identity = json.dumps(parts)
    return hashlib.sha256(identity.encode()).hexdigest()[:16]


def freeze(out: Path, report: BuildReport, members: list[Candidate], build_id: str, options: BuildOptions,
           recipe: Recipe, plan: TrainingPlan, origin: Mapping[str, Any] | None, floor_margin: float) -> None:
    """Write the population folder ``out`` (staged beside it, then moved into place whole), its
    provenance read from the build's ``options``, ``recipe`` and training ``plan``."""
    overwrite, matches_per_pair, verify_matches = options.overwrite, options.matches_per_pair, options.verify_matches
    max_candidates, scheme_options = options.max_candidates, options.scheme_options
    snapshots, runs, warm = plan.snapshots, plan.runs_per_scheme, plan.warm_build()
    manifest_path = out / "population.json"
    if manifest_path.exists() and not overwrite:
        existing = json.loads(manifest_path.read_text()).get("provenance", {}).get("build", {}).get("build_id")
        if existing != build_id:
            raise ValueError(f"{out} holds a population built with other arguments (build {existing}); pass "
                             "overwrite=True to replace it, or another out_dir or name")
    staging = out.with_name(out.name + ".partial")
    shutil.rmtree(staging, ignore_errors=True)
    (staging / "agents").mkdir(parents=True)
    by_key = {m.key: m for m in members}
    records = {r.key: r for r in report.members}
    # one stacked bundle per architecture, members in rating order (weakest first)
    groups: dict[Architecture, list[Candidate]] = {}
    for m in sorted(members, key=lambda m: records[m.key].rating):
        if not m.scripted:
            groups.setdefault(m.architecture, []).append(m)
    bundles = []
    for k, (arch, group) in enumerate(groups.items()):
        file = f"{arch.family}-{k}.safetensors"
        tensors = {param: torch.stack([check_parameters(arch, m.params)[param] for m in group])
                   for param in arch.parameter_shapes()}
        header = {"family": arch.family, "sizes": arch.sizes(), "spaces": arch.spaces(),
                  "game": report.game_id, "members": [records[m.key].name for m in group]}
        save_file(tensors, str(staging / file), metadata={"format": BUNDLE_FORMAT,
                                                           "format_version": str(FORMAT_VERSION),
                                                           "bundle": json.dumps(header, sort_keys=True)})
        bundles.append({"file": file, **header})
        for i, m in enumerate(group):
            records[m.key].bundle, records[m.key].bundle_index = file, i
    entries = []
    for record in sorted(report.members, key=lambda r: r.rating):
        member = by_key[record.key]
        if member.scripted:
            entries.append(_scripted_entry(record, report.name))
            continue
        provenance = {"scheme": record.scheme, "game": report.game_id, "steps": record.steps, "seed": record.seed,
                      "learner": record.learner, "population": report.name, "rating": record.rating,
                      "rating_interval": [record.rating_lower, record.rating_upper],
                      "warm_start": record.warm_start}
        save_arena_policy(staging / record.artifact, member.architecture, member.params, report.game_id,
                          name=record.name, provenance=provenance,
                          description=f"{record.scheme} snapshot after {record.steps} env steps (seed {record.seed}), "
                                      f"member of {report.name}")
        entries.append({
            "name": record.name, "kind": "base", "artifact": record.artifact, "format": "arena-policy",
            "bundle": record.bundle, "bundle_index": record.bundle_index,
            "metadata": {"rating": record.rating, "rating_lower": record.rating_lower,
                         "rating_upper": record.rating_upper, "rank": record.rank, "scheme": record.scheme,
                         "steps": record.steps, "seed": record.seed, "learner": record.learner,
                         "warm_start": record.warm_start},
            "agent_metadata": {"scheme": record.scheme, "steps": record.steps, "seed": record.seed,
                               "learner": record.learner, "population": report.name,
                               "warm_start": record.warm_start,
                               "family": member.architecture.family}})
    figures = asdict(report.figures) if report.figures else {}
    manifest = {
        "format": POPULATION_FORMAT, "format_version": FORMAT_VERSION, "name": report.name, "version": 1,
        "game_id": report.game_id, "frozen": True,
        "provenance": {
            "build": {"build_id": build_id, "schemes": report.schemes, "steps_per_scheme": report.steps_per_scheme,
                      "runs_per_scheme": dict(runs), "seed": report.seed, "snapshots_per_run": snapshots, "candidates": report.candidates,
                      "max_candidates": max_candidates, "matches_per_pair": matches_per_pair,
                      "floor_margin": floor_margin,
                      "verify_matches": verify_matches,
                      "recipe": {"hidden": list(recipe.hidden), "early_snapshots": recipe.early_snapshots,
                                 "warm_overrides": jsonable(recipe.warm_overrides),
                                 "common": jsonable(recipe.common),
                                 "per_scheme": jsonable(recipe.per_scheme)},
                      "scheme_options": jsonable(scheme_options or {}), "warm_runs": jsonable(warm),
                      **({"base": origin.get("base"), "scripted": origin["scripted"],
                          "top_runs": origin["top_runs"]} if origin else {}),
                      "code": _code_version()},
            "figures": figures, "criteria": report.criteria, "passed": report.passed,
            "rating": "Bradley-Terry (Elo scale, members' mean 1000) with a seat term, over the round robin among "
                      "members and the scripted random and heuristic agents; 95% bootstrap intervals",
            "references": {"random": figures.get("random_rating"), "heuristic": figures.get("heuristic_rating")}},
        "bundles": bundles,
        "members": entries,
    }
    write_json(staging / "population.json", manifest)
    (staging / "README.md").write_text(population_readme(manifest))
    if out.exists():
        shutil.rmtree(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    os.replace(staging, out)


def _scripted_entry(record: MemberRecord, population: str) -> dict[str, Any]:
    """The ``population.json`` entry of a built-in member: no artifact, its name and budget instead."""
    from arena_league.policies.scripted import heuristic_options, search_budget

    assert record.scripted is not None
    budget = search_budget(record.scripted)
    if budget is None:
        budget = {"options": heuristic_options(record.scripted)}
    metadata = {"rating": record.rating, "rating_lower": record.rating_lower, "rating_upper": record.rating_upper,
                "rank": record.rank, "scheme": record.scheme, "steps": record.steps, "seed": record.seed,
                "learner": record.learner, "warm_start": None, "budget": budget}
    return {"name": record.name, "kind": "scripted", "artifact": None, "format": "scripted",
            "bundle": "", "bundle_index": -1, "metadata": metadata,
            "agent_metadata": {"scripted": record.scripted, "scheme": record.scheme, "population": population,
                               "budget": budget}}


def register(league: Any, out: Path, name: str, member_names: list[str]) -> str:
    """Import the frozen population unless the league already holds it with these members."""
    from arena_league import registry as reg
    from arena_league.league.populations import import_population

    with league.reading() as session:
        for population in reg.list_populations(session):
            if population.name == name and sorted(m.agent.name for m in population.members) == sorted(member_names):
                return f"{population.name}:{population.version}"
    return import_population(league, out)


def _code_version() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], check=False, capture_output=True, text=True,
                             timeout=5, cwd=Path(__file__).resolve().parent)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"
