"""Process-pool and Ray backends return exactly the in-process results for the same specs."""

from __future__ import annotations

import socket

import pytest

from arena_league.matchmaking import AgentRef, play_matches, round_robin, specs_for_seatings
from arena_league.policies import (
    Architecture,
    export_onnx,
    game_action_spec,
    init_parameters,
    save_arena_policy,
)

AGENT_NAMES = ["random", "heuristic"]


@pytest.fixture(scope="module")
def league(tmp_path_factory):
    """Two games mixed in one list of specs, with their in-process results. GoBang's agents include
    an arena-policy folder and an ONNX file, which every worker loads from its reference."""
    folder = tmp_path_factory.mktemp("agents")
    game = "GoBang-2T1P-v1"
    spec = game_action_spec(game)
    arch = Architecture("mlp", spec.obs_dim, "discrete", n_actions=spec.n_actions, hidden=(8,))
    specs, agents = [], {
        "mlp-folder": AgentRef("arena-policy", str(save_arena_policy(folder / "mlp", arch, init_parameters(arch, 1),
                                                                      game)), game),
        "mlp-onnx": AgentRef("onnx", str(folder / "mlp.onnx"), game),
    }
    export_onnx(arch, init_parameters(arch, 2), folder / "mlp.onnx", game_id=game)
    for first_match_id, game_id in ((0, game), (100, "Soccer-2T1P-v1")):
        names = [f"{game_id}/{name}" for name in AGENT_NAMES]
        agents.update({key: AgentRef("scripted", name, game_id) for key, name in zip(names, AGENT_NAMES)})
        if game_id == game:
            names += ["mlp-folder", "mlp-onnx"]
        specs += specs_for_seatings(game_id, round_robin(names, 2), league_seed=5, first_match_id=first_match_id)
    return specs, agents, play_matches(specs, agents, batch_size=3)


def test_process_pool_matches_in_process(league):
    specs, agents, expected = league
    results = play_matches(specs, agents, backend="process", workers=2, chunk_size=5, batch_size=2)
    assert results == expected
    assert sum("mlp-folder" in r.seats for r in results) == sum("mlp-onnx" in r.seats for r in results) == 6


def test_sandboxed_agents_in_a_process_pool_match_in_process(league):
    # each pool worker plays the submitted agents' matches in a sandbox child of its own
    specs, agents, expected = league
    sandboxed = {key: AgentRef(ref.kind, ref.name, ref.game_id, ref.action_type, sandboxed=ref.kind != "scripted")
                 for key, ref in agents.items()}
    assert play_matches(specs, sandboxed, backend="process", workers=2, chunk_size=5, batch_size=2) == expected


def test_ray_matches_in_process(league):
    specs, agents, expected = league
    ray = pytest.importorskip("ray", reason="the ray backend needs Ray (pip install 'arena-league[ray]')")
    try:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    except Exception as error:  # any failure to start a local instance is a skip
        pytest.skip(f"a local Ray instance cannot start here: {error}")
    try:
        results = play_matches(specs, agents, backend="ray", chunk_size=4, batch_size=4)
    finally:
        ray.shutdown()
    assert results == expected


def test_a_cluster_address_where_nothing_answers_is_refused_at_once():
    pytest.importorskip("ray", reason="joining a cluster needs Ray (pip install 'arena-league[ray]')")
    from arena_league.matchmaking.cluster import join_ray

    with socket.socket() as probe:  # a port just freed: nothing listens there
        probe.bind(("127.0.0.2", 0))
        port = probe.getsockname()[1]
    with pytest.raises(ValueError, match=f"nothing answers at the Ray address 127.0.0.2:{port}"):
        join_ray(f"127.0.0.2:{port}")
    with pytest.raises(ValueError, match="the Ray address 'head-node' is not HOST:PORT"):
        join_ray("head-node")
