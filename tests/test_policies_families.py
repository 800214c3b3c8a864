"""Policy families: seeded initialisation, a stacked population equal to its agents run one by one,
ONNX export equal to the torch forward, and policies that sample legal actions."""

from __future__ import annotations

import numpy as np
import onnx
import onnxruntime as ort
import pytest
import torch

from arena_league.policies import (
    Architecture,
    GridLayout,
    ManifestError,
    StackedFamily,
    StackedPolicy,
    TorchPolicy,
    build_module,
    export_onnx,
    init_parameters,
    manifest_for,
    scripted_policy,
    stack_policies,
)
from arena_league.policies.artifacts import manifest_architecture
from arena_league.policies.families import RowGroups
from arena_league.policies.threads import torch_threads

ARCHITECTURES = {
    "mlp-discrete": Architecture("mlp", 25, "discrete", n_actions=5, hidden=(32, 32)),
    "mlp-continuous-relu": Architecture("mlp", 19, "continuous", act_dim=2, hidden=(16,), activation="relu"),
    "cnn-gobang": Architecture("cnn", 455, "discrete", n_actions=225, hidden=(32,), grid=GridLayout(2, 15, 15, 0),
                               conv_channels=(4, 4)),
    "cnn-grid-in-the-middle": Architecture("cnn", 40, "continuous", act_dim=3, hidden=(), conv_channels=(3,),
                                           grid=GridLayout(2, 3, 4, 7), kernel_size=3),
    "gru-discrete": Architecture("gru", 25, "discrete", n_actions=5, hidden=(16,), gru_size=8),
    "gru-continuous": Architecture("gru", 19, "continuous", act_dim=2, hidden=(), gru_size=6),
    "mlp-gaussian": Architecture("mlp", 19, "continuous", act_dim=3, hidden=(16,), noise="gaussian"),
    "gru-squashed": Architecture("gru", 19, "continuous", act_dim=2, hidden=(8,), gru_size=6, noise="squashed"),
}


@pytest.fixture(autouse=True)
def one_torch_thread():
    with torch_threads(1):
        yield


def _sharpened(arch: Architecture, seed: int) -> dict[str, torch.Tensor]:
    """Parameters whose outputs are far from zero (a fresh head is scaled by 0.01)."""
    params = init_parameters(arch, seed)
    params["head.weight"] = params["head.weight"] * 100
    if "log_std" in params:
        params["log_std"] = torch.linspace(-2.0, -0.5, arch.act_dim) + 0.1 * seed
    return params


def test_initialisation_is_a_function_of_the_seed():
    arch = ARCHITECTURES["cnn-gobang"]
    first, again, other = init_parameters(arch, 3), init_parameters(arch, 3), init_parameters(arch, 4)
    assert all(torch.equal(first[k], again[k]) for k in first)
    assert not torch.equal(first["hidden.0.weight"], other["hidden.0.weight"])
    assert set(first) == set(arch.parameter_shapes())


@pytest.mark.parametrize("name", list(ARCHITECTURES))
def test_stacked_forward_equals_each_agent_run_alone(name):
    arch = ARCHITECTURES[name]
    rng = np.random.default_rng(0)
    n_members = 6
    members = [_sharpened(arch, seed) for seed in range(n_members)]
    stacked = StackedFamily(arch, members)
    alone = [build_module(arch, m) for m in members]
    # Balanced owners, one owner holding most rows, and owners missing from the batch.
    for owners in (rng.integers(0, n_members, 60), np.array([2] * 50 + [0, 5, 5]), np.array([4, 1])):
        obs = torch.from_numpy(rng.standard_normal((len(owners), arch.obs_dim)).astype(np.float32))
        state = torch.from_numpy(rng.standard_normal((len(owners), arch.gru_size)).astype(np.float32)) \
            if arch.recurrent else None
        with torch.inference_mode():
            out, state_out = stacked(obs, torch.from_numpy(owners), state)
            for i, owner in enumerate(owners):
                expected, expected_state = alone[owner](obs[i: i + 1], state[i: i + 1] if state is not None else None)
                torch.testing.assert_close(out[i: i + 1], expected, rtol=1e-5, atol=1e-5)
                if arch.recurrent:
                    torch.testing.assert_close(state_out[i: i + 1], expected_state, rtol=1e-5, atol=1e-5)
    for i in range(n_members):
        restored = stacked.member_parameters(i)
        assert all(torch.equal(restored[k], members[i][k]) for k in restored)


