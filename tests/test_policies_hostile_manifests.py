"""Hostile arena-policy folders are refused from the manifest and the safetensors header alone,
before any tensor is allocated: absurd widths, GRU sizes, layer counts and parameter counts,
headers that lie about shapes or point past the file, deeply nested and oversized JSON. Each
hostile load runs in a subprocess under a 2 GiB address-space limit, so a regression ends in a
failed assertion, not a machine out of memory."""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from arena_league.policies import (
    DEFAULT_LIMITS,
    Architecture,
    ArtifactTooLargeError,
    CorruptArtifactError,
    ManifestError,
    game_action_spec,
    init_parameters,
    load_agent,
    read_artifact,
    save_arena_policy,
    unpack_artifact,
)
from arena_league.policies import artifacts as artifacts_module
from arena_league.policies.artifacts import (
    ArtifactLimits,
    check_architecture_limits,
    load_json,
    manifest_architecture,
    pack_artifact,
)
from arena_league.policies.errors import WeightsMismatchError
from arena_league.policies.threads import torch_threads

GAME = "GoBang-2T1P-v1"
SPEC = game_action_spec(GAME)
ARCH = Architecture("mlp", obs_dim=SPEC.obs_dim, action_type="discrete", n_actions=SPEC.n_actions, hidden=(16,))
ROOT = Path(__file__).resolve().parent.parent
CHECKPOINTS = ROOT / "checkpoints"
#: The address space each hostile load runs in.
MEMORY_LIMIT = 2 * 1024**3
#: Seconds a refusal may take once the modules are imported (it reads a few KiB).
REFUSAL_SECONDS = 5.0

_LOAD = f"""
import resource, sys, time
resource.setrlimit(resource.RLIMIT_AS, ({MEMORY_LIMIT}, {MEMORY_LIMIT}))
from arena_league.policies.artifacts import load_agent, read_artifact
from arena_league.policies.errors import ArtifactError
start = time.perf_counter()
try:
    if sys.argv[2] == "read":
        read_artifact(sys.argv[1])
    else:
        load_agent(sys.argv[1], {GAME!r})
except ArtifactError as error:
    print(type(error).__name__, time.perf_counter() - start)
    print(error)
else:
    print("accepted", time.perf_counter() - start)
"""

_SUBMIT = f"""
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, ({MEMORY_LIMIT}, {MEMORY_LIMIT}))
from arena_league.cli import main
sys.exit(main(["submit", sys.argv[1], "--game", {GAME!r}, "--name", "x"]))
"""


@pytest.fixture(autouse=True)
def one_torch_thread():
    with torch_threads(1):
        yield


# --- building hostile folders ----------------------------------------------------------------------

def agent_folder(tmp_path: Path, name: str = "agent") -> Path:
    return save_arena_policy(tmp_path / name, ARCH, init_parameters(ARCH, 0), GAME, name="agent")


def with_manifest(tmp_path: Path, edit, name: str = "hostile") -> Path:
    """A folder of ARCH's weights whose manifest ``edit`` changed (in place, on the parsed object)."""
    folder = agent_folder(tmp_path, name)
    manifest = json.loads((folder / "manifest.json").read_text())
    edit(manifest)
    (folder / "manifest.json").write_text(json.dumps(manifest))
    return folder


def header_of(folder: Path) -> tuple[dict, bytes]:
    data = (folder / "weights.safetensors").read_bytes()
    length = struct.unpack("<Q", data[:8])[0]
    return json.loads(data[8: 8 + length]), data[8 + length:]


def with_header(folder: Path, header: dict | bytes, body: bytes) -> Path:
    text = header if isinstance(header, bytes) else json.dumps(header).encode()
    (folder / "weights.safetensors").write_bytes(struct.pack("<Q", len(text)) + text + body)
    return folder


def sizes(**values):
    def edit(manifest: dict) -> None:
        manifest["sizes"].update(values)
    return edit


