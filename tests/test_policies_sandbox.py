"""The inference sandbox: agents compute in a child process, every failure stays with its agent.

Hostile ONNX graphs (a Loop of 10^15 iterations, a 3 GiB allocation, an onnxruntime failure, NaN
logits), each on every call or only past 100 rows, fail their own agent's call and no other; the
child is restarted after it had to die; stacked agents are run apart to find the one at fault;
matches played through the sandbox are the matches played in-process, bit for bit. The sandbox
child carries its own address-space limit, so none of these can take the machine down."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time

import hostile_agents as hostile
import numpy as np
import pytest

from arena_league.matchmaking import AgentRef, LockstepRunner, play_matches, round_robin, specs_for_seatings
from arena_league.matchmaking.agents import load_agents
from arena_league.policies import Architecture, game_action_spec, init_parameters, save_arena_policy
from arena_league.policies.sandbox import (
    AgentSource,
    GroupCall,
    InferenceSandbox,
    SandboxLimits,
    largest_batch,
)

CROSSROADS = "Crossroads-2T2P-v1"
GOBANG = "GoBang-2T1P-v1"
FAST = SandboxLimits(call_seconds=0.5)


def mlp_folder(tmp_path, game_id: str, seed: int, hidden=(16,), family: str = "mlp"):
    spec = game_action_spec(game_id)
    arch = Architecture(family, obs_dim=spec.obs_dim, action_type=spec.action_type, n_actions=spec.n_actions,
                        act_dim=spec.act_dim, hidden=hidden, **({"gru_size": 8} if family == "gru" else {}))
    return save_arena_policy(tmp_path / f"{family}-{seed}", arch, init_parameters(arch, seed), game_id,
                             name=f"{family}-{seed}")


def observations(game_id: str, rows: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    spec = game_action_spec(game_id)
    rng = np.random.default_rng(seed)
    return rng.standard_normal((rows, spec.obs_dim)).astype(np.float32), rng.random((rows, 1))


@pytest.fixture
def sandbox():
    with InferenceSandbox(FAST) as box:
        yield box


def test_hostile_calls_fail_only_their_own_agent(tmp_path, sandbox):
    models = {"hang": hostile.hanging(CROSSROADS, above=100), "alloc": hostile.allocating(CROSSROADS, 3 << 30, above=100),
              "fail": hostile.failing(CROSSROADS, above=100), "nan": hostile.nan_out(CROSSROADS, above=100),
              "plain": hostile.plain(CROSSROADS)}
    agents = {key: AgentSource(str(hostile.save(model, tmp_path / f"{key}.onnx")), CROSSROADS)
              for key, model in models.items()}
    handles = sandbox.load(agents)

    def step(rows: int):
        obs, uniforms = observations(CROSSROADS, rows)
        calls = [GroupCall(h.group, obs, uniforms, np.full(rows, h.position)) for h in handles.values()]
        return dict(zip(handles, sandbox.act_many(calls)))

    small = step(50)  # under the trigger: every agent plays
    assert all(not outcome.failures for outcome in small.values())
    assert sandbox.starts == 1
    started = time.monotonic()
    big = step(150)
    assert time.monotonic() - started < 10  # the hanging call was stopped at its budget
    reasons = {key: outcome.failures.get(handles[key].position) for key, outcome in big.items()}
    assert "ran past its 0.5 s budget for a call of 150 rows" in reasons["hang"]
    assert reasons["alloc"].startswith("ran out of memory") and "ConstantOfShape" in reasons["alloc"]
    assert reasons["fail"].startswith("failed: onnxruntime failed in a Reshape node")
    assert reasons["nan"].startswith("output NaN or infinite logits for 150 of 150")
    assert reasons["plain"] is None
    # the hang killed the child; the others were answered by a new one, and the plain agent's
    # actions are what the same agent computes in-process
    assert sandbox.starts == 2
    plain = load_agents({"p": AgentRef("onnx", agents["plain"].source, CROSSROADS)})["p"]
    obs, uniforms = observations(CROSSROADS, 150)
    np.testing.assert_array_equal(big["plain"].actions, plain.act(obs, uniforms)[0])


def test_a_call_larger_than_the_largest_batch_is_split_to_it(tmp_path, sandbox):
    limit = largest_batch(CROSSROADS)
    assert limit == 64 * 4
    agent = AgentSource(str(hostile.save(hostile.failing(CROSSROADS, above=limit), tmp_path / "a.onnx")), CROSSROADS)
    handle = sandbox.load({"a": agent})["a"]
    obs, uniforms = observations(CROSSROADS, 3 * limit + 5)
    actions, _ = handle.act(obs, uniforms)  # never sees more rows than validation tried
    assert actions.shape == (3 * limit + 5,)


def test_a_stacked_call_that_raises_is_run_member_by_member_in_the_child(tmp_path, monkeypatch):
    # the child's own logic, run here: a stacked forward that runs out of memory is retried member by
    # member, so only the member that fails alone is blamed and the other's rows get their actions
    import multiprocessing

    from arena_league.policies.families import StackedPolicy
    from arena_league.policies.sandbox import _Child

    child = _Child(multiprocessing.RawArray("d", 2))
    folders = [mlp_folder(tmp_path, CROSSROADS, seed) for seed in (1, 2)]
    _, errors, units = child.load([(f"m{i}", AgentSource(str(f), CROSSROADS)) for i, f in enumerate(folders)], [])
    assert not errors and units == [["m0", "m1"]]
    stacked = child.units[0].policy
    member = StackedPolicy.member

    def out_of_memory(*args, **kwargs):
        raise MemoryError("a stacked forward too big")

    def member_one_fails(self, index):
        policy = member(self, index)
        if index == 1:
            monkeypatch.setattr(policy, "act", out_of_memory)
        return policy

    monkeypatch.setattr(stacked, "act", out_of_memory)
    monkeypatch.setattr(StackedPolicy, "member", member_one_fails)
    obs, uniforms = observations(CROSSROADS, 10)
    owners = np.arange(10) % 2
    [(actions, _, failures)] = child.act([(0, obs, uniforms, owners, None, None)])
    assert failures == {1: "ran out of memory (a stacked forward too big)"}
    alone = member(stacked, 0).act(obs[owners == 0], uniforms[owners == 0])[0]
    np.testing.assert_array_equal(actions[owners == 0], alone)


def test_a_stacked_call_that_dies_is_run_member_by_member(tmp_path):
    game_id = "Crossroads-2T4P-v1"
    folders = [mlp_folder(tmp_path, game_id, seed, hidden=(2048, 2048)) for seed in (1, 2)]
    # a budget no call can meet (each takes a few GFLOP): the stacked call is stopped, then each
    # member's call alone, so the blame lands on each agent by itself
    with InferenceSandbox(SandboxLimits(call_seconds=1e-6)) as box:
        handles = box.load({f"m{i}": AgentSource(str(f), game_id) for i, f in enumerate(folders)})
        assert handles["m0"].group == handles["m1"].group
        rows = largest_batch(game_id)
        obs, uniforms = observations(game_id, rows)
        positions = np.arange(rows) % 2
        outcome = box.act_many([GroupCall(handles["m0"].group, obs, uniforms, positions)])[0]
        assert set(outcome.failures) == {0, 1}
        assert all("budget" in reason for reason in outcome.failures.values())
        assert box.starts == 4  # the first child, then one after the stacked call and each member


def test_an_agent_that_cannot_load_is_broken_and_the_others_play(tmp_path, sandbox):
    wrong_game = mlp_folder(tmp_path, GOBANG, 3)  # a GoBang agent offered to Crossroads
    fine = mlp_folder(tmp_path, CROSSROADS, 4)
    handles = sandbox.load({"wrong": AgentSource(str(wrong_game), CROSSROADS), "fine": AgentSource(str(fine), CROSSROADS)})
    assert "could not be loaded" in handles["wrong"].broken and "GoBang" in handles["wrong"].broken
    assert handles["fine"].broken is None
    obs, uniforms = observations(CROSSROADS, 8)
    calls = [GroupCall(handles[k].group, obs, uniforms, np.full(8, handles[k].position)) for k in ("wrong", "fine")]
    wrong, right = sandbox.act_many(calls)
    assert wrong.failures and not right.failures


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


def test_an_agent_that_fails_forfeits_its_matches_in_flight_and_is_then_skipped(tmp_path):
    game_id = CROSSROADS
    good = [mlp_folder(tmp_path, game_id, seed) for seed in (1, 2)]
    bad = hostile.save(hostile.failing(game_id, above=20), tmp_path / "bad.onnx")
    refs = {"g1": AgentRef("arena-policy", str(good[0]), game_id, sandboxed=True),
            "g2": AgentRef("arena-policy", str(good[1]), game_id, sandboxed=True),
            "bad": AgentRef("onnx", str(bad), game_id, sandboxed=True)}
    specs = specs_for_seatings(game_id, round_robin(["g1", "g2", "bad"], 12))
    policies = load_agents(refs, FAST)
    runner = LockstepRunner(game_id, policies, batch_size=32)
    results = runner.play(specs, forfeit_limit={"bad": 5})
    forfeited = [r for r in results if r.forfeits]
    # every match of `bad` in flight at its first failing call forfeited at once (team `bad` loses)
    assert forfeited and all(r.forfeit_of == {"bad": forfeited[0].forfeits[0][1]} for r in forfeited)
    assert "Reshape" in forfeited[0].forfeits[0][1]
    for result in forfeited:
        bad_team = result.teams[result.seats.index("bad")]
        assert all(o == ("loss" if t == bad_team else "win") for o, t in zip(result.outcomes, result.teams))
    assert runner.forfeit_counts["bad"] == len(forfeited) >= 5
    # then its remaining matches were skipped, and every match of the good pair was played
    played = {r.spec for r in results}
    assert {s for s in specs if "bad" not in s.seats} <= played
    assert all("bad" in s.seats for s in runner.skipped) and len(runner.skipped) + len(results) == len(specs)
    again = LockstepRunner(game_id, policies, batch_size=32).play(specs, forfeit_limit={"bad": 5})
    assert again == results  # forfeits are deterministic too


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
