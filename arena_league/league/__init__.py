"""League operations over the registry, the match engine and the rating engine: what the
``arena-league`` command and a web front end call (see :mod:`arena_league.league.service`)."""

from arena_league.league.service import (
    MATCH_IDS_PER_JOB,
    EvaluationReport,
    RankReport,
    SubmitResult,
    agent_ref,
    base_population,
    ensure_scripted_agents,
    evaluate,
    export_population,
    import_population,
    job_handlers,
    leaderboard,
    open_home,
    queue_evaluation,
    rank,
    recent_matches,
    register_game,
    scripted_agent_name,
    submit,
)

__all__ = ["MATCH_IDS_PER_JOB", "EvaluationReport", "RankReport", "SubmitResult", "agent_ref", "base_population",
           "ensure_scripted_agents", "evaluate", "export_population", "import_population", "job_handlers",
           "leaderboard", "open_home", "queue_evaluation", "rank", "recent_matches", "register_game",
           "scripted_agent_name", "submit"]
