"""The README of a frozen population: provenance, figures and criteria, members per scheme, and the
call that rebuilds it."""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Mapping
from typing import Any

import numpy as np

from arena_league.envs import game_spec
from arena_league.league.population.candidates import scripted_scheme
from arena_league.league.population.recipes import DEFAULT_FLOOR_MARGIN, TOP_RUN_SEEDS
from arena_league.league.population.records import HEADROOM, SCRIPTED_SCHEME, TUNED_SCHEME, criteria_for
from arena_league.league.population.runs import imitation_ladder


def _members_line(manifest: Mapping[str, Any], figures: Mapping[str, Any]) -> str:
    """How many members, and what made them, in words."""
    schemes = dict(figures.get("schemes", {}))
    searchers, tuned = schemes.pop(SCRIPTED_SCHEME, 0), schemes.pop(TUNED_SCHEME, 0)
    line = f"{len(manifest['members'])} agents"
    if searchers or tuned:
        built_in = " and ".join(([f"{searchers} built-in search agents"] if searchers else [])
                                + ([f"{tuned} tuned heuristics"] if tuned else []))
        return f"{line}: {len(manifest['members']) - searchers - tuned} that {len(schemes)} training schemes " \
               f"produced and {built_in} above them"
    return f"{line} that {len(schemes)} training schemes produced"


def _candidates_line(build: Mapping[str, Any], game_id: str) -> str:
    """Where a build's candidates came from, in words."""
    parts = []
    base, scripted, top = build.get("base"), build.get("scripted") or [], build.get("top_runs") or []
    trained = build["candidates"] - (base or {}).get("members", 0) - len(scripted)
    if trained or not (base or scripted):
        parts.append(f"{trained} snapshots of the runs above" if build["schemes"] else
                     f"{trained} snapshots of the top runs")
    for text, count in Counter(json.dumps(run) for run in top).items():  # identical top runs said once
        run = json.loads(text)
        options = {k: v for k, v in run.items() if k not in ("scheme", "steps")}
        parts.append(f"{'a top run' if count == 1 else f'{count} top runs (seeds from seed + {TOP_RUN_SEEDS})'} of "
                     f"{run['scheme']} for {run['steps']:,} env steps, {json.dumps(options)}")
    if base:
        parts.append(f"the {base['members']} members of `{base['name']}` (build {base['build_id']}), rated again "
                     "with the others" + (f" ({len(base['retired'])} retired: "
                                          + ", ".join(f"`{k}`" for k in base["retired"]) + ")"
                                          if base.get("retired") else ""))
    from arena_league.envs import game_spec

    rules = game_spec(game_id).rules
    searchers = [n for n in scripted if scripted_scheme(n) == SCRIPTED_SCHEME]
    tuned = [n for n in scripted if scripted_scheme(n) == TUNED_SCHEME]
    if searchers:
        parts.append(f"{len(searchers)} built-in search agents over the game's own rules (scheme `search`; the "
                     f"budget is in the name, `search-wW-rR-hH-eE`: {rules.search_budget_meaning}): "
                     + ", ".join(f"`{n}`" for n in searchers))
    if tuned:
        parts.append(f"{len(tuned)} tuned heuristics, the game's heuristic with other constants (scheme `tuned`; "
                     "the constants are in the name, `heuristic-<option><value>`: "
                     f"{rules.heuristic_options_meaning}): " + ", ".join(f"`{n}`" for n in tuned))
    return f"{build['candidates']}: " + "; ".join(parts)


