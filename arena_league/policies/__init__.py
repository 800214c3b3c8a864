"""The policy layer: agents as batched policies, their artifacts, and submission validation.

After Arena (Song et al., AAAI 2020), which ranks new agents against a base population per game:

* :mod:`.policy`: the batched :class:`Policy` contract the match engine calls;
* :mod:`.families`: MLP, CNN and GRU families as torch modules; populations of one family stacked
  into one tensor bundle (:class:`StackedPolicy`); :func:`stack_policies` for the engine;
* :mod:`.onnx_export` / :mod:`.onnx_policy`: ONNX agents out and in (input ``obs``, output ``logits`` or ``action``);
* :mod:`.scripted`: built-in ``scripted:random`` and ``scripted:heuristic`` for every game;
* :mod:`.artifacts`: reading artifacts safely (no pickle, TorchScript or .pt2), content
  addresses, arena-policy folders, :func:`load_agent`;
* :mod:`.validation`: :func:`validate_submission`, ending in a match against copies of itself.
"""

from arena_league.policies.artifacts import (
    ARTIFACT_KINDS,
    DEFAULT_LIMITS,
    AgentArtifact,
    AgentInfo,
    ArtifactLimits,
    LoadedAgent,
    artifact_digest,
    load_agent,
    load_policy,
    manifest_for,
    pack_artifact,
    policy_folder_artifact,
    read_artifact,
    refused_format,
    save_arena_policy,
    unpack_artifact,
    write_artifact,
)
from arena_league.policies.errors import (
    ArtifactError,
    ArtifactTooLargeError,
    CorruptArtifactError,
    ManifestError,
    SpaceMismatchError,
    UnsafeArtifactError,
)
from arena_league.policies.families import (
    FAMILIES,
    Architecture,
    FamilyNet,
    GridLayout,
    PolicyGroup,
    StackedFamily,
    StackedPolicy,
    TorchPolicy,
    build_module,
    init_parameters,
    stack_policies,
)
from arena_league.policies.onnx_export import export_onnx
from arena_league.policies.onnx_policy import OnnxPolicy, PolicyOutputError
from arena_league.policies.policy import ActionSpec, Policy, sample_from_logits
from arena_league.policies.scripted import SCRIPTED_NAMES, scripted_descriptor, scripted_policy
from arena_league.policies.spaces import game_action_spec
from arena_league.policies.validation import ValidationResult, validate_submission

__all__ = [
    "ARTIFACT_KINDS", "DEFAULT_LIMITS", "FAMILIES", "SCRIPTED_NAMES",
    "ActionSpec", "AgentArtifact", "AgentInfo", "Architecture", "ArtifactError", "ArtifactLimits",
    "ArtifactTooLargeError", "CorruptArtifactError", "FamilyNet", "GridLayout", "LoadedAgent", "ManifestError",
    "OnnxPolicy", "Policy", "PolicyGroup", "PolicyOutputError", "SpaceMismatchError", "StackedFamily",
    "StackedPolicy", "TorchPolicy", "UnsafeArtifactError", "ValidationResult",
    "artifact_digest", "build_module", "export_onnx", "game_action_spec", "init_parameters", "load_agent",
    "load_policy", "manifest_for", "pack_artifact", "policy_folder_artifact", "read_artifact", "refused_format",
    "sample_from_logits", "save_arena_policy", "scripted_descriptor", "scripted_policy", "stack_policies",
    "unpack_artifact", "validate_submission", "write_artifact",
]
