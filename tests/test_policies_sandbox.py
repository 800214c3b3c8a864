"""The inference sandbox: agents compute in a child process, every failure stays with its agent.

Hostile ONNX graphs (a Loop of 10^15 iterations, a 3 GiB allocation, an onnxruntime failure, NaN
logits), each only past some batch size, forfeit their own matches and no other; after a death
the matches in flight are replayed in a new child; stacked agents are run apart to find the one at
fault; matches played in the sandbox are the matches played in-process, bit for bit. The child
carries its own address-space limit, so none of this can take the machine down."""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
import textwrap
import time

import hostile_agents as hostile
import numpy as np
import pytest

from arena_league.matchmaking import AgentRef, play_matches, round_robin, specs_for_seatings
from arena_league.matchmaking.agents import load_agents
from arena_league.policies import Architecture, game_action_spec, init_parameters, save_arena_policy
from arena_league.policies.sandbox import (
    AgentSource,
    ForfeitError,
    InferenceSandbox,
    SandboxLimits,
    largest_batch,
    process_sandbox,
)

CROSSROADS = "Crossroads-2T2P-v1"
GOBANG = "GoBang-2T1P-v1"
FAST = SandboxLimits(call_seconds=0.5)


def mlp_folder(tmp_path, game_id: str, seed: int, hidden=(16,)):
    spec = game_action_spec(game_id)
    arch = Architecture("mlp", obs_dim=spec.obs_dim, action_type=spec.action_type, n_actions=spec.n_actions,
                        act_dim=spec.act_dim, hidden=hidden)
    return save_arena_policy(tmp_path / f"mlp-{seed}", arch, init_parameters(arch, seed), game_id, name=f"mlp-{seed}")