def gru(size: int):
    def edit(manifest: dict) -> None:
        manifest["family"] = "gru"
        manifest["sizes"]["gru_size"] = size
    return edit


def cnn(conv_channels: list[int], kernel_size: int):
    def edit(manifest: dict) -> None:
        manifest["family"] = "cnn"
        manifest["sizes"].update(grid={"channels": 1, "height": 15, "width": 15, "offset": 0},
                                 conv_channels=conv_channels, kernel_size=kernel_size)
    return edit


def deep_manifest(folder: Path, depth: int) -> Path:
    """The manifest with a ``provenance`` nested ``depth`` arrays deep (written as text: json.dumps
    would recurse)."""
    text = (folder / "manifest.json").read_text().rstrip().rstrip("}")
    (folder / "manifest.json").write_text(text + ', "provenance": ' + "[" * depth + "]" * depth + "}")
    return folder


# --- running a hostile load under a memory limit ----------------------------------------------------

def refusal(folder: Path, how: str = "read") -> tuple[str, str]:
    """(error class, message) of loading ``folder`` in a subprocess capped at 2 GiB of address
    space; fails if it crashes, is killed, accepts the folder or takes long."""
    started = time.perf_counter()
    run = subprocess.run([sys.executable, "-c", _LOAD, str(folder), how], check=False, capture_output=True,
                         text=True, timeout=120, cwd=ROOT)
    assert run.returncode == 0, f"the load crashed (exit {run.returncode}) after {time.perf_counter() - started:.1f} " \
                                f"s:\n{run.stderr[-3000:]}"
    first, _, message = run.stdout.partition("\n")
    kind, seconds = first.split()
    assert kind != "accepted", f"{folder} was accepted"
    assert float(seconds) < REFUSAL_SECONDS, f"the refusal took {seconds} s"
    return kind, message.strip()


def submit_refused(folder: Path, tmp_path: Path) -> str:
    """The one stderr line of ``arena-league submit`` refusing ``folder`` (exit 2, nothing stored),
    run under the memory limit."""
    home = tmp_path / "home"
    env = {k: v for k, v in os.environ.items() if k != "ARENA_LEAGUE_DB"} | {"ARENA_LEAGUE_HOME": str(home)}
    run = subprocess.run([sys.executable, "-c", _SUBMIT, str(folder)], check=False, capture_output=True, text=True,
                         timeout=300, cwd=ROOT, env=env)
    assert run.returncode == 2, f"exit {run.returncode}:\n{run.stdout[-2000:]}\n{run.stderr[-3000:]}"
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in run.stderr, run.stderr
    stored = [p for p in (home / "artifacts").rglob("*") if p.is_file()] if (home / "artifacts").exists() else []
    assert stored == [], f"the refused agent was stored: {stored}"
    return lines[0]


# --- the declared policy is over a limit --------------------------------------------------------------

@pytest.mark.parametrize(("edit", "limit"), [
    (sizes(hidden=[2_000_000]), "max_width"),
    (sizes(hidden=[10**9]), "max_width"),
    (gru(30_000), "max_gru_size"),
    (sizes(hidden=[8] * 5000), "max_layers"),
    (sizes(hidden=[4096] * 16), "max_parameters"),
    (cnn([100_000], 3), "max_conv_channels"),
    (cnn([16] * 40, 3), "max_layers"),
    (cnn([16], 10_001), "max_kernel_size"),
], ids=["hidden-2e6", "hidden-1e9", "gru-30000", "5000-layers", "parameters", "conv-channels", "convolutions",
        "kernel"])
def test_an_oversized_declared_policy_is_refused_before_allocation(tmp_path, edit, limit):
    folder = with_manifest(tmp_path, edit)
    for how in ("read", "load"):
        kind, message = refusal(folder, how)
        assert kind == "ArtifactTooLargeError", message
        assert f"ArtifactLimits.{limit}" in message and "nothing was allocated" in message
        assert "smaller policy" in message  # the fix


