"""Generate the site's reference pages from the package itself (run by mkdocs-gen-files at build time).

Pages written (virtual files: nothing lands in docs/):

* ``games/index.md`` and ``games/<game-id>.md``: every registered game id, from the game catalog
  (its manual, options, layouts, actions, observation cells, default social tree, a top-down picture);
* ``populations/index.md`` and ``populations/<game-id>-<name>.md``: every shipped population under
  ``checkpoints/<game>/<name>/`` (its README, provenance, figures, criteria and rating ladder);
* ``reference/commands.md`` (the CLI's argparse parser), ``reference/settings.md`` (the league's
  settings table), ``reference/web-api.md`` (the web service's OpenAPI document) and
  ``reference/python.md`` (mkdocstrings blocks of the modules users call).

It imports ``arena_league``, so it runs from a checkout where the package is importable (an
editable install, or ``PYTHONPATH`` set to the checkout).
"""

from __future__ import annotations

import argparse
import inspect
import io
import json
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # pictures are drawn headless at build time

import matplotlib.pyplot as plt
import mkdocs_gen_files
from PIL import Image

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # the checkout's package, not another installed copy
    sys.path.insert(0, str(ROOT))

from arena_league.cli import build_parser, tree_outline  # noqa: E402
from arena_league.envs import game_spec, list_games, make, make_rules  # noqa: E402
from arena_league.envs.physics2d import CellLayout  # noqa: E402
from arena_league.league import game_rows, option_line  # noqa: E402
from arena_league.league.settings import SETTINGS  # noqa: E402

CHECKPOINTS = ROOT / "checkpoints"
#: The seed of the pictures, so that a rebuild draws the same arenas.
PICTURE_SEED = 0


# --- markdown helpers --------------------------------------------------------------------------------------------

def cell(value: Any) -> str:
    """``value`` as one markdown table cell: pipes escaped, one line, angle brackets shown as text
    outside code spans (a ``<scheme>`` in a help string stands for a value the reader gives, not an HTML tag)."""
    text = " ".join(str(value).split())
    parts = re.split(r"(`[^`]*`)", text)
    out = []
    for part in parts:
        if part.startswith("`") and part.endswith("`") and len(part) > 1:
            out.append(part.replace("|", "\\|"))
        else:
            out.append(part.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace("|", "\\|"))
    return "".join(out)


def table(columns: list[str], rows: list[list[Any]]) -> str:
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def rst_to_markdown(text: str) -> str:
    """A module docstring as markdown: ``code`` and Sphinx roles as code spans, and the docstrings'
    definition-list sections (a line, then its body indented four spaces) as headed sections."""
    text = re.sub(r":[a-z]+:`~?([^`]+)`", lambda m: f"`{m.group(1).split('.')[-1] if '~' in m.group(0) else m.group(1)}`",
                  text)
    text = re.sub(r"``([^`]+)``", r"`\1`", text)
    lines = text.splitlines()
    out: list[str] = []
    for k, line in enumerate(lines):
        following = lines[k + 1] if k + 1 < len(lines) else ""
        if line and not line[0].isspace() and following.startswith("    ") and (k == 0 or not lines[k - 1].strip()):
            out.append(f"#### {line.strip()}")
            out.append("")
        elif line.startswith("    "):
            out.append(line[4:])
        else:
            out.append(line)
    return "\n".join(out)


def write_png(path: str, picture: Any) -> None:
    buffer = io.BytesIO()
    Image.fromarray(picture).save(buffer, format="PNG")
    with mkdocs_gen_files.open(path, "wb") as f:
        f.write(buffer.getvalue())


def save_figure(path: str, figure: Any) -> None:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=100, bbox_inches="tight")
    plt.close(figure)
    with mkdocs_gen_files.open(path, "wb") as f:
        f.write(buffer.getvalue())


# --- populations -------------------------------------------------------------------------------------------------

def shipped_populations() -> dict[str, list[tuple[str, Path]]]:
    """Per game id, its shipped populations as ``(name, folder)``, from ``checkpoints/<game>/<name>/``."""
    found: dict[str, list[tuple[str, Path]]] = {}
    for manifest in sorted(CHECKPOINTS.glob("*/*/population.json")):
        folder = manifest.parent
        found.setdefault(folder.parent.name, []).append((folder.name, folder))
    return found


