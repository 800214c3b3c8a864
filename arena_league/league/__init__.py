"""League operations over the registry, the match engine and the rating engine: what the
``arena-league`` command and a web front end call, as plain functions.

* :mod:`.service`: submit, evaluate (now or queued), rank against a base population, leaderboards,
  recent matches, the job handlers;
* :mod:`.populations`: populations per game, the game's default base, import and export;
* :mod:`.population_index`: the shipped populations' index, where they are found, pulling one;
* :mod:`.agents` / :mod:`.jobs`: agents and jobs as a person looks them up; cancelling a job;
  reinstating a suspended agent;
* :mod:`.settings`: the league's settings (the inference sandbox's budgets, suspension after forfeits,
  upload limits);
* :mod:`.tokens`, :mod:`.uploads`, :mod:`.views`, :mod:`.matches`, :mod:`.trees`: what the web
  service calls: bearer tokens, uploads validated by a job, one JSON document per page, matches and
  their replays, social trees kept, verified and previewed;
* :mod:`.leaderboards` / :mod:`.report`: ratings tables with intervals, for a terminal, JSON and HTML;
* :mod:`.schedules`: recurring evaluations, the scheduler and the worker;
* :mod:`.first_league`: the whole workflow on the embedded default;
* :mod:`.gc`: removing artifact files no agent references;
* :mod:`.catalog`: the game set and social-tree verification; :mod:`.replays`: replay summaries;
* :mod:`.train`: training an entrant; :mod:`.human`: a person playing against a base population
  (at a terminal), :mod:`.live`: the same in a browser, one message at a time;
* :mod:`.home`: opening a league, registering games, suggestions for mistyped names;
* :mod:`.population`: the base-population build (train, round robin, select, rate, freeze).

The names below load their module on first use, so that a command that only reads the registry
does not load torch, onnxruntime or the physics engines.
"""

from __future__ import annotations

from arena_league import lazy_exports

#: Submodule -> the names this package offers from it.
_EXPORTS: dict[str, tuple[str, ...]] = {
    "agents": ("agent_detail", "agent_rows", "latest_placements", "recent_matches", "reinstate_agent", "resolve_agent"),
    "catalog": ("check_game", "game_ids", "game_manual", "game_rows", "option_line", "verify_social_tree"),
    "errors": (
        "USER_ERRORS", "ForbiddenError", "JobCancelledError", "JobFailedError", "JobInterrupted", "NotFoundError",
        "RateLimitedError",
    ),
    "first_league": ("QuickstartReport", "quickstart"),
    "gc": ("collect_garbage",),
    "home": ("did_you_mean", "league_location", "open_home", "register_game", "short_name"),
    "human": ("Ladder", "LiveMatch", "play_human"),
    "live": ("LivePlay", "check_json_nesting", "player_of", "read_message"),
    "jobs": ("cancel_job", "evaluation_payload", "follow_job", "job_detail", "job_rows"),
    "matches": ("find_match", "match_page", "match_replay", "match_replay_file", "match_view", "queue_replay"),
    "leaderboards": ("Leaderboard", "render_terminal"),
    "populations": (
        "base_import", "base_to_import", "describe_population", "ensure_population", "export_population",
        "game_population", "import_population", "list_populations", "list_shipped", "queue_import",
        "shipped_population",
    ),
    "population_index": ("index_differences", "pull_population", "shipped_rows", "write_index"),
    "replays": ("replay_document", "replay_summary"),
    "report": ("write_html_report",),
    "schedules": (
        "WorkerSummary", "add_evaluation_schedule", "list_schedules", "remove_schedule", "run_scheduler",
        "release_jobs_of_process", "run_worker", "signal_stop", "tick", "waiting_jobs",
    ),
    "service": (
        "LEAGUE_WIDE", "MATCH_IDS_PER_JOB", "EvaluationPlan", "EvaluationReport", "RankReport", "SubmitResult",
        "agent_ref", "agent_refs", "base_population", "ensure_scripted_agents", "evaluate", "evaluation_plan",
        "job_handlers", "leaderboard", "queue_evaluation", "queue_rank", "rank", "scripted_agent_name", "submit",
    ),
    "settings": ("SETTINGS", "league_settings", "reset_setting", "sandbox_limits", "set_setting"),
    "tokens": ("Identity", "authenticate", "create_token", "list_tokens", "revoke_token"),
    "trees": (
        "check_spec", "delete_saved_tree", "list_tree_views", "preview_replay", "queue_preview", "queue_verify",
        "save_tree", "tree_catalog", "tree_text", "tree_view",
    ),
    "uploads": ("series_versions", "upload_agent", "upload_limits"),
    "views": ("METHODS", "LeaderboardCache", "agent_log", "agent_view", "game_view", "games_view", "home_view",
              "job_view"),
    "train": ("train_entrant",),
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
