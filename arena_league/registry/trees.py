"""Social trees saved in the league: a name, a game, an owner and the spec (JSON)."""

from __future__ import annotations

from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from arena_league.registry.models import Tree, utcnow
from arena_league.registry.repository import require_game

__all__ = ["count_trees", "create_tree", "delete_tree", "get_tree", "list_trees"]


def create_tree(session: Session, name: str, game_id: str, owner: str, spec: dict[str, Any]) -> Tree:
    """Keep a tree of a registered game (its spec checked by the caller)."""
    require_game(session, game_id)
    tree = Tree(name=name, game_id=game_id, owner=owner, spec=spec, created_at=utcnow())
    session.add(tree)
    session.flush()
    return tree


def get_tree(session: Session, tree_id: int) -> Tree | None:
    return session.get(Tree, tree_id)


def count_trees(session: Session, owner: str) -> int:
    """How many saved trees ``owner`` keeps."""
    return int(session.scalar(select(func.count(Tree.id)).where(Tree.owner == owner)))


def list_trees(session: Session, *, game_id: str | None = None, owner: str | None = None,
               limit: int | None = None) -> list[Tree]:
    """Saved trees, newest first, optionally of one game or owner, the newest ``limit`` when given."""
    query = select(Tree).order_by(Tree.id.desc()).limit(limit)
    if game_id is not None:
        query = query.where(Tree.game_id == game_id)
    if owner is not None:
        query = query.where(Tree.owner == owner)
    return list(session.scalars(query))


def delete_tree(session: Session, tree: Tree) -> None:
    session.delete(tree)
    session.flush()