def population_page(game_id: str, name: str) -> str:
    return f"{game_id}-{name}"


# --- games -------------------------------------------------------------------------------------------------------

def tree_lines(spec: Any, depth: int = 0) -> list[str]:
    """A social tree spec as a nested markdown list: scheme, reward, scale and parameters per node."""
    pad = "    " * depth
    if isinstance(spec, str):
        return [f"{pad}- `{spec}`"]
    scale = spec.get("scale", 1)
    words = [f"**{spec.get('scheme')}**", f"`{spec.get('reward', 'none')}`"]
    if scale != 1:
        words.append(f"x{scale:g}")
    if spec.get("params"):
        words.append("(" + ", ".join(f"{k}={v}" for k, v in spec["params"].items()) + ")")
    if "agent" in spec:
        words.insert(0, f"{spec['agent']}:")
    lines = [f"{pad}- " + " ".join(words)]
    for child in spec.get("children", []):
        lines += tree_lines(child, depth + 1)
    return lines


def action_rows(rules: Any) -> list[list[Any]]:
    meanings = tuple(rules.action_meanings)
    if len(meanings) == rules.n_actions:
        return [[k, meaning] for k, meaning in enumerate(meanings)]
    if len(meanings) == 1:  # one pattern for every index (a board cell)
        return [[f"0-{rules.n_actions - 1}", meanings[0]]]
    return [[f"0-{rules.n_actions - 1}", "see the manual above"]]


def game_page(row: dict[str, Any], populations: list[tuple[str, Path]]) -> str:
    game_id = row["game_id"]
    spec = game_spec(game_id)
    module = sys.modules[spec.rules.__module__]
    lines = [f"# {game_id}", "", f"{row['summary'][:1].upper()}{row['summary'][1:]}.", "",
             f"![{game_id} from above, seed {PICTURE_SEED}]({game_id}.png){{ width=\"400\" }}", "",
             table(["property", "value"], [
                 ["teams x players", f"{row['teams']} x {row['players_per_team']}"],
                 ["turns", "in turn" if row["turn_based"] else "simultaneous"],
                 ["action types", ", ".join(row["action_types"])],
                 ["observation", f"float32[{row['obs_dim']}] per seat"],
                 ["episode length", f"{row['max_cycles']} steps (default `max_cycles`)"],
                 ["league matches", "in pairs: two halves from one start, roles swapped "
                                    "([Games played in pairs](../ratings.md#games-played-in-pairs))"
                  if spec.paired else "single matches"],
                 ["other layouts", ", ".join(f"[{g}]({g}.md)" for g in _sibling_ids(spec)) or "none"],
             ]),
             "```python", "from arena_league.envs import make", "",
             f'env = make("{game_id}")  # a PettingZoo ParallelEnv', "```", ""]
    lines += ["## Options", ""]
    if row["options"]:
        lines += ["Keyword options of `make(game_id, **options)`:", "",
                  table(["option", "default", "accepts", "meaning"],
                        [[f"`{o['name']}`", _default_words(o), o["accepts"], o["meaning"]] for o in row["options"]])]
        lines += ["In words (as `arena-league games " + game_id + "` prints them):", ""]
        lines += [f"- {cell(option_line(o))}" for o in row["options"]] + [""]
    else:
        lines += ["The game declares no options table: its manual below says what it takes.", ""]
    lines += ["## Actions", ""]
    for action_type in row["action_types"]:
        rules = make_rules(game_id, action_type)
        if action_type == "discrete":
            lines += [f"**discrete**: {rules.n_actions} actions.", "", table(["action", "meaning"], action_rows(rules))]
        else:
            lines += [f"**continuous**: a float32 vector of {rules.act_dim} values (the manual says what each does).", ""]
    rules = make_rules(game_id)
    lines += ["## Observation", ""]
    layout = getattr(rules, "layout", None)
    if isinstance(layout, CellLayout):
        lines += [f"Each seat observes `float32[{rules.obs_dim}]`, these runs of cells in order:", "",
                  table(["cells", "name", "bounds", "meaning"],
                        [[r["cells"], f"`{r['name']}`", ", ".join(f"[{lo:g}, {hi:g}]" for lo, hi in r["bounds"]),
                          r["meaning"]] for r in layout.table()])]
    else:
        lines += [f"Each seat observes `float32[{rules.obs_dim}]`; the manual below lays it out.", ""]
    lines += ["## Default social tree", "", f"Outline: `{tree_outline(row['default_tree'])}`", ""]
    lines += [*tree_lines(row["default_tree"]), ""]
    lines += ['??? note "The tree as a spec (JSON)"', "", "    ```json"]
    lines += ["    " + line for line in json.dumps(row["default_tree"], indent=2).splitlines()]
    lines += ["    ```", ""]
    lines += ["## Shipped populations", ""]
    if populations:
        lines += [f"- [{name}](../populations/{population_page(game_id, name)}.md)" for name, _ in populations] + [""]
    else:
        lines += ["None: agents of this game are ranked once a base population is built for it "
                  "(`arena-league population build`).", ""]
    lines += ["## Throughput", "",
              "The env's own steps per second on your machine, with random actions, beside PettingZoo's "
              "butterfly envs in the same run:", "", "```bash",
              f"PYTHONPATH=. python benchmarks/env_throughput.py --games {game_id}", "```", "",
              "Measured figures for each game family, and training's speed on one game of each engine, are "
              "on the [performance page](../performance.md).", ""]
    lines += ["## Manual", "", f"The docstring of `{module.__name__}`.", ""]
    lines += [rst_to_markdown(inspect.cleandoc(module.__doc__ or "(no manual)")), ""]
    return "\n".join(lines)


