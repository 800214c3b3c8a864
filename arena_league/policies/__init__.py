"""The policy layer: agents as batched policies, their artifacts, and submission validation.

After Arena (Song et al., AAAI 2020), which ranks new agents against a base population per game:

* :mod:`.policy`: the batched :class:`Policy` contract the match engine calls;
* :mod:`.architecture`: a policy's family, sizes and spaces, checked; seeded parameters;
* :mod:`.families`: MLP, CNN and GRU families as torch modules; populations of one family stacked
  into one tensor bundle (:class:`StackedPolicy`); :func:`stack_policies` for the engine;
* :mod:`.onnx_export` / :mod:`.onnx_policy`: ONNX agents out and in (input ``obs``, output
  ``logits`` or ``action``);
* :mod:`.scripted`: built-in ``scripted:random`` and ``scripted:heuristic`` for every game;
* :mod:`.artifacts`: reading artifacts safely (no pickle, TorchScript or .pt2), content
  addresses, arena-policy folders, :func:`load_agent`;
* :mod:`.validation`: :func:`validate_submission`, ending in a match against copies of itself;
* :mod:`.sandbox`: the inference sandbox, a child process with memory and time budgets in which
  submitted agents are validated and play;
* :mod:`.threads`: :func:`torch_threads`, torch's thread count for a block, restored after it.

The names below load their module on first use, so that a part of the league that needs only a
light module (the artifact store needs :mod:`.address`) does not load torch and onnxruntime.
"""

from __future__ import annotations

from arena_league import lazy_exports

#: Submodule -> the names this package offers from it.
_EXPORTS: dict[str, tuple[str, ...]] = {
    "address": ("file_address", "folder_address"),
    "architecture": ("FAMILIES", "Architecture", "GridLayout", "init_parameters"),
    "artifacts": (
        "ARTIFACT_KINDS", "DEFAULT_LIMITS", "AgentArtifact", "AgentInfo", "ArtifactLimits", "LoadedAgent",
        "artifact_digest", "load_agent", "load_policy", "manifest_for", "pack_artifact",
        "policy_folder_artifact", "read_artifact", "refused_format", "save_arena_policy", "unpack_artifact",
        "write_artifact",
    ),
    "errors": (
        "ArtifactError", "ArtifactTooLargeError", "CorruptArtifactError", "ManifestError",
        "SpaceMismatchError", "UnsafeArtifactError",
    ),
    "families": (
        "FamilyNet", "PolicyGroup", "StackedFamily", "StackedPolicy", "TorchPolicy", "build_module",
        "stack_policies",
    ),
    "onnx_export": ("export_onnx",),
    "onnx_policy": ("OnnxPolicy", "PolicyOutputError"),
    "policy": ("ActionSpec", "Policy", "sample_from_logits"),
    "sandbox": ("AgentSource", "ForfeitError", "InferenceSandbox", "SandboxLimits", "SandboxedPolicy", "largest_batch"),
    "scripted": ("SCRIPTED_NAMES", "scripted_descriptor", "scripted_policy"),
    "spaces": ("game_action_spec",),
    "threads": ("torch_threads",),
    "validation": ("ValidationResult", "validate_submission"),
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