@pytest.mark.parametrize("name", list(ARCHITECTURES))
def test_onnx_export_equals_the_torch_forward(name):
    arch = ARCHITECTURES[name]
    params = _sharpened(arch, 11)
    session = ort.InferenceSession(export_onnx(arch, params), providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(1)
    for batch in (1, 7):
        obs = rng.standard_normal((batch, arch.obs_dim)).astype(np.float32)
        feeds = {"obs": obs}
        state = None
        if arch.recurrent:
            state = rng.standard_normal((batch, arch.gru_size)).astype(np.float32)
            feeds["state_in"] = state
        results = dict(zip([o.name for o in session.get_outputs()], session.run(None, feeds)))
        with torch.inference_mode():
            expected, expected_state = build_module(arch, params)(
                torch.from_numpy(obs), torch.from_numpy(state) if state is not None else None)
        output = "logits" if arch.action_type == "discrete" else "action"
        noisy = {"log_std"} if arch.noise != "none" else set()
        assert set(results) == ({output, "state_out"} if arch.recurrent else {output}) | noisy
        if noisy:
            np.testing.assert_array_equal(results["log_std"],
                                          np.broadcast_to(params["log_std"].numpy(), (batch, arch.act_dim)))
        np.testing.assert_allclose(results[output], expected.numpy(), rtol=1e-5, atol=1e-5)
        if arch.recurrent:
            np.testing.assert_allclose(results["state_out"], expected_state.numpy(), rtol=1e-5, atol=1e-5)
    obs_input = onnx.load_model_from_string(export_onnx(arch, params)).graph.input[0]
    assert obs_input.type.tensor_type.shape.dim[0].dim_param == "N"  # the batch dimension is dynamic


def test_a_stacked_member_exports_to_the_same_onnx_as_the_agent_alone():
    arch = ARCHITECTURES["gru-discrete"]
    stacked = StackedPolicy.from_seeds(arch, [5, 6, 7])
    assert stacked.export_member_onnx(1, game_id="Crossroads-2T2P-v1") == export_onnx(
        arch, init_parameters(arch, 6), game_id="Crossroads-2T2P-v1")


def test_stacked_policy_acts_like_its_members_whatever_the_batch():
    arch = ARCHITECTURES["mlp-discrete"]
    policies = [TorchPolicy(arch, _sharpened(arch, s), name=f"agent-{s}") for s in range(5)]
    stacked = StackedPolicy.from_policies(policies)
    rng = np.random.default_rng(2)
    owners = rng.integers(0, 5, 200)
    obs = rng.standard_normal((200, 25)).astype(np.float32)
    uniforms = rng.random((200, 1))
    mask = rng.random((200, 5)) < 0.6
    actions, _ = stacked.act(obs, uniforms, mask, owners=owners)
    for member, policy in enumerate(policies):
        rows = owners == member
        alone, _ = policy.act(obs[rows], uniforms[rows], mask[rows])
        np.testing.assert_array_equal(actions[rows], alone)
    # Float64 compute: the same rows give the same logits in any batch composition.
    logits = stacked.bundle(torch.from_numpy(obs), torch.from_numpy(owners))[0]
    part = stacked.bundle(torch.from_numpy(obs[::3]), torch.from_numpy(owners[::3]))[0]
    torch.testing.assert_close(part, logits[::3], rtol=0, atol=1e-12)
    legal = mask | ~mask.any(axis=1, keepdims=True)
    assert legal[np.arange(200), actions].all()


def test_stack_policies_groups_agents_of_one_architecture_for_the_engine():
    mlp, gru = ARCHITECTURES["mlp-discrete"], ARCHITECTURES["gru-discrete"]
    policies = [TorchPolicy(mlp, seed=0), scripted_policy("random", "Crossroads-2T2P-v1"), TorchPolicy(mlp, seed=1),
                TorchPolicy(gru, seed=2), TorchPolicy(mlp, seed=3)]
    groups = stack_policies(policies)
    assert [g.members for g in groups] == [(0, 2, 4), (1,), (3,)]
    assert isinstance(groups[0].policy, StackedPolicy) and groups[0].policy.n_members == 3
    rng = np.random.default_rng(3)
    obs = rng.standard_normal((9, 25)).astype(np.float32)
    uniforms = rng.random((9, 1))
    owners = np.array([0, 1, 2, 2, 1, 0, 0, 2, 1])  # positions in the group's members
    actions, _ = groups[0].act(obs, uniforms, owners)
    for position, index in enumerate(groups[0].members):
        rows = owners == position
        np.testing.assert_array_equal(actions[rows], policies[index].act(obs[rows], uniforms[rows])[0])
    state = policies[3].initial_state(9)
    _, next_state = groups[2].act(obs, uniforms, np.zeros(9, np.int64), state=state)
    assert next_state.shape == (9, 8) and not np.array_equal(next_state, state)


def test_continuous_policies_stay_in_range_and_greedy_picks_the_best_legal_action():
    arch = ARCHITECTURES["mlp-continuous-relu"]
    policy = TorchPolicy(arch, _sharpened(arch, 0))
    obs = np.random.default_rng(4).standard_normal((50, 19)).astype(np.float32) * 10
    actions, _ = policy.act(obs, np.random.default_rng(5).random((50, 2)))
    assert actions.shape == (50, 2) and actions.dtype == np.float32 and np.abs(actions).max() <= 1.0
    discrete = TorchPolicy(ARCHITECTURES["mlp-discrete"], _sharpened(ARCHITECTURES["mlp-discrete"], 1), greedy=True)
    obs = np.random.default_rng(6).standard_normal((20, 25)).astype(np.float32)
    logits, _ = discrete.forward(obs)
    mask = np.ones((20, 5), bool)
    mask[:, logits.argmax(axis=1)[0]] = False
    chosen, _ = discrete.act(obs, np.zeros((20, 1)), mask)
    np.testing.assert_array_equal(chosen, np.where(mask, logits, -np.inf).argmax(axis=1))


def test_manifests_round_trip_and_bad_sizes_are_named():
    for arch in ARCHITECTURES.values():
        assert manifest_architecture(manifest_for(arch, "Crossroads-2T2P-v1")) == arch
    with pytest.raises(ManifestError, match="kernel_size must be odd"):
        Architecture("cnn", 455, "discrete", n_actions=225, grid=GridLayout(2, 15, 15), conv_channels=(4,),
                     kernel_size=4)
    with pytest.raises(ManifestError, match=r"needs 460 observation cells, but obs_dim is 455"):
        Architecture("cnn", 455, "discrete", n_actions=225, grid=GridLayout(2, 15, 15, 10), conv_channels=(4,))
    manifest = manifest_for(ARCHITECTURES["mlp-discrete"], "Crossroads-2T2P-v1")
    manifest["sizes"]["hiden"] = [3]
    with pytest.raises(ManifestError, match=r"unknown size\(s\) 'hiden' for the mlp family"):
        manifest_architecture(manifest)


def test_row_groups_round_trip_and_keep_padding_bounded():
    rng = np.random.default_rng(7)
    n_members = 100
    layouts = set()
    for owner_rows in (rng.integers(0, n_members, 800), rng.integers(0, 10, 50), np.array([3] * 500 + [1, 2, 9]),
                       rng.zipf(1.5, 400) % n_members):
        owners = torch.from_numpy(owner_rows.astype(np.int64))
        groups = RowGroups.of(owners, n_members)
        rows = torch.arange(len(owners), dtype=torch.float64)[:, None]
        assert torch.equal(groups.unpad(groups.pad(rows)), rows)
        padded = groups.pad(rows)
        assert torch.equal(groups.group_owner[groups.slot], owners[groups.order])  # each row meets its owner
        assert padded.shape[0] * padded.shape[1] <= 4 * len(owners) + n_members
        layouts.add(groups.identity)
    assert layouts == {True, False}


@pytest.mark.parametrize("name", ["mlp-gaussian", "gru-squashed"])
def test_noisy_continuous_agents_sample_around_their_mean_the_same_way_everywhere(name):
    """A continuous agent with noise plays mean + exp(log_std) z (clipped, or squashed by tanh),
    z from the engine's uniforms: stacked, alone and exported to ONNX it draws the same actions,
    greedy it plays the mean, and its draws have the learned spread."""
    arch = ARCHITECTURES[name]
    members = [_sharpened(arch, seed) for seed in range(3)]
    members[1]["head.weight"] = members[1]["head.weight"] * 0  # mean 0, spread small: far from the bounds
    members[1]["log_std"] = torch.linspace(-2.5, -1.5, arch.act_dim)
    alone = [TorchPolicy(arch, m) for m in members]
    stacked = StackedPolicy.from_policies(alone)
    rng = np.random.default_rng(3)
    obs = rng.standard_normal((30, arch.obs_dim)).astype(np.float32)
    uniforms = rng.random((30, arch.act_dim))
    owners = np.arange(30) % 3
    state = stacked.initial_state(30)
    actions, _ = stacked.act(obs, uniforms, state=state, owners=owners)
    assert actions.dtype == np.float32 and np.abs(actions).max() <= 1.0
    for i in range(30):
        single, _ = alone[owners[i]].act(obs[i: i + 1], uniforms[i: i + 1], state=state[i: i + 1] if state is not None
                                         else None)
        np.testing.assert_allclose(actions[i: i + 1], single, rtol=1e-6, atol=1e-6)
    mean, _ = alone[0].forward(obs, state)
    greedy, _ = TorchPolicy(arch, members[0], greedy=True).act(obs, uniforms, state=state)
    np.testing.assert_allclose(greedy, mean, rtol=1e-6, atol=1e-6)
    assert not np.allclose(alone[0].act(obs, uniforms, state=state)[0], mean, atol=1e-3)
    onnx_agent = load_policy_from_onnx(alone[2].export_onnx(), arch)
    np.testing.assert_allclose(onnx_agent.act(obs, uniforms, state=state)[0], alone[2].act(obs, uniforms, state=state)[0],
                               rtol=1e-5, atol=1e-5)
    # Many draws for the zero-mean member: the spread of each component is its exp(log_std).
    many = rng.standard_normal((20_000, arch.obs_dim)).astype(np.float32)
    draws, _ = alone[1].act(many, rng.random((20_000, arch.act_dim)), state=alone[1].initial_state(20_000))
    std = np.exp(members[1]["log_std"].numpy())
    raw = draws if arch.noise == "gaussian" else np.arctanh(draws)
    np.testing.assert_allclose(raw.std(axis=0), std, rtol=0.05)
    np.testing.assert_allclose(raw.mean(axis=0), 0.0, atol=0.02)


def load_policy_from_onnx(data: bytes, arch: Architecture):
    from arena_league.policies.onnx_policy import OnnxPolicy

    return OnnxPolicy(data, arch.spec, "Crossroads-2T2P-v1")


def test_noise_is_named_in_the_manifest_and_bad_noise_is_refused():
    arch = ARCHITECTURES["mlp-gaussian"]
    manifest = manifest_for(arch, "Crossroads-2T2P-v1")
    assert manifest["sizes"]["noise"] == "gaussian" and manifest_architecture(manifest) == arch
    assert "noise" not in manifest_for(ARCHITECTURES["mlp-continuous-relu"], "Crossroads-2T2P-v1")["sizes"]
    assert arch.parameter_shapes()["log_std"] == (3,)
    manifest["sizes"]["noise"] = "uniform"
    with pytest.raises(ManifestError, match=r"unknown noise 'uniform'; valid: none, gaussian, squashed"):
        manifest_architecture(manifest)
    with pytest.raises(ManifestError, match="noise 'gaussian' belongs to continuous agents"):
        Architecture("mlp", 25, "discrete", n_actions=5, noise="gaussian")
    params = init_parameters(arch, 0)
    del params["log_std"]
    with pytest.raises(ManifestError, match=r"missing log_std"):
        TorchPolicy(arch, params)


def test_an_onnx_agent_with_a_malformed_log_std_or_noise_is_refused_with_the_fix():
    from arena_league.policies import SpaceMismatchError

    arch = ARCHITECTURES["mlp-gaussian"]
    model = onnx.load_model_from_string(TorchPolicy(arch, _sharpened(arch, 0)).export_onnx())
    wide = onnx.ModelProto()
    wide.CopyFrom(model)
    wide.graph.output[-1].type.tensor_type.shape.dim[1].dim_value = 5
    with pytest.raises(SpaceMismatchError, match=r"log_std is float32\[N, 5\]; .* log_std is float32\[N, 3\]"):
        load_policy_from_onnx(wide.SerializeToString(), arch)
    onnx.helper.set_model_props(model, {"arena_league.noise": "laplace"})
    with pytest.raises(SpaceMismatchError, match=r"arena_league.noise is 'laplace'; valid: gaussian, squashed"):
        load_policy_from_onnx(model.SerializeToString(), arch)