def _sibling_ids(spec: Any) -> list[str]:
    return [g for g in list_games() if game_spec(g).rules is spec.rules and g != spec.game_id]


def _default_words(record: dict[str, Any]) -> str:
    default = record["default"]
    if default is None:
        return record.get("default_text", "computed by the game")
    return f"`{json.dumps(default)}`"


def generate_games(populations: dict[str, list[tuple[str, Path]]]) -> None:
    rows = game_rows()
    index = ["# Games", "",
             f"The {len(rows)} game ids of the catalog (`arena-league games`), in Arena's "
             "`<Game>-<x>T<y>P-v<N>` convention: x teams of y players. Each page has the game's manual, "
             "options, actions, observation, default social tree and a picture.", "",
             table(["id", "family", "layouts", "action types", "summary"], [
                 [f"[{r['game_id']}]({r['game_id']}.md)", game_spec(r["game_id"]).rules.name,
                  ", ".join(f"{t}T{p}P" for t, p in game_spec(r["game_id"]).rules.layouts),
                  ", ".join(r["action_types"]), r["summary"]] for r in rows])]
    with mkdocs_gen_files.open("games/index.md", "w") as f:
        f.write("\n".join(index))
    for row in rows:
        game_id = row["game_id"]
        with mkdocs_gen_files.open(f"games/{game_id}.md", "w") as f:
            f.write(game_page(row, populations.get(game_id, [])))
        env = make(game_id, render_mode="rgb_array")
        env.reset(seed=PICTURE_SEED)
        write_png(f"games/{game_id}.png", env.render())
        env.close()


# --- populations -------------------------------------------------------------------------------------------------

def ladder_figure(document: dict[str, Any]) -> Any:
    """Members' ratings in rank order with their intervals, coloured by scheme, and the scripted references."""
    members = sorted(document["members"], key=lambda m: -m["metadata"]["rating"])
    schemes = sorted({m["metadata"].get("scheme", "?") for m in members})
    colours = {s: plt.get_cmap("tab10")(k % 10) for k, s in enumerate(schemes)}
    figure, axes = plt.subplots(figsize=(9, 3.6))
    for scheme in schemes:
        at = [k for k, m in enumerate(members) if m["metadata"].get("scheme", "?") == scheme]
        rating = [members[k]["metadata"]["rating"] for k in at]
        low = [members[k]["metadata"]["rating"] - members[k]["metadata"].get("rating_lower", rating[i])
               for i, k in enumerate(at)]
        high = [members[k]["metadata"].get("rating_upper", rating[i]) - members[k]["metadata"]["rating"]
                for i, k in enumerate(at)]
        axes.errorbar([k + 1 for k in at], rating, yerr=[low, high], fmt="o", markersize=3, elinewidth=0.8,
                      color=colours[scheme], label=scheme)
    for name, rating in document["provenance"].get("references", {}).items():
        axes.axhline(rating, linestyle="--", linewidth=0.8, color="grey")
        axes.annotate(name, (len(members), rating), textcoords="offset points", xytext=(4, 2), fontsize=8,
                      color="grey")
    axes.set_xlabel("rank among members")
    axes.set_ylabel("rating (Elo scale)")
    axes.set_title(f"{document['game_id']} {document['name']}: members' ratings with 95% intervals")
    axes.legend(title="scheme", fontsize=8, loc="lower left")  # ratings fall left to right: that corner is empty
    axes.grid(alpha=0.3)
    return figure