def test_the_limit_names_the_figure(tmp_path):
    with pytest.raises(ArtifactTooLargeError, match=r"width 2,000,000, over the limit of 4,096 .*max_width"):
        read_artifact(with_manifest(tmp_path, sizes(hidden=[2_000_000])))
    with pytest.raises(ArtifactTooLargeError, match=r"gru_size of 30,000, over the limit of 4,096"):
        read_artifact(with_manifest(tmp_path, gru(30_000), "gru"))
    with pytest.raises(ArtifactTooLargeError, match=r"has 254,509,281 parameters \(971 MiB as float32\), over the "
                                                    r"limit of 16,777,216 \(ArtifactLimits\.max_parameters\)"):
        read_artifact(with_manifest(tmp_path, sizes(hidden=[4096] * 16), "wide"))


def test_limits_can_be_raised_for_a_league_of_ones_own(tmp_path):
    arch = manifest_architecture(json.loads((with_manifest(tmp_path, sizes(hidden=[5000])) / "manifest.json")
                                            .read_text()))
    with pytest.raises(ArtifactTooLargeError, match="max_width"):
        check_architecture_limits(arch)
    assert check_architecture_limits(arch, ArtifactLimits(max_width=5000)) == arch.n_parameters()


# --- the safetensors header ---------------------------------------------------------------------

def test_a_header_claiming_huge_shapes_is_refused_before_loading(tmp_path):
    folder = agent_folder(tmp_path)
    header, body = header_of(folder)
    header["hidden.0.weight"]["shape"] = [1_000_000, 1_000_000]
    kind, message = refusal(with_header(folder, header, body))
    assert kind == "CorruptArtifactError" and "hidden.0.weight" in message and "data_offsets span" in message
    begin = header["hidden.0.weight"]["data_offsets"][0]
    header["hidden.0.weight"]["data_offsets"] = [begin, begin + 4 * 10**12]
    kind, message = refusal(with_header(folder, header, body))
    assert kind == "CorruptArtifactError" and "past the end of the file" in message and "save_file" in message


def test_a_header_length_over_the_limit_is_refused_unread(tmp_path):
    folder = agent_folder(tmp_path)
    (folder / "weights.safetensors").write_bytes(struct.pack("<Q", 1 << 40) + b"{}" * 100)
    kind, message = refusal(folder)
    assert kind == "ArtifactTooLargeError" and "max_safetensors_header_bytes" in message


def test_a_deeply_nested_header_is_refused_unparsed(tmp_path):
    folder = agent_folder(tmp_path)
    header, body = header_of(folder)
    text = json.dumps(header).encode()[:-1] + b', "__metadata__": ' + b"[" * 20_000 + b"]" * 20_000 + b"}"
    kind, message = refusal(with_header(folder, text, body))
    assert kind == "ArtifactTooLargeError" and "max_json_depth" in message


def test_offsets_past_the_file_are_refused(tmp_path):
    folder = agent_folder(tmp_path)
    header, body = header_of(folder)
    last = max(header.values(), key=lambda e: e.get("data_offsets", [0, 0])[1] if isinstance(e, dict) else 0)
    last["data_offsets"] = [o + 1024 for o in last["data_offsets"]]
    kind, message = refusal(with_header(folder, header, body))
    assert kind == "CorruptArtifactError" and "past the end of the file" in message


def test_gaps_and_overlaps_between_tensors_are_refused(tmp_path):
    folder = agent_folder(tmp_path)
    header, body = header_of(folder)
    header["head.bias"]["data_offsets"] = [4, 4 + 4 * SPEC.n_actions]
    with pytest.raises(CorruptArtifactError, match="a gap or an overlap"):
        read_artifact(with_header(folder, header, body))


