"""Loading a frozen population: its stacked bundles and any member's policy."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch
from safetensors.torch import load_file

from arena_league.policies.architecture import Architecture
from arena_league.policies.artifacts import manifest_architecture
from arena_league.policies.families import StackedPolicy

__all__ = ["bundle_weights", "load_bundles", "member_policy"]


def member_policy(folder: str | Path, entry: Mapping[str, Any], game_id: str) -> Any:
    """The policy of one member (an entry of ``population.json``): its artifact, or the built-in
    agent it names."""
    from arena_league.policies import load_policy
    from arena_league.policies.scripted import scripted_policy

    if entry.get("kind") == "scripted":
        return scripted_policy(entry["agent_metadata"]["scripted"], game_id)
    return load_policy(Path(folder) / entry["artifact"], game_id)


def load_bundles(folder: str | Path, *, compute_dtype: torch.dtype = torch.float64) -> list[StackedPolicy]:
    """The stacked bundles of a frozen population folder, as :class:`StackedPolicy` objects whose
    ``member_names`` are the members' agent names (one batched forward for a whole family)."""
    return [StackedPolicy(arch, params, names=members, compute_dtype=compute_dtype)
            for arch, members, params in bundle_weights(Path(folder))]


def bundle_weights(folder: Path) -> list[tuple[Architecture, list[str], list[dict[str, torch.Tensor]]]]:
    """Each stacked bundle of a frozen population: its architecture, member names and their weights."""
    manifest = json.loads((folder / "population.json").read_text())
    found = []
    for bundle in manifest.get("bundles", []):
        tensors = load_file(str(folder / bundle["file"]))
        arch = manifest_architecture({"family": bundle["family"], "sizes": bundle["sizes"],
                                      "spaces": bundle["spaces"]})
        members = bundle["members"]
        for param, shape in arch.parameter_shapes().items():
            if param not in tensors or tuple(tensors[param].shape) != (len(members), *shape):
                raise ValueError(f"{folder / bundle['file']}: tensor {param} is missing or not [{len(members)}, "
                                 f"{', '.join(map(str, shape))}]; the bundle does not match population.json")
        found.append((arch, members, [{p: tensors[p][i] for p in arch.parameter_shapes()} for i in range(len(members))]))
    return found