def generate_populations(populations: dict[str, list[tuple[str, Path]]]) -> None:
    index_rows = []
    for game_id, shipped in populations.items():
        for name, folder in shipped:
            document = json.loads((folder / "population.json").read_text())
            provenance = document.get("provenance", {})
            figures = provenance.get("figures", {})
            page = population_page(game_id, name)
            index_rows.append([f"[{game_id} {name}]({page}.md)", f"[{game_id}](../games/{game_id}.md)",
                               len(document.get("members", [])), figures.get("spread", ""),
                               figures.get("best_vs_worst_score", ""),
                               "yes" if provenance.get("passed") else "no", provenance.get("build", {}).get("code", "")])
            save_figure(f"populations/{page}.png", ladder_figure(document))
            with mkdocs_gen_files.open(f"populations/{page}.md", "w") as f:
                f.write(population_markdown(game_id, name, folder, document))
    index = ["# Shipped populations", "",
             "The frozen base populations under `checkpoints/<game>/<name>/` that new agents are ranked "
             "against; each page has the population's README, how it was built, its figures and criteria, "
             "and its rating ladder.", "",
             table(["population", "game", "members", "spread (Elo)", "best vs worst score", "criteria passed",
                    "code"], index_rows)]
    with mkdocs_gen_files.open("populations/index.md", "w") as f:
        f.write("\n".join(index))


def population_markdown(game_id: str, name: str, folder: Path, document: dict[str, Any]) -> str:
    provenance = document.get("provenance", {})
    readme = (folder / "README.md").read_text() if (folder / "README.md").exists() else f"# {game_id} {name}\n"
    page = population_page(game_id, name)
    lines = [readme.rstrip(), "", f"Game: [{game_id}](../games/{game_id}.md). Why its recipe is what it is: the "
             "[per-game build notes](../populations.md#per-game-build-notes) and the "
             "[population build notes](../population-build-notes.md).", "", "## Rating ladder", "",
             f"![rating ladder of {game_id} {name}]({page}.png)", ""]
    # the README a build writes has its own figures and criteria tables: these are the raw records, for one without
    criteria = provenance.get("criteria", {})
    if criteria and "## Criteria" not in readme:
        lines += ["## Criteria (from population.json)", "",
                  table(["criterion", "met"], [[f"`{k}`", "yes" if v else "no"] for k, v in criteria.items()])]
    figures = provenance.get("figures", {})
    if figures and "## Figures" not in readme:
        lines += ["## Figures (from population.json)", "",
                  table(["figure", "value"], [[f"`{k}`", json.dumps(v) if isinstance(v, (dict, list)) else v]
                                              for k, v in figures.items()])]
    if "rating" in provenance:
        lines += [f"Ratings: {cell(provenance['rating'])}", ""]
    build = provenance.get("build", {})
    if build:
        lines += ["## Build settings (from population.json)", "",
                  table(["setting", "value"], [[f"`{k}`", f"`{json.dumps(v)}`" if isinstance(v, (dict, list)) else v]
                                               for k, v in build.items()])]
    members = sorted(document.get("members", []), key=lambda m: m["metadata"].get("rank", 0))
    if members:
        lines += ['??? note "Every member"', ""]
        lines += ["    " + line for line in table(
            ["rank", "member", "scheme", "rating", "interval"],
            [[m["metadata"].get("rank", ""), f"`{m['name']}`", m["metadata"].get("scheme", ""),
              m["metadata"].get("rating", ""),
              f"[{m['metadata'].get('rating_lower', '')}, {m['metadata'].get('rating_upper', '')}]"]
             for m in members]).splitlines()]
        lines += [""]
    return "\n".join(lines)