def test_a_header_that_contradicts_the_manifest_is_refused_before_loading(tmp_path, monkeypatch):
    folder = with_manifest(tmp_path, sizes(hidden=[32]))
    assert read_artifact(folder).kind == "arena-policy"  # each file is well formed on its own
    kind, message = refusal(folder, "load")
    assert kind == "WeightsMismatchError"
    assert "hidden.0.weight has shape [16, 455]" in message and "needs [32, 455]" in message

    def no_loading(*args, **kwargs):
        raise AssertionError("safetensors was asked to load the tensors")

    monkeypatch.setattr(artifacts_module, "load_safetensors", no_loading)
    with pytest.raises(WeightsMismatchError) as raised:
        load_agent(folder, GAME)
    assert isinstance(raised.value, ManifestError) and isinstance(raised.value, CorruptArtifactError)
    header, body = header_of(folder)
    header["hidden.0.weight"]["dtype"] = "I32"
    (folder / "manifest.json").write_text(json.dumps(read_artifact(agent_folder(tmp_path, "fine")).manifest()))
    with pytest.raises(WeightsMismatchError, match="hidden.0.weight has dtype I32; weights are floating point"):
        load_agent(with_header(folder, header, body), GAME)
    header["hidden.0.weight"]["dtype"] = "F32"
    header["extra"] = {"dtype": "F32", "shape": [0], "data_offsets": [len(body), len(body)]}
    with pytest.raises(WeightsMismatchError, match="unexpected extra"):
        load_agent(with_header(folder, header, body), GAME)


# --- JSON depth and size --------------------------------------------------------------------------

def test_a_20000_deep_manifest_is_refused_without_recursion(tmp_path):
    folder = deep_manifest(agent_folder(tmp_path), 20_000)
    for how in ("read", "load"):
        kind, message = refusal(folder, how)
        assert kind == "ArtifactTooLargeError" and "more than 32 deep" in message and "max_json_depth" in message
    (folder / "manifest.json").write_text('{"a":' * 10_000 + "0" + "}" * 10_000)
    kind, message = refusal(folder)
    assert kind == "ArtifactTooLargeError" and "max_json_depth" in message


def test_an_oversized_manifest_is_refused_by_its_size_before_it_is_read(tmp_path, monkeypatch):
    folder = with_manifest(tmp_path, lambda m: m.update(description="x" * 100_000))
    kind, message = refusal(folder)
    assert kind == "ArtifactTooLargeError" and "manifest.json" in message and "it was not read" in message


def test_json_agent_files_and_packed_blobs_are_bounded_too(tmp_path):
    deep = tmp_path / "agent.json"
    deep.write_text('{"a":' * 10_000 + "0" + "}" * 10_000)
    with pytest.raises(ArtifactTooLargeError, match="max_json_depth"):
        read_artifact(deep)
    with pytest.raises(ArtifactTooLargeError, match="max_json_depth"):
        unpack_artifact(b'{"a":' * 10_000 + b"0" + b"}" * 10_000)
    assert unpack_artifact(pack_artifact(read_artifact(agent_folder(tmp_path)))).kind == "arena-policy"
    wide = read_artifact(with_manifest(tmp_path, sizes(hidden=[5000]), "wide"), ArtifactLimits(max_width=5000))
    with pytest.raises(ArtifactTooLargeError, match="max_width"):
        unpack_artifact(pack_artifact(wide))


def test_the_depth_scan_reads_strings_as_strings():
    text = b'{"a[[[[": "]]]]}}}", "b": "\\"[[[[", "c": [[1]], "d": "\\\\"}'
    assert load_json(text, "x", "test", 1000, ArtifactLimits(max_json_depth=3)) == json.loads(text)
    with pytest.raises(ArtifactTooLargeError):
        load_json(b'{"a": "[", "b": [[[1]]]}', "x", "test", 1000, ArtifactLimits(max_json_depth=3))
    with pytest.raises(CorruptArtifactError, match="not valid JSON"):
        load_json(b'["' + b"[" * 10_000, "x", "test", 100_000)  # an unterminated string ends the scan
    utf16 = json.dumps({"a": '"' + "[" * 50, "b": [[1]]}).encode("utf-16")
    assert load_json(utf16, "x", "test", 10_000, ArtifactLimits(max_json_depth=3))["b"] == [[1]]


