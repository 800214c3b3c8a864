"""The options of a base-population build, declared once: the library and the command read them here.

:class:`BuildOptions` is what :func:`arena_league.league.population.build.build_population` takes;
``arena-league population build`` makes its command-line options from the fields that carry a
``flag`` (:func:`command_line_options`), with the field's default and one-line doc, so that no
default is written twice. This module imports nothing heavy: the command builds its parser from it
for every command, including those that never build a population.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["BACKENDS", "STAGES", "BuildOptions", "BuildProgress", "CommandLineOption", "command_line_options"]

#: The stages of a build, in order; ``stop_after`` names one.
STAGES: tuple[str, ...] = ("train", "round_robin", "select", "freeze", "register")

#: Where a build's training runs and round-robin chunks run (:attr:`BuildOptions.backend`).
BACKENDS: tuple[str, ...] = ("local", "ray")

#: A build's progress callback: ``progress(stage, done, total)``.
BuildProgress = Callable[[str, int, int], None]


def _doc(doc: str, *, flag: str | None = None, kind: str = "text", default_text: str | None = None,
         metavar: str | None = None) -> dict[str, Any]:
    """The metadata of a field of :class:`BuildOptions`: its one-line doc and, when the command
    takes it, its flag, the kind of value the flag reads (``positive``, ``non_negative``, ``seed``,
    ``text``, ``texts``: one or more words) and how its default reads in the help."""
    return {"doc": doc, "flag": flag, "kind": kind, "default_text": default_text, "metavar": metavar}


@dataclass(frozen=True)
class BuildOptions:
    """How :func:`~arena_league.league.population.build.build_population` builds a population;
    every field has the default the command shows."""

    size: int = field(default=100, metadata=_doc(
        "members of the population (Arena: 100)", flag="--size", kind="positive"))
    name: str = field(default="base-v1", metadata=_doc(
        "the population's name; members are named <name>.<key>@<game>", flag="--name"))
    schemes: Sequence[str] | None = field(default=None, metadata=_doc(
        "training schemes ('none' on the command line: train nothing, with a base or scripted members)",
        flag="--schemes", kind="texts", default_text="per game: sp pbt dppo, plus cc in team games"))
    steps_per_scheme: int | Mapping[str, int] | None = field(default=None, metadata=_doc(
        "env steps of each run, one number or one per scheme", flag="--steps", kind="positive",
        default_text="the game's recipe"))
    runs_per_scheme: int | Mapping[str, int] = field(default=1, metadata=_doc(
        "runs (seeds seed, seed + 1, ...) of each scheme from scratch, one number or one per scheme",
        flag="--runs", kind="positive"))
    warm_runs_per_scheme: int | Mapping[str, int] | None = field(default=None, metadata=_doc(
        "more runs of each scheme whose learners first imitate the game's heuristic (0: none)",
        flag="--warm-runs", kind="non_negative", default_text="the game's recipe"))
    warm_steps_per_scheme: int | Mapping[str, int] | None = field(default=None, metadata=_doc(
        "RL env steps of each warm-started run (default: the recipe's, or steps_per_scheme when given)"))
    warm_start: Mapping[str, Any] | Sequence[Mapping[str, Any]] | None = field(default=None, metadata=_doc(
        "WarmStart fields of the warm-started runs, or a list of them taken in turn (default: the recipe's)"))
    seed: int = field(default=0, metadata=_doc(
        "seed of the first run of every scheme and of the match schedule: same seed, same result",
        flag="--seed", kind="seed"))
    work_dir: str | Path | None = field(default=None, metadata=_doc(
        "runs and matches as they are made (a rerun with the same options resumes from here)",
        flag="--work-dir", default_text="runs/population/GAME/NAME"))
    out_dir: str | Path | None = field(default=None, metadata=_doc(
        "the frozen population", flag="--out-dir", default_text="checkpoints/GAME/NAME"))
    matches_per_pair: int = field(default=2, metadata=_doc(
        "round-robin matches per pair of candidates, seats balanced (the shipped populations' READMEs give theirs)",
        flag="--matches-per-pair", kind="positive"))
    verify_matches: int = field(default=200, metadata=_doc(
        "extra matches of the best member against the worst and against the heuristic"))
    snapshots: int | None = field(default=None, metadata=_doc("snapshots per run (default: the recipe's)"))
    scheme_options: Mapping[str, Mapping[str, Any]] | None = field(default=None, metadata=_doc(
        "overrides of run_scheme per scheme, over the recipe's ({'pbt': {'population_size': 2}})"))
    max_candidates: int = field(default=240, metadata=_doc(
        "trained snapshots in the round robin at most (thinned evenly per learner, its first and last kept)"))
    floor_margin: float | None = field(default=None, metadata=_doc(
        "members are rated this far above the random agent, Elo (default: the recipe's)"))
    bootstrap_rounds: int = field(default=200, metadata=_doc("bootstrap rounds of the members' rating intervals"))
    batch_size: int = field(default=256, metadata=_doc("matches in flight on the batched match engine"))
    overwrite: bool = field(default=False, metadata=_doc(
        "replace an out_dir that holds a population built with other options"))
    stop_after: str | None = field(default=None, metadata=_doc(
        "stop after this stage (train, round_robin, select, freeze); the report says how far it got"))
    base: str | Path | None = field(default=None, metadata=_doc(
        "a frozen population of the game whose members join the candidates (base-v2 from base-v1)",
        flag="--base", metavar="FOLDER", default_text="none"))
    scripted: Sequence[str] = field(default=(), metadata=_doc(
        "built-in agents that join the candidates, e.g. search-w8-r4-h30-e0.1 (GoBang), search-w3-r1-h4 (Snake), "
        "search-w8-r1-h40-v2 (FightForFood)", flag="--scripted", kind="texts", metavar="AGENT", default_text="none"))
    top_runs: Sequence[Mapping[str, Any]] | None = field(default=None, metadata=_doc(
        "runs with their own options for the top, seeds from seed + 1000 (default: the recipe's)"))
    retire: Sequence[str] = field(default=(), metadata=_doc(
        "keys of base members left out (e.g. search-w4-r1-h40: superseded by its -v2)", flag="--retire",
        kind="texts", metavar="KEY", default_text="none"))
    processes: int = field(default=1, metadata=_doc(
        "processes that train runs and play round-robin chunks side by side (the population is the same for "
        "any number)", flag="--processes", kind="positive"))
    backend: str = field(default="local", metadata=_doc(
        "where training runs and round-robin chunks run: local (here, or in --processes worker processes) or ray "
        "(each a Ray task; the work folder must be on storage every node reads and writes; the population is the "
        "same)", flag="--backend", metavar="{local,ray}"))
    ray_address: str | None = field(default=None, metadata=_doc(
        "the Ray cluster to join with --backend ray (ray start's head address, HOST:PORT)", flag="--address",
        default_text="$RAY_ADDRESS, else a local instance of --processes CPUs"))

    def replaced(self, fields: Mapping[str, Any]) -> BuildOptions:
        """These options with ``fields`` changed; a name that is no field is refused with the known ones."""
        known = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(fields) - known)
        if unknown:
            raise TypeError(f"BuildOptions has no {', '.join(unknown)}; its fields are {', '.join(sorted(known))}")
        return dataclasses.replace(self, **fields) if fields else self

    def check(self) -> None:
        """Refuse options no build can use, before anything is trained."""
        if self.stop_after is not None and self.stop_after not in STAGES:
            raise ValueError(f"stop_after must be one of {', '.join(STAGES)}, not {self.stop_after!r}")
        if self.size < 2:
            raise ValueError(f"a population needs at least 2 members, not {self.size}")
        if self.matches_per_pair < 1 or self.verify_matches < 1:
            raise ValueError("matches_per_pair and verify_matches must be at least 1")
        if isinstance(self.processes, bool) or not isinstance(self.processes, int) or self.processes < 1:
            raise ValueError(f"processes must be a whole number, at least 1, not {self.processes!r}")
        if self.backend not in BACKENDS:
            raise ValueError(f"backend must be one of {', '.join(BACKENDS)}, not {self.backend!r}")
        if self.ray_address is not None and self.backend != "ray":
            raise ValueError(f"a Ray address ({self.ray_address}) is for the ray backend; add --backend ray")


@dataclass(frozen=True)
class CommandLineOption:
    """A field of :class:`BuildOptions` that ``population build`` takes as a flag."""

    field: str
    flag: str
    kind: str
    default: Any
    help: str
    metavar: str | None


def command_line_options() -> list[CommandLineOption]:
    """The fields ``population build`` takes, in declaration order, each with its help (the field's
    doc and its default)."""
    found = []
    for f in dataclasses.fields(BuildOptions):
        meta = f.metadata
        if meta.get("flag") is None:
            continue
        shown = meta["default_text"] if meta["default_text"] is not None else f.default
        found.append(CommandLineOption(f.name, meta["flag"], meta["kind"], f.default,
                                       f"{meta['doc']} (default {shown})", meta["metavar"]))
    return found