# --- reference: commands -----------------------------------------------------------------------------------------

def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    """``(name, help, parser)`` of each subcommand of ``parser``, in the order they were declared."""
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help or "" for choice in action._choices_actions}
            found += [(name, helps.get(name, ""), sub) for name, sub in action.choices.items()]
    return found


def _option_rows(parser: argparse.ArgumentParser) -> list[list[Any]]:
    formatter = parser._get_formatter()
    rows = []
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)) or action.help == argparse.SUPPRESS:
            continue
        name = ", ".join(f"`{s}`" for s in action.option_strings) or f"`{action.metavar or action.dest}`"
        if action.option_strings and action.nargs != 0:
            metavar = action.metavar or action.dest.upper()
            name += f" `{metavar if isinstance(metavar, str) else ' '.join(metavar)}`"
        help_text = formatter._expand_help(action) if action.help else ""
        if action.choices and not isinstance(action.choices, dict):
            help_text += " (one of " + ", ".join(f"`{c}`" for c in action.choices) + ")"
        if action.nargs == 0 or action.default in (None, argparse.SUPPRESS) or not action.option_strings:
            default = ""
        else:
            default = f"`{action.default}`"
        required = "required" if (action.required and action.option_strings) or (
            not action.option_strings and action.nargs not in ("?", "*")) else ""
        rows.append([name, required, default, help_text])
    return rows


def _command_section(path: str, help_text: str, parser: argparse.ArgumentParser, depth: int) -> list[str]:
    lines = [f"{'#' * depth} `{path}`", ""]
    if help_text:
        lines += [f"{cell(help_text[:1].upper() + help_text[1:])}.", ""]
    lines += ["```text", parser.format_usage().strip(), "```", ""]
    rows = _option_rows(parser)
    if rows:
        lines += [table(["argument", "", "default", "meaning"], rows)]
    for name, sub_help, sub in _subcommands(parser):
        lines += _command_section(f"{path} {name}", sub_help, sub, min(depth + 1, 4))
    return lines


def generate_commands() -> None:
    parser = build_parser()
    lines = ["# Commands", "",
             "Every command of the `arena-league` command line and its arguments, read from its argument "
             "parser (`arena_league.cli.build_parser`); `arena-league COMMAND --help` prints the same. Every "
             "command also takes `--debug` (on an error, show the full traceback).", "",
             "```text", parser.format_usage().strip(), "```", "",
             table(["command", "what it does"], [[f"[`{name}`](#arena-league-{name})", help_text]
                                                 for name, help_text, _ in _subcommands(parser)])]
    for name, help_text, sub in _subcommands(parser):
        lines += _command_section(f"arena-league {name}", help_text, sub, 2)
    with mkdocs_gen_files.open("reference/commands.md", "w") as f:
        f.write("\n".join(lines))


# --- reference: settings -----------------------------------------------------------------------------------------

def generate_settings() -> None:
    rows = [[f"`{s.key}`", "whole number" if s.kind is int else "number", f"`{s.default}`",
             f"[{s.low:g}, {s.high:g}]", s.help] for s in SETTINGS.values()]
    lines = ["# Settings", "",
             "A league's settings: the budgets submitted agents play within, kept in its registry so that "
             "every worker and web server reads the same values. A league stores only those its operator "
             "changed; `arena-league settings` lists them, `arena-league settings set KEY VALUE` changes one "
             "and `arena-league settings reset KEY` returns it to its default. Read from "
             "`arena_league.league.settings.SETTINGS`.", "",
             table(["key", "type", "default", "range", "meaning"], rows)]
    with mkdocs_gen_files.open("reference/settings.md", "w") as f:
        f.write("\n".join(lines))


# --- reference: web API ------------------------------------------------------------------------------------------

def openapi_document() -> dict[str, Any]:
    """The web service's OpenAPI document, from an app over a throwaway league (no workers, no server)."""
    from arena_league.web.app import create_app

    with tempfile.TemporaryDirectory(prefix="arena-docs-") as home:
        app = create_app(home)
        try:
            return app.openapi()
        finally:
            app.state.league.close()