# --- through the command --------------------------------------------------------------------------

@pytest.mark.parametrize("case", ["hidden-1e9", "gru-30000", "deep-json", "header-mismatch", "offsets", "oversized"])
def test_submit_refuses_hostile_folders_with_one_line_and_stores_nothing(tmp_path, case):
    if case == "hidden-1e9":
        folder, expected = with_manifest(tmp_path, sizes(hidden=[10**9])), "ArtifactLimits.max_width"
    elif case == "gru-30000":
        folder, expected = with_manifest(tmp_path, gru(30_000)), "ArtifactLimits.max_gru_size"
    elif case == "deep-json":
        folder, expected = deep_manifest(agent_folder(tmp_path), 20_000), "ArtifactLimits.max_json_depth"
    elif case == "header-mismatch":
        folder, expected = with_manifest(tmp_path, sizes(hidden=[2048])), "needs [2048, 455]"
    elif case == "offsets":
        folder = agent_folder(tmp_path)
        header, body = header_of(folder)
        header["head.bias"]["shape"], header["head.bias"]["data_offsets"] = [10**6], [0, 4 * 10**6]
        folder, expected = with_header(folder, header, body), "past the end of the file"
    else:
        folder = with_manifest(tmp_path, lambda m: m.update(description="x" * 100_000))
        expected = "over the limit of 64 KiB"
    line = submit_refused(folder, tmp_path)
    assert line.startswith("error:") and expected in line, line


# --- what is not hostile still loads --------------------------------------------------------------

def test_a_normal_agent_loads_and_plays(tmp_path):
    loaded = load_agent(agent_folder(tmp_path), GAME)
    assert loaded.info.family == "mlp" and loaded.info.obs_dim == SPEC.obs_dim
    obs = np.zeros((2, SPEC.obs_dim), dtype=np.float32)
    actions, _ = loaded.policy.act(obs, np.full((2, 1), 0.5))
    assert actions.shape[0] == 2


def test_a_generous_real_agent_is_within_the_default_limits(tmp_path):
    big = Architecture("gru", obs_dim=SPEC.obs_dim, action_type="discrete", n_actions=SPEC.n_actions,
                       hidden=(1024, 1024), gru_size=512)
    assert check_architecture_limits(big) == big.n_parameters() > 2_000_000
    folder = save_arena_policy(tmp_path / "big", big, init_parameters(big, 0), GAME)
    assert load_agent(folder, GAME).info.state_shape == (512,)
    assert DEFAULT_LIMITS.max_parameters * 4 <= 64 * 1024**2  # far below GBs


SHIPPED = sorted(CHECKPOINTS.glob("*/base-v1"))


@pytest.mark.parametrize("population", SHIPPED, ids=lambda p: p.parent.name)
def test_a_member_of_each_shipped_population_loads(population):
    members = sorted((population / "agents").iterdir())
    largest = max(members, key=lambda m: manifest_architecture(json.loads((m / "manifest.json").read_text()))
                  .n_parameters())
    loaded = load_agent(largest, population.parent.name)
    assert loaded.info.game_id == population.parent.name
    assert loaded.policy.architecture.n_parameters() * 100 < DEFAULT_LIMITS.max_parameters


def test_every_shipped_member_is_within_the_limits():
    manifests = sorted(CHECKPOINTS.glob("*/base-v1/agents/*/manifest.json"))
    assert manifests
    for path in manifests:
        check_architecture_limits(manifest_architecture(json.loads(path.read_text())), source=str(path))