def observations(game_id: str, rows: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    spec = game_action_spec(game_id)
    rng = np.random.default_rng(seed)
    return rng.standard_normal((rows, spec.obs_dim)).astype(np.float32), rng.random((rows, 1))


def test_hostile_agents_forfeit_their_own_matches_and_the_others_play_as_in_process(tmp_path):
    models = {"hang": hostile.hanging(CROSSROADS, above=20),
              "alloc": hostile.allocating(CROSSROADS, 3 << 30, above=20),
              "fail": hostile.failing(CROSSROADS, above=20), "nan": hostile.nan_out(CROSSROADS, above=20)}
    refs = {name: AgentRef("onnx", str(hostile.save(model, tmp_path / f"{name}.onnx")), CROSSROADS, sandboxed=True)
            for name, model in models.items()}
    for seed in (1, 2):
        refs[f"good{seed}"] = AgentRef("arena-policy", str(mlp_folder(tmp_path, CROSSROADS, seed)), CROSSROADS,
                                       sandboxed=True)
    specs = specs_for_seatings(CROSSROADS, round_robin(list(refs), 8))
    started = time.monotonic()
    results = play_matches(specs, refs, sandbox_limits=FAST, forfeit_limit=1)
    assert time.monotonic() - started < 120
    reasons = {}
    for result in results:
        for agent, reason in result.forfeits:
            reasons.setdefault(agent, reason)
    assert "ran past its 0.5 s budget for a call of" in reasons["hang"]
    assert reasons["alloc"].startswith("ran out of memory") and "ConstantOfShape" in reasons["alloc"]
    assert reasons["fail"].startswith("failed: onnxruntime failed in a Reshape node")
    assert reasons["nan"].startswith("output NaN or infinite logits")
    assert set(reasons) == {"hang", "alloc", "fail", "nan"}
    # every match without a hostile agent was played, exactly as in-process
    good = [s for s in specs if set(s.seats) <= {"good1", "good2"}]
    played = {r.spec: r for r in results}
    local = {k: AgentRef(r.kind, r.name, r.game_id) for k, r in refs.items()}
    assert [played[s] for s in good] == play_matches(good, local)
    # a hostile agent's matches are forfeits (lost) or, past its one allowed forfeit, skipped
    for result in results:
        bad = set(result.seats) - {"good1", "good2"}
        if bad:
            assert result.forfeits and {a for a, _ in result.forfeits} <= bad
    assert process_sandbox(FAST).starts >= 2  # the hang and the allocation killed a child


def test_forfeits_on_a_whole_array_engine_leave_the_other_boards_playing(tmp_path):
    """GoBang's engine steps every board, a forfeited one too: a board left by a forfeit that then
    ends has no match to finish, and the matches still queued are played to their end."""
    path = hostile.save(hostile.failing(GOBANG), tmp_path / "bad.onnx")
    refs = {"bad": AgentRef("onnx", str(path), GOBANG, sandboxed=True),
            "random": AgentRef("scripted", "random", GOBANG), "heuristic": AgentRef("scripted", "heuristic", GOBANG)}
    specs = specs_for_seatings(GOBANG, round_robin(list(refs), 4), league_seed=3)
    results = play_matches(specs, refs, sandbox_limits=FAST, forfeit_limit=3)
    forfeited = [r for r in results if r.forfeits]
    assert forfeited and all(r.forfeits[0][0] == "bad" and "onnxruntime failed" in r.forfeits[0][1]
                             for r in forfeited)
    clean = [s for s in specs if "bad" not in s.seats]
    played = {r.spec: r for r in results}
    assert [played[s] for s in clean] == play_matches(clean, refs)  # the others' matches, as without `bad`
    assert len(results) + sum(1 for s in specs if "bad" in s.seats and s not in played) == len(specs)


def test_a_call_larger_than_the_largest_batch_is_split_to_it(tmp_path):
    limit = largest_batch(CROSSROADS)
    assert limit == 64 * 4
    path = hostile.save(hostile.failing(CROSSROADS, above=limit), tmp_path / "a.onnx")
    specs = specs_for_seatings(CROSSROADS, [("a", "a")] * 128)
    results = play_matches(specs, {"a": AgentRef("onnx", str(path), CROSSROADS, sandboxed=True)}, batch_size=128,
                           sandbox_limits=FAST)
    assert len(results) == 128 and not any(r.forfeits for r in results)  # 512 rows a step, in calls of 256


def test_a_stacked_call_that_kills_the_child_is_replayed_member_by_member(tmp_path):
    game_id = "Crossroads-2T4P-v1"
    refs = {f"m{i}": AgentRef("arena-policy", str(mlp_folder(tmp_path, game_id, i, hidden=(2048, 2048))), game_id,
                              sandboxed=True) for i in (1, 2)}
    refs["script"] = AgentRef("scripted", "heuristic", game_id)
    # a budget no big call meets (each takes some GFLOP): the stacked call of m1 and m2 is stopped
    # and blames no one; run apart, each one's call is stopped in turn, and each forfeits alone
    limits = SandboxLimits(call_seconds=1e-6)
    results = play_matches(specs_for_seatings(game_id, round_robin(list(refs), 8)), refs, sandbox_limits=limits,
                           forfeit_limit=1)
    forfeited = {agent for r in results for agent, _ in r.forfeits}
    assert forfeited == {"m1", "m2"} and all(len(r.forfeits) == 1 for r in results)
    assert all("budget" in reason for r in results for _, reason in r.forfeits)
    assert all(r.outcomes[r.seats.index("script")] == "win" for r in results if "script" in r.seats)
    assert process_sandbox(limits).starts >= 3


def test_trusted_agents_are_not_held_to_the_call_budget(tmp_path):
    # a submitted agent and a trusted one (a base member) of one architecture: their stacked call is
    # stopped; run apart, only the submitted one is held to the budget, so only it forfeits
    game_id = "Crossroads-2T4P-v1"
    refs = {name: AgentRef("arena-policy", str(mlp_folder(tmp_path, game_id, seed, hidden=(2048, 2048))), game_id,
                           sandboxed=name == "submitted") for name, seed in (("submitted", 1), ("base", 2))}
    refs["script"] = AgentRef("scripted", "heuristic", game_id)
    results = play_matches(specs_for_seatings(game_id, round_robin(list(refs), 4)), refs,
                           sandbox_limits=SandboxLimits(call_seconds=1e-6), forfeit_limit=1)
    assert len(results) == 12
    assert {agent for r in results for agent, _ in r.forfeits} == {"submitted"}
    assert all(not r.forfeits for r in results if "submitted" not in r.seats)


def test_a_stacked_call_that_raises_is_run_member_by_member_in_the_child(tmp_path, monkeypatch):
    # the child's own logic, run here: a stacked forward that runs out of memory is retried member by
    # member, so only the member that fails alone is blamed and the other's rows get their actions
    from arena_league.policies.families import StackedPolicy, stack_policies
    from arena_league.policies.sandbox import _Child

    child = _Child(multiprocessing.RawArray("d", 4))
    folders = [mlp_folder(tmp_path, CROSSROADS, seed) for seed in (1, 2)]
    _, errors = child.load([(f"m{i}", AgentSource(str(f), CROSSROADS)) for i, f in enumerate(folders)])
    assert not errors
    [unit] = stack_policies([child.policies["m0"], child.policies["m1"]])
    member = StackedPolicy.member

    def out_of_memory(*args, **kwargs):
        raise MemoryError("a stacked forward too big")

    def member_one_fails(self, index):
        policy = member(self, index)
        if index == 1:
            monkeypatch.setattr(policy, "act", out_of_memory)
        return policy

    monkeypatch.setattr(unit.policy, "act", out_of_memory)
    monkeypatch.setattr(StackedPolicy, "member", member_one_fails)
    obs, uniforms = observations(CROSSROADS, 10)
    owners = np.arange(10) % 2
    actions, _, failures = child.guarded(0, unit, obs, uniforms, owners, None, None)
    assert failures == {1: "ran out of memory (a stacked forward too big)"}
    alone = member(unit.policy, 0).act(obs[owners == 0], uniforms[owners == 0])[0]
    np.testing.assert_array_equal(actions[owners == 0], alone)


def test_an_agent_that_cannot_load_forfeits_its_matches_without_a_step(tmp_path):
    refs = {"wrong": AgentRef("arena-policy", str(mlp_folder(tmp_path / "g", GOBANG, 3)), CROSSROADS, sandboxed=True),
            "fine": AgentRef("arena-policy", str(mlp_folder(tmp_path, CROSSROADS, 4)), CROSSROADS, sandboxed=True),
            "other": AgentRef("scripted", "heuristic", CROSSROADS)}
    specs = specs_for_seatings(CROSSROADS, round_robin(list(refs), 2))
    results = play_matches(specs, refs, sandbox_limits=FAST, forfeit_limit=5)
    wrong = [r for r in results if "wrong" in r.seats]
    assert len(wrong) == 4 and all(r.steps == 0 for r in wrong)
    assert all("could not be loaded" in r.forfeit_of["wrong"] and "GoBang" in r.forfeit_of["wrong"] for r in wrong)
    assert [r for r in results if "wrong" not in r.seats and r.forfeits] == []


def test_matches_through_the_sandbox_are_the_matches_played_in_process(tmp_path):
    for game_id in (CROSSROADS, GOBANG):
        folders = [mlp_folder(tmp_path / game_id, game_id, seed) for seed in range(4)]
        onnx = hostile.save(hostile.plain(CROSSROADS), tmp_path / "plain.onnx") if game_id == CROSSROADS else None
        names = [f"a{i}" for i in range(len(folders))] + (["onnx"] if onnx else [])
        paths = [*folders, *([onnx] if onnx else [])]
        specs = specs_for_seatings(game_id, round_robin(names, 2), league_seed=7)
        kinds = ["arena-policy"] * len(folders) + ["onnx"] * (onnx is not None)
        inprocess = play_matches(specs, {n: AgentRef(k, str(p), game_id) for n, k, p in zip(names, kinds, paths)},
                                 batch_size=8)
        sandboxed = play_matches(specs, {n: AgentRef(k, str(p), game_id, sandboxed=True)
                                         for n, k, p in zip(names, kinds, paths)}, batch_size=8)
        assert sandboxed == inprocess


def test_a_single_agent_call_over_budget_raises_and_the_next_call_gets_a_new_child(tmp_path):
    path = hostile.save(hostile.hanging(CROSSROADS, above=100), tmp_path / "h.onnx")
    with InferenceSandbox(FAST) as box:
        agent = box.load_one(AgentSource(str(path), CROSSROADS))
        obs, uniforms = observations(CROSSROADS, 150)
        with pytest.raises(ForfeitError, match="ran past its 0.5 s budget for a forward"):
            agent.act(obs, uniforms)
        actions, _ = agent.act(obs[:50], uniforms[:50])
        assert actions.shape == (50,) and box.starts == 2
    handle = load_agents({"h": AgentRef("onnx", str(path), CROSSROADS, sandboxed=True)}, FAST)["h"]
    with pytest.raises(ForfeitError, match="budget"):
        handle.act(obs, uniforms)


def test_the_child_dies_with_its_parent(tmp_path):
    script = textwrap.dedent(f"""
        import sys
        from arena_league.policies.sandbox import InferenceSandbox, AgentSource
        if __name__ == "__main__":
            box = InferenceSandbox()
            box.load({{"a": AgentSource("scripted:random", {CROSSROADS!r})}})
            print(box._process.pid, flush=True)
            import os
            os._exit(0)  # no clean-up: the child must go by itself
    """)
    path = tmp_path / "parent.py"
    path.write_text(script)
    done = subprocess.run([sys.executable, str(path)], capture_output=True, text=True, timeout=120, check=True,
                          cwd=os.path.dirname(__file__))
    pid = int(done.stdout.split()[-1])
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.1)
    pytest.fail(f"the sandbox child {pid} outlived its parent")