def _schema_words(schema: dict[str, Any]) -> str:
    if "$ref" in schema:
        return schema["$ref"].rsplit("/", 1)[-1]
    if "anyOf" in schema:
        return " or ".join(_schema_words(s) for s in schema["anyOf"])
    if schema.get("type") == "array":
        return f"array of {_schema_words(schema.get('items', {}))}"
    words = schema.get("type", "any")
    if "enum" in schema:
        words += " (one of " + ", ".join(str(v) for v in schema["enum"]) + ")"
    return words


def generate_web_api() -> None:
    document = openapi_document()
    methods = ("get", "post", "put", "patch", "delete")
    routes = [(path, method, operation) for path, item in document["paths"].items()
              for method, operation in item.items() if method in methods]
    lines = ["# Web API", "", cell(document["info"].get("description", "")), "",
             f"{len(routes)} routes, read from the service's OpenAPI document (`/openapi.json` of a running "
             "`arena-league serve`; the interactive form is at `/docs`).", "",
             table(["method", "path", "summary"], [[method.upper(), f"`{path}`", operation.get("summary", "")]
                                                   for path, method, operation in routes])]
    for path, method, operation in routes:
        lines += [f"## {method.upper()} `{path}`", ""]
        description = operation.get("description") or operation.get("summary", "")
        if description:
            lines += [cell(description), ""]
        parameters = operation.get("parameters", [])
        if parameters:
            lines += [table(["parameter", "in", "required", "type", "meaning"], [
                [f"`{p['name']}`", p.get("in", ""), "yes" if p.get("required") else "no",
                 _schema_words(p.get("schema", {})), p.get("description", p.get("schema", {}).get("description", ""))]
                for p in parameters])]
        body = operation.get("requestBody")
        if body:
            kinds = ", ".join(f"`{kind}` ({_schema_words(content.get('schema', {}))})"
                              for kind, content in body.get("content", {}).items())
            lines += [f"Request body{' (required)' if body.get('required') else ''}: {kinds}.", ""]
        answers = ", ".join(f"{code} {cell(answer.get('description', ''))}"
                            for code, answer in operation.get("responses", {}).items())
        if answers:
            lines += [f"Responses: {answers}.", ""]
    with mkdocs_gen_files.open("reference/web-api.md", "w") as f:
        f.write("\n".join(lines))


# --- reference: Python API ---------------------------------------------------------------------------------------

#: The modules users call and, per module, the names documented (``None``: the module's ``__all__``).
PYTHON_API: dict[str, list[str] | None] = {
    "arena_league.envs": ["make", "make_aec", "list_games", "game_spec", "game_options", "make_rules",
                          "default_tree", "example_trees", "reward_catalog", "check_tree", "GameSpec"],
    "arena_league.training": ["run_scheme", "run_trainer", "PPOConfig", "TrainerBase", "PPO", "SelfPlay",
                              "PBT", "DPPO", "register_scheme"],
    "arena_league.matchmaking": ["play_matches", "MatchSpec", "MatchResult", "AgentRef", "round_robin"],
    "arena_league.rating": ["bradley_terry", "fit_bradley_terry", "bootstrap_ratings", "elo_online",
                            "openskill_ratings", "alpha_rank", "nash_averaging", "place_entrant",
                            "competition_ranks", "effective_diversity"],
    "arena_league.policies": ["load_agent", "load_policy", "scripted_policy", "save_arena_policy",
                              "validate_submission", "Policy"],
}


def generate_python() -> None:
    import importlib

    lines = ["# Python API", "",
             "The functions and classes of the modules users call, from their docstrings.", ""]
    for module_name, names in PYTHON_API.items():
        module = importlib.import_module(module_name)
        lines += [f"## `{module_name}`", "", rst_to_markdown(inspect.cleandoc(module.__doc__ or "")), ""]
        for name in names or module.__all__:
            # the defining module: griffe reads source and cannot follow a package's lazy exports
            home = getattr(getattr(module, name), "__module__", module_name)
            lines += [f"::: {home}.{name}", "    options:", "      heading_level: 3", ""]
    with mkdocs_gen_files.open("reference/python.md", "w") as f:
        f.write("\n".join(lines))


def main() -> None:
    populations = shipped_populations()
    generate_games(populations)
    generate_populations(populations)
    generate_commands()
    generate_settings()
    generate_web_api()
    generate_python()


main()
