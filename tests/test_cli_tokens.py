"""Tokens from the command: made once and shown once, kept as a hash, listed without the token,
revoked by id or by owner; a revoked or unknown token identifies no one."""

from __future__ import annotations

import hashlib

from cli_helpers import run

from arena_league import registry as reg
from arena_league.league import authenticate, open_home

pytest_plugins = ["cli_helpers"]  # the home fixture


def test_a_token_is_shown_once_kept_as_a_hash_and_revoked(capsys, home):
    code, made, _ = run(capsys, "token", "create", "alice", "--json")
    assert code == 0 and made["owner"] == "alice" and made["admin"] is False
    token = made["token"]
    assert token.startswith("al_") and len(token) > 40
    code, admin, _ = run(capsys, "token", "create", "root", "--admin", "--json")
    with open_home(home) as league:
        with league.reading() as session:
            rows = reg.list_tokens(session)
        assert rows[0].token_hash == hashlib.sha256(token.encode()).hexdigest()
        assert all(token not in (r.token_hash, r.prefix) for r in rows)  # the token itself is not kept
        assert authenticate(league, token).owner == "alice"
        assert authenticate(league, admin["token"]).admin is True
        assert authenticate(league, token[:-1] + "x") is None and authenticate(league, None) is None
    code, listing, _ = run(capsys, "token", "list", "--json")
    assert [(t["owner"], t["admin"], t["revoked_at"]) for t in listing["tokens"]] == [("alice", False, None),
                                                                                     ("root", True, None)]
    assert token not in str(listing)
    code, revoked, _ = run(capsys, "token", "revoke", "alice", "--json")
    assert revoked == {"revoked": 1, "which": "alice"}
    code, _, err = run(capsys, "token", "revoke", "alice")
    assert code == 2 and "no live token of alice" in err
    code, revoked, _ = run(capsys, "token", "revoke", str(admin["id"]), "--json")
    assert revoked["revoked"] == 1
    with open_home(home) as league:
        assert authenticate(league, token) is None and authenticate(league, admin["token"]) is None
    code, _, err = run(capsys, "token", "create", "a:b")
    assert code == 2 and "which names may not hold" in err


def test_serve_refuses_a_bad_port_and_one_in_use_in_one_line(capsys, home):
    import socket

    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        code, _, err = run(capsys, "serve", "--port", str(port), "--no-worker")
    assert code == 2 and f"cannot listen on 127.0.0.1:{port} (Address already in use" in err
    assert "Traceback" not in err
