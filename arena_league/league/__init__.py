"""League operations over the registry, the match engine and the rating engine: what the
``arena-league`` command and a web front end call, as plain functions.

* :mod:`.service`: submit, evaluate (now or queued), rank against a base population,
  leaderboards, recent matches, population import and export, the job handlers;
* :mod:`.leaderboards` / :mod:`.report`: ratings tables with intervals, for a terminal, JSON and HTML;
* :mod:`.schedules`: recurring evaluations, the scheduler and the worker;
* :mod:`.quickstart`: the whole workflow on the embedded default;
* :mod:`.catalog`: the game set and social-tree verification; :mod:`.replays`: replay summaries;
* :mod:`.train`: training an entrant; :mod:`.human`: a person playing against a base population;
* :mod:`.population`: the base-population build (train, round robin, select, rate, freeze).

Modules that pull in heavy libraries (the build, training, human play) are imported by name, on use.
"""

from arena_league.league.catalog import game_rows, verify_social_tree
from arena_league.league.errors import USER_ERRORS
from arena_league.league.leaderboards import Leaderboard, render_terminal
from arena_league.league.quickstart import QuickstartReport, quickstart
from arena_league.league.replays import replay_summary
from arena_league.league.report import write_html_report
from arena_league.league.schedules import (
    WorkerSummary,
    add_evaluation_schedule,
    list_schedules,
    remove_schedule,
    run_scheduler,
    run_worker,
    tick,
)
from arena_league.league.service import (
    MATCH_IDS_PER_JOB,
    EvaluationReport,
    RankReport,
    SubmitResult,
    agent_ref,
    base_population,
    ensure_population,
    ensure_scripted_agents,
    evaluate,
    evaluation_payload,
    export_population,
    import_population,
    job_handlers,
    leaderboard,
    list_populations,
    open_home,
    queue_evaluation,
    rank,
    recent_matches,
    register_game,
    scripted_agent_name,
    shipped_population,
    submit,
)

__all__ = [
    "MATCH_IDS_PER_JOB", "USER_ERRORS",
    "EvaluationReport", "Leaderboard", "QuickstartReport", "RankReport", "SubmitResult", "WorkerSummary",
    "add_evaluation_schedule", "agent_ref", "base_population", "ensure_population", "ensure_scripted_agents",
    "evaluate", "evaluation_payload", "export_population", "game_rows", "import_population", "job_handlers",
    "leaderboard", "list_populations", "list_schedules", "open_home", "queue_evaluation", "quickstart", "rank",
    "recent_matches", "register_game", "remove_schedule", "render_terminal", "replay_summary", "run_scheduler",
    "run_worker", "scripted_agent_name", "shipped_population", "submit", "tick", "verify_social_tree",
    "write_html_report",
]
