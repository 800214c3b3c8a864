"""Alembic migrations of the league registry (run by `arena_league.registry.db.open_league`)."""