def population_readme(manifest: Mapping[str, Any]) -> str:
    """The README of a frozen population: provenance, figures and criteria, members per scheme."""
    prov = manifest["provenance"]
    build, figures = prov["build"], prov["figures"]
    game, name = manifest["game_id"], manifest["name"]
    runs = build.get("runs_per_scheme", {})
    steps = ", ".join(f"{s} {n:,}" + (f" (x{runs[s]} seeds)" if runs.get(s, 1) > 1 else "")
                      for s, n in build["steps_per_scheme"].items()) or \
        ("none besides the top runs below" if build.get("top_runs") else "none (this build trained nothing)")
    criteria_rows = "\n".join(
        f"| {criterion.replace('_', ' ')} | {figure} {comparison} {threshold:g} | {figures.get(figure)} | "
        f"{'yes' if prov['criteria'].get(criterion) else 'NO'} |"
        for criterion, (figure, comparison, threshold) in criteria_for(game).items())
    ratings = sorted(m["metadata"]["rating"] for m in manifest["members"])
    # a game played in pairs counts pairs (two matches from one start, roles swapped) where others count matches
    unit = "pairs" if game_spec(game).paired else "matches"
    schedule = (f"{build['matches_per_pair']} pair(s) per pair of agents (each two matches from one start, roles "
                "swapped)" if unit == "pairs" else f"{build['matches_per_pair']} matches per pair (seats balanced)")
    seat = figures.get("seat_term")
    seat_row = f"| seat term of the ratings | {seat['text']} |" if seat else ""
    by_scheme: dict[str, list[float]] = {}
    for m in manifest["members"]:
        by_scheme.setdefault(m["metadata"]["scheme"], []).append(m["metadata"]["rating"])
    scheme_rows = "\n".join(f"| {s} | {len(r)} | {min(r):.0f} | {np.median(r):.0f} | {max(r):.0f} |"
                            for s, r in sorted(by_scheme.items()))
    options = json.dumps(build["scheme_options"]) if build["scheme_options"] else "none"
    warm = build.get("warm_runs")
    warm_line = ""
    if warm:
        rungs = imitation_ladder(warm["warm_start"])
        imitation = {"expert": "scripted:heuristic", **rungs[0]}
        warm_line = (f"* warm-started runs: {json.dumps(warm['runs_per_scheme'])} per scheme (seeds after those from "
                     f"scratch), RL env steps {json.dumps(warm['steps_per_scheme'])}; before RL each learner imitates "
                     f"`{imitation['expert']}` by DAgger (`arena_league.training.imitation`, options "
                     f"{json.dumps(warm['warm_start'])}), as AlphaStar's league starts from imitation. Their members' "
                     f"keys read `<scheme>-ws-...`; members without `ws` were trained from scratch.\n")
    n_warm = sum(1 for m in manifest["members"] if m["metadata"].get("warm_start"))
    n_early = build["recipe"].get("early_snapshots", 0)
    wide = (f" (warm-started runs: {json.dumps(build['recipe']['warm_overrides'])})"
            if warm and build["recipe"].get("warm_overrides") else "")
    early = (f", plus {n_early} log-spaced ones before the first (at step 0, then 1/2, 1/4, ... of the interval)"
             if n_early else "")
    reproduce = (f"build_population({game!r}, BuildOptions(size={len(manifest['members'])}, name={name!r}, "
                 f"schemes={build['schemes']!r}, steps_per_scheme={build['steps_per_scheme']!r}, "
                 + (f"runs_per_scheme={build['runs_per_scheme']!r}, "
                    if any(n != 1 for n in build.get("runs_per_scheme", {}).values()) else "")
                 + (f"warm_runs_per_scheme={warm['runs_per_scheme']!r}, "
                    f"warm_steps_per_scheme={warm['steps_per_scheme']!r}, warm_start={warm['warm_start']!r}, "
                    if warm else "")
                 + f"snapshots={build['snapshots_per_run']}, seed={build['seed']}, "
                 f"matches_per_pair={build['matches_per_pair']}, max_candidates={build['max_candidates']}"
                 + (f", scheme_options={build['scheme_options']!r}" if build["scheme_options"] else "")
                 + (f", base={build['base']['path']!r}" if build.get("base") else "")
                 + (f", retire={build['base']['retired']!r}" if (build.get("base") or {}).get("retired") else "")
                 + (f", scripted={build['scripted']!r}" if build.get("scripted") else "")
                 + (f", top_runs={build['top_runs']!r}" if build.get("top_runs") else "")
                 + (f", floor_margin={build['floor_margin']!r}" if build.get("floor_margin", DEFAULT_FLOOR_MARGIN) != DEFAULT_FLOOR_MARGIN else "")
                 + "))")
    reproduce = "from arena_league.league.population.build import BuildOptions, build_population\n    " + reproduce
    return f"""# {name}: the base population of {game}

{_members_line(manifest, figures)}, frozen as
the base population new {game} agents are ranked against (after Arena, Song et al., AAAI 2020).
Built by `arena_league.league.population.build.build_population` (code {build['code']}).

## Provenance

* schemes and env steps per run: {steps}; seed {build['seed']}; {build['snapshots_per_run']} snapshots per run
  (early snapshots are weak, late ones strong){early}; actors: MLP, hidden {build['recipe']['hidden']}{wide};
  recipe overrides {json.dumps(build['recipe']['per_scheme'])}; build options {options}.
{warm_line}* candidates: {_candidates_line(build, game)}, plus the scripted `random` and `heuristic` agents as
  references, in a round robin of {schedule}.
* selection: {len(manifest['members'])} candidates spanning the rating range from {build.get('floor_margin', DEFAULT_FLOOR_MARGIN):g} Elo above the random agent,
  preferring, among candidates of similar rating, those whose results against the others differ most.
* ratings: {prov['rating']}. Every member's scheme, env steps, seed, learner, rating and interval are in
  `population.json` and in its `agents/<member>/manifest.json`.

## Figures

| figure | value |
|---|---|
| members | {figures.get('size')} ({n_warm} from warm-started runs) |
| Bradley-Terry spread (best - worst) | {figures.get('spread')} Elo |
| best member vs worst ({figures.get('best_vs_worst_matches')} {unit}) | wins {figures.get('best_vs_worst_win_rate')}, score {figures.get('best_vs_worst_score')} |
| best member vs the heuristic ({figures.get('best_vs_heuristic_matches', 0)} {unit}; headroom: wins >= {HEADROOM[2]:g}) | wins {figures.get('best_vs_heuristic_win_rate', 'not measured')}, score {figures.get('best_vs_heuristic_score', 'not measured')} |
| random agent | rating {figures.get('random_rating')}, rank {figures.get('random_rank')} of {figures.get('size', 0) + 1} |
| heuristic agent | rating {figures.get('heuristic_rating')}, rank {figures.get('heuristic_rank')} of {figures.get('size', 0) + 1} |
| effective diversity | {figures.get('effective_diversity')} |
| {unit} behind the ratings | {figures.get('round_robin_matches')} |
| member ratings (min / median / max) | {ratings[0]:.0f} / {np.median(ratings):.0f} / {ratings[-1]:.0f} |
{seat_row}

| scheme | members | min rating | median | max |
|---|---|---|---|---|
{scheme_rows}

## Criteria

| criterion | rule | value | met |
|---|---|---|---|
{criteria_rows}

## Rebuild

    {reproduce}

(resumable: interrupted, it picks up from its work_dir; the same call reads back what was saved)

## Use

    arena-league population import checkpoints/{game}/{name}
    arena-league rank my-agent --population {name}

or, in Python, `arena_league.league.import_population(league, "checkpoints/{game}/{name}")`
and `arena_league.league.population.build.load_bundles("checkpoints/{game}/{name}")` for the stacked weights.
"""
