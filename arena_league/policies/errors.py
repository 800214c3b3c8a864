"""Why an agent artifact was refused.

Arena (Song et al., AAAI 2020) ranks agents that people submit; the league only accepts
artifacts that carry weights and a fixed graph, never code. Every refusal is one of these
exceptions, raised where the cause is known, with the fix in the message. All are ``ValueError``s
so a caller that only wants "was the input bad?" can catch that.
"""

from __future__ import annotations


class ArtifactError(ValueError):
    """An agent artifact cannot be used (base class of every refusal below)."""


class UnsafeArtifactError(ArtifactError):
    """The file is a format that can carry code (pickle, TorchScript, .pt2), or an ONNX model names
    external data outside its own folder (an absolute path, a directory part, ``..``, a link): it
    is never loaded, and the file it names is never read."""


class ArtifactTooLargeError(ArtifactError):
    """The artifact is over one of the limits of ``ArtifactLimits``: a file's size (checked with
    ``stat`` before it is read), a JSON document's nesting depth, a safetensors header's length, or
    the size of the policy a manifest declares (checked before any tensor is allocated)."""


class CorruptArtifactError(ArtifactError):
    """The file is truncated, corrupt, or not the format it claims to be."""


class ManifestError(ArtifactError):
    """An ``arena-policy`` folder's manifest or weights do not describe a known policy family."""


class SpaceMismatchError(ArtifactError):
    """The agent's inputs or outputs do not match the game's observation and action spaces."""


class WeightsMismatchError(ManifestError, CorruptArtifactError):
    """An ``arena-policy`` folder's ``weights.safetensors`` header does not list the tensors its
    ``manifest.json`` describes (a name, dtype or shape differs): the two files contradict each
    other, so the artifact is refused as unreadable, before any tensor is loaded."""


def artifact_error_class(name: str | None, base: type[ArtifactError] = ArtifactError) -> type[ArtifactError] | None:
    """The artifact error class named ``name`` (as a validation verdict or the sandbox reports it)
    when it is ``base`` or one of its kinds; None otherwise."""
    found = globals().get(name or "")
    return found if isinstance(found, type) and issubclass(found, base) else None
