"""Agent artifacts: reading them safely, their content address, and loading them as policies.

Arena (Song et al., AAAI 2020) ranks agents that people submit. The league accepts three kinds
of agent, and nothing that can carry code:

* ``onnx``: one ONNX file following the I/O convention (see :mod:`.onnx_policy`);
* ``arena-policy``: a folder holding ``manifest.json`` (a known family, its sizes, the game id
  and its spaces) and ``weights.safetensors`` (the family's tensors), and optionally
  ``README.md``; nothing else. Manifest example::

      {"format": "arena-policy", "format_version": 1, "family": "mlp",
       "game": "Crossroads-2T2P-v1",
       "spaces": {"obs_dim": 25, "action_type": "discrete", "n_actions": 5},
       "sizes": {"hidden": [32, 32], "activation": "tanh"},
       "name": "crossroads-imitation"}

  (``cnn`` adds ``"grid": {"channels", "height", "width", "offset"}``, ``"conv_channels"`` and
  ``"kernel_size"``; ``gru`` adds ``"gru_size"``; see :mod:`.families`.)
* ``scripted``: a built-in agent by name, ``scripted:random`` or ``scripted:heuristic``.

Pickle (any protocol), PyTorch checkpoints and TorchScript archives (zip files holding pickles
and code), ``.pt2`` exported programs and numpy ``.npy`` files are recognised from their bytes,
whatever the file is called, and refused with the format named. Sizes are checked with ``stat``
before a byte is read.

External data. ``torch.onnx.export(model, args, "model.onnx")`` (the dynamo exporter, torch's
default) writes the graph to ``model.onnx`` and every tensor over 256 bytes to ``model.onnx.data``
beside it, each tensor naming its file by ``location`` and its bytes by ``offset`` and ``length``.
Such a file is read with its data when:

* the tensors with external data are the main graph's (its initializers and its nodes' tensor
  attributes); one inside a subgraph (an ``If`` / ``Loop`` / ``Scan`` branch), a function or a
  sparse tensor is refused;
* ``location`` is a plain file name: not absolute, no directory part, no ``..``;
* that file is a regular file (not a link) in the model's own folder, and each tensor's offset
  and length lie inside it (and match the tensor's size where its type has a fixed one);
* the model and its data files together are within ``ArtifactLimits.max_onnx_bytes``, checked
  with ``stat`` before the data is read.

The data is read from the folder of the model's path as given (a link to the model is not
resolved), never from the current directory, and no file outside that folder is ever opened. It
is folded in: each such tensor takes its bytes as ``raw_data`` and drops its external-data
entries and its ``data_location`` (left unset, as an exporter writing one file leaves it), and
the model is serialized again (protobuf, deterministic). The artifact, its content address and the stored file are that one
self-contained ONNX file, so the model and its data moved together to another folder are the same
agent. With torch 2.13, a dynamo export with external data folds to the very bytes the same
export writes with ``external_data=False``: both are one agent. The TorchScript exporter
(``dynamo=False``) builds a different graph, so its file is another agent. A file without
external data is kept byte for byte as given, never re-serialized.

Limits (:class:`ArtifactLimits`, each with its default). Each is checked before the thing it
bounds is read, parsed or allocated, and a refusal is an :class:`ArtifactTooLargeError` naming the
limit, the artifact's figure and the fix:

* file sizes, with ``stat`` before a byte is read: an ONNX file with its external data
  (``max_onnx_bytes``, 256 MiB), ``weights.safetensors`` (``max_weights_bytes``, 256 MiB),
  ``manifest.json`` and a JSON agent descriptor (``max_manifest_bytes``, 64 KiB), ``README.md``
  (``max_readme_bytes``, 256 KiB);
* every JSON document an artifact carries (``manifest.json``, a scripted descriptor, the
  safetensors header): nesting depth (``max_json_depth``, 32), counted by a scan of the text
  without recursion before the document is parsed;
* the policy a manifest declares, computed from the manifest alone
  (:meth:`~arena_league.policies.architecture.Architecture.parameter_shapes` allocates nothing):
  hidden layers and convolutions (``max_layers``, 16 of each), each hidden layer's width
  (``max_width``, 4096), ``gru_size`` (``max_gru_size``, 4096), each convolution's output channels
  (``max_conv_channels``, 1024), ``kernel_size`` (``max_kernel_size``, 15), and the parameter count
  (``max_parameters``, 16,777,216: 64 MiB as float32). The largest shipped base-population member
  has 59,268 parameters (an MLP with hidden [128, 128]);
* the safetensors header's length (``max_safetensors_header_bytes``, 1 MiB), read from its first 8
  bytes.

The safetensors header is checked before ``safetensors`` loads any tensor. When the folder is
read: every tensor's ``data_offsets`` lie inside the file, span the bytes its dtype and shape
need, and tile the data without gaps or overlaps (:class:`CorruptArtifactError` otherwise). When
the agent is loaded, after the manifest's spaces are compared with the game's: the tensors' names
and shapes are the architecture's :meth:`parameter_shapes` and their dtypes floating point (F32,
F16, BF16, F64), or :class:`~arena_league.policies.errors.WeightsMismatchError`.

Content address (the registry's): :mod:`arena_league.policies.address`.
"""

from __future__ import annotations

import errno
import hashlib
import io
import json
import math
import os
import pickletools
import re
import stat
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Any

import numpy as np
import onnx
import torch
from google.protobuf.message import DecodeError
from safetensors import SafetensorError
from safetensors.torch import load as load_safetensors
from safetensors.torch import save as save_safetensors

from arena_league.policies.address import file_address, folder_address
from arena_league.policies.architecture import Architecture, architecture_from_manifest, check_parameters
from arena_league.policies.errors import (
    ArtifactError,
    ArtifactTooLargeError,
    CorruptArtifactError,
    ManifestError,
    SpaceMismatchError,
    UnsafeArtifactError,
    WeightsMismatchError,
)
from arena_league.policies.families import TorchPolicy
from arena_league.policies.onnx_policy import (
    EXTERNAL_DATA_FIX,
    ONE_FILE_EXPORT,
    OnnxPolicy,
    TensorPlace,
    external_location,
    model_tensors,
    parse_onnx,
    uses_external_data,
)
from arena_league.policies.policy import ActionSpec, Policy
from arena_league.policies.scripted import (
    SCRIPTED_FORMAT,
    SCRIPTED_NAMES,
    SCRIPTED_PREFIX,
    is_scripted_name,
    scripted_descriptor,
    scripted_policy,
)
from arena_league.policies.spaces import action_types, game_action_spec

MiB = 1 << 20
#: Artifact kinds, named as the registry's ``ArtifactFormat`` values.
ARTIFACT_KINDS: tuple[str, ...] = ("onnx", "arena-policy", "scripted")
MANIFEST_FORMAT = "arena-policy"
MANIFEST_VERSION = 1
MANIFEST_FILE = "manifest.json"
WEIGHTS_FILE = "weights.safetensors"
README_FILE = "README.md"
_MANIFEST_KEYS = frozenset({"format", "format_version", "family", "game", "spaces", "sizes", "name", "description",
                            "provenance", "license"})
_HEAD_BYTES = 512
_PACK_MAGIC = b"arena-policy-pack 1\n"
#: Bytes per element of the tensor types whose size is fixed (the rest are left to onnxruntime).
_ITEM_BYTES = {onnx.TensorProto.FLOAT: 4, onnx.TensorProto.DOUBLE: 8, onnx.TensorProto.FLOAT16: 2,
               onnx.TensorProto.BFLOAT16: 2, onnx.TensorProto.INT8: 1, onnx.TensorProto.UINT8: 1,
               onnx.TensorProto.INT16: 2, onnx.TensorProto.UINT16: 2, onnx.TensorProto.INT32: 4,
               onnx.TensorProto.UINT32: 4, onnx.TensorProto.INT64: 8, onnx.TensorProto.UINT64: 8,
               onnx.TensorProto.BOOL: 1, onnx.TensorProto.COMPLEX64: 8, onnx.TensorProto.COMPLEX128: 16}
_INLINE_FIELDS = ("raw_data", "float_data", "int32_data", "string_data", "int64_data", "double_data", "uint64_data")
#: The most one serialized protobuf message (so one ONNX file) can hold.
_PROTOBUF_MAX_BYTES = (1 << 31) - 1
_SUBMIT_INSTEAD = ("submit an ONNX file (torch.onnx.export with input 'obs' and output 'logits' or 'action') or an "
                   "arena-policy folder (manifest.json + weights.safetensors)")


#: Bytes per element of every safetensors dtype.
_SAFETENSORS_ITEM_BYTES = {"BOOL": 1, "U8": 1, "I8": 1, "F8_E5M2": 1, "F8_E4M3": 1, "I16": 2, "U16": 2, "F16": 2,
                           "BF16": 2, "I32": 4, "U32": 4, "F32": 4, "I64": 8, "U64": 8, "F64": 8}
#: The safetensors dtypes a policy's weights may have (floating point).
_WEIGHT_DTYPES = ("F32", "F16", "BF16", "F64")
#: Dimensions of one tensor in a safetensors header.
_MAX_TENSOR_RANK = 8
#: A JSON string (its closing quote optional, so an unterminated one ends the scan) or a bracket.
_JSON_TOKEN = re.compile(r'"(?:[^"\\]+|\\.)*"?|[\[\]{}]', re.DOTALL)
_LIMITS_FIX = ("Submit a smaller policy (fewer or narrower layers) or, in a league of your own, raise "
               "ArtifactLimits.{field}")


@dataclass(frozen=True)
class ArtifactLimits:
    """Limits on an artifact, each checked before what it bounds is read, parsed or allocated
    (see the module docstring): file sizes (with ``stat``), JSON nesting depth, the safetensors
    header's length, and the size of the policy a manifest declares."""

    max_onnx_bytes: int = 256 * MiB
    max_weights_bytes: int = 256 * MiB
    max_manifest_bytes: int = 64 * 1024
    max_readme_bytes: int = 256 * 1024
    #: Nesting depth of any JSON document an artifact carries.
    max_json_depth: int = 32
    #: Length of a safetensors file's JSON header.
    max_safetensors_header_bytes: int = 1 * MiB
    #: Parameters of the policy a manifest declares (1 << 24: 64 MiB as float32).
    max_parameters: int = 1 << 24
    #: Hidden layers, and separately convolutions.
    max_layers: int = 16
    #: Width of each hidden layer.
    max_width: int = 4096
    #: ``gru_size`` of a ``gru`` policy.
    max_gru_size: int = 4096
    #: Output channels of each convolution of a ``cnn`` policy.
    max_conv_channels: int = 1024
    #: ``kernel_size`` of a ``cnn`` policy.
    max_kernel_size: int = 15


DEFAULT_LIMITS = ArtifactLimits()


@dataclass(frozen=True)
class AgentArtifact:
    """An artifact's bytes, read once and checked for format (not yet for the game).

    ``files`` maps a name to its bytes: ``{"model.onnx": ...}`` for an ONNX file (its external
    data folded in, see the module docstring),
    ``{"manifest.json": ..., "weights.safetensors": ...[, "README.md": ...]}`` for an
    arena-policy folder, ``{"scripted.json": ...}`` for a scripted agent.
    """

    kind: str
    files: Mapping[str, bytes]
    source: str = "<bytes>"
    digest: str = field(init=False)

    def __post_init__(self) -> None:
        if self.kind not in ARTIFACT_KINDS:
            raise ValueError(f"unknown artifact kind {self.kind!r}; valid: {', '.join(ARTIFACT_KINDS)}")
        if self.kind == "arena-policy":
            digest = folder_address((name, file_address(data)) for name, data in self.files.items())
        else:
            digest = file_address(self.content)
        object.__setattr__(self, "digest", digest)

    @property
    def content(self) -> bytes:
        """The single file of an ``onnx`` or ``scripted`` artifact."""
        if self.kind == "arena-policy":
            raise ValueError("an arena-policy artifact is a folder of files; use .files or pack_artifact()")
        return next(iter(self.files.values()))

    @property
    def size_bytes(self) -> int:
        return sum(len(b) for b in self.files.values())

    def manifest(self, limits: ArtifactLimits = DEFAULT_LIMITS) -> dict[str, Any]:
        """The parsed and checked ``manifest.json`` of an arena-policy folder (its size, depth and
        the policy it declares within ``limits``)."""
        if self.kind != "arena-policy":
            raise ValueError(f"a {self.kind} artifact has no manifest")
        return parse_manifest(self.files[MANIFEST_FILE], self.source, limits)


# --- recognising formats ---------------------------------------------------------------------------

def refused_format(head: bytes, path: str | os.PathLike[str] | None = None) -> str | None:
    """The name of a code-carrying (or otherwise refused) format recognised from a file's first
    bytes (and, for zip archives, its entry names), or None."""
    if len(head) >= 2 and head[0] == 0x80 and 2 <= head[1] <= 5:
        return f"a Python pickle (protocol {head[1]})"
    if head.startswith(b"\x93NUMPY"):
        return "a numpy .npy file (it may hold pickled objects)"
    if head.startswith((b"PK\x03\x04", b"PK\x05\x06")):
        return _zip_format(path)
    if head.startswith((b"\x1f\x8b", b"BZh", b"\xfd7zXZ")):
        return "a compressed archive"
    if _looks_like_text_pickle(head):
        return "a Python pickle (protocol 0 or 1)"
    return None


def _looks_like_text_pickle(head: bytes) -> bool:
    """Protocols 0 and 1 have no header; a run of valid pickle opcodes (parsed, never executed)
    from the first byte gives them away. ONNX's protobuf bytes fail at once."""
    count = 0
    try:
        for opcode, _, _ in pickletools.genops(io.BytesIO(head)):
            count += 1
            if opcode.name == "STOP" or count >= 4:
                return True
    except ValueError:  # bytes that are not opcodes (UnicodeDecodeError is a ValueError too)
        return False
    return False


def _zip_format(path: str | os.PathLike[str] | None) -> str:
    names: list[str] = []
    if path is not None:
        try:
            with zipfile.ZipFile(path) as archive:  # reads the central directory only
                names = archive.namelist()
        except (zipfile.BadZipFile, OSError):
            return "a zip archive (truncated or damaged)"
    base = [n.rsplit("/", 1)[-1] for n in names]
    if "archive_format" in base or any(n.endswith(".pt2") for n in names):
        return "a PyTorch .pt2 archive (torch.export / AOTInductor package, which can carry code)"
    if any("/code/" in f"/{n}" for n in names) or "constants.pkl" in base:
        return "a TorchScript archive (torch.jit.save, which carries code)"
    if any(n.endswith(".pkl") for n in names):
        return "a PyTorch checkpoint (torch.save: a pickle inside a zip archive)"
    return "a zip archive"


def _refuse(what: str, source: str) -> ArtifactError:
    if what.startswith(("a zip archive", "a compressed archive")):
        return ArtifactError(f"{source} is {what}, not an agent format; unpack it and {_SUBMIT_INSTEAD}")
    return UnsafeArtifactError(f"{source} is {what}, which can carry code and is never loaded; {_SUBMIT_INSTEAD}")


# --- reading ---------------------------------------------------------------------------------------

def _stat_size(path: Path, limit: int, what: str) -> int:
    info = path.stat()
    if not stat.S_ISREG(info.st_mode):
        raise ArtifactError(f"{path} is not a regular file; submit the file itself")
    if info.st_size > limit:
        raise ArtifactTooLargeError(f"{path} is {info.st_size} bytes ({human_size(info.st_size)}), over the limit "
                                    f"of {human_size(limit)} for {what}; it was not read. Shrink the agent (fewer "
                                    "or smaller layers) or raise the limit (ArtifactLimits)")
    return info.st_size


def human_size(n_bytes: int) -> str:
    """``256 MiB``, ``2 GiB``, ``9.3 KiB``, ``512 bytes``."""
    for unit, size in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n_bytes >= size:
            return f"{n_bytes / size:.3g} {unit}"
    return f"{n_bytes} bytes"


# --- limits ---------------------------------------------------------------------------------------

def load_json(data: bytes, what: str, source: str, max_bytes: int, limits: ArtifactLimits = DEFAULT_LIMITS,
              invalid: type[ArtifactError] = CorruptArtifactError) -> Any:
    """Parse a JSON document an artifact carries, its size (``max_bytes``) and nesting depth
    (``limits.max_json_depth``) checked first; the depth is counted by a scan of the text, without
    recursion, so a deeply nested document never reaches the parser.

    Raises:
        ArtifactTooLargeError: over a limit (naming it).
        ``invalid``: not valid JSON (by default :class:`CorruptArtifactError`).
    """
    if len(data) > max_bytes:
        raise ArtifactTooLargeError(f"{source}: {what} is {len(data)} bytes ({human_size(len(data))}), over the limit "
                                    f"of {human_size(max_bytes)}; it was not parsed. Write it without padding or "
                                    "bulky fields")
    try:
        text = data.decode(json.detect_encoding(data))
    except (UnicodeDecodeError, LookupError) as error:
        raise invalid(f"{source}: {what} is not valid JSON text ({error}); write it as UTF-8") from None
    depth = 0
    for match in _JSON_TOKEN.finditer(text):
        bracket = text[match.start()]
        if bracket in "[{":
            depth += 1
            if depth > limits.max_json_depth:
                raise ArtifactTooLargeError(f"{source}: {what} nests arrays and objects more than "
                                            f"{limits.max_json_depth} deep (ArtifactLimits.max_json_depth); it was "
                                            "not parsed. Write it with flat fields (no deep nesting)")
        elif bracket in "]}":
            depth -= 1
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as error:
        raise invalid(f"{source}: {what} is not valid JSON ({error})") from None


def check_architecture_limits(arch: Architecture, limits: ArtifactLimits = DEFAULT_LIMITS,
                              source: str = MANIFEST_FILE) -> int:
    """Refuse a declared policy over ``limits`` (layers, widths, ``gru_size``, convolutions, the
    parameter count), computed from its shapes alone: no tensor is allocated. Returns the
    parameter count.

    Raises:
        ArtifactTooLargeError: naming the limit, the manifest's figure and the fix.
    """
    def refuse(what: str, figure: int, name: str) -> ArtifactTooLargeError:
        return ArtifactTooLargeError(f"{source}: the manifest declares {what} {figure:,}, over the limit of "
                                     f"{getattr(limits, name):,} (ArtifactLimits.{name}); nothing was allocated. "
                                     + _LIMITS_FIX.format(field=name))

    for what, figure, name in (("a number of hidden layers of", len(arch.hidden), "max_layers"),
                               ("a number of convolutions of", len(arch.conv_channels), "max_layers"),
                               ("a hidden layer of width", max(arch.hidden, default=0), "max_width"),
                               ("a gru_size of", arch.gru_size, "max_gru_size"),
                               ("a convolution with output channels", max(arch.conv_channels, default=0),
                                "max_conv_channels"),
                               ("a kernel_size of", arch.kernel_size if arch.family == "cnn" else 0,
                                "max_kernel_size")):
        if figure > getattr(limits, name):
            raise refuse(what, figure, name)
    n_parameters = arch.n_parameters()
    if n_parameters > limits.max_parameters:
        raise ArtifactTooLargeError(f"{source}: the {arch.family} policy the manifest declares has {n_parameters:,} "
                                    f"parameters ({human_size(4 * n_parameters)} as float32), over the limit of "
                                    f"{limits.max_parameters:,} (ArtifactLimits.max_parameters); nothing was "
                                    "allocated. " + _LIMITS_FIX.format(field="max_parameters"))
    return n_parameters


def weights_header(data: bytes, source: str = "<weights>", limits: ArtifactLimits = DEFAULT_LIMITS
                   ) -> dict[str, tuple[str, tuple[int, ...]]]:
    """The tensors a safetensors file lists (name -> dtype, shape), from its header alone: the
    header's length within ``limits.max_safetensors_header_bytes``, its JSON within
    ``limits.max_json_depth``, and every tensor's ``data_offsets`` inside the file, matching its
    dtype and shape and tiling the data without gaps or overlaps. No tensor is loaded.

    Raises:
        ArtifactTooLargeError: the header is over its limit.
        CorruptArtifactError: the file is truncated or its header is malformed.
    """
    where = f"{source}: {WEIGHTS_FILE}"
    fix = "save it again with safetensors.torch.save_file"
    if len(data) < 8:
        raise CorruptArtifactError(f"{where} is truncated or not a safetensors file ({len(data)} bytes, short of the "
                                   f"8 that give its header's length); {fix}")
    length = int.from_bytes(data[:8], "little")
    if length > limits.max_safetensors_header_bytes:
        raise ArtifactTooLargeError(f"{where} declares a header of {length:,} bytes, over the limit of "
                                    f"{human_size(limits.max_safetensors_header_bytes)} "
                                    "(ArtifactLimits.max_safetensors_header_bytes); it was not read. A policy's "
                                    f"header lists a few dozen tensors: {fix}")
    if 8 + length > len(data):
        raise CorruptArtifactError(f"{where} is truncated or not a safetensors file: its header claims {length:,} "
                                   f"bytes, but the file holds {len(data) - 8:,} after the length; {fix}")
    header = load_json(data[8: 8 + length], f"{WEIGHTS_FILE}'s header", source, limits.max_safetensors_header_bytes,
                       limits)
    if not isinstance(header, dict) or not isinstance(header.pop("__metadata__", {}), dict):
        raise CorruptArtifactError(f"{where} has a malformed header (not an object of tensors); {fix}")
    data_bytes = len(data) - 8 - length
    tensors: dict[str, tuple[str, tuple[int, ...]]] = {}
    spans: list[tuple[int, int, str]] = []
    for name, entry in header.items():
        if not isinstance(entry, dict) or set(entry) != {"dtype", "shape", "data_offsets"}:
            raise CorruptArtifactError(f"{where}: the header entry of tensor {name!r} is not {{dtype, shape, "
                                       f"data_offsets}}; {fix}")
        dtype, shape, offsets = entry["dtype"], entry["shape"], entry["data_offsets"]
        if dtype not in _SAFETENSORS_ITEM_BYTES:
            raise CorruptArtifactError(f"{where}: tensor {name!r} has the unknown dtype {dtype!r}; {fix}")
        if not isinstance(shape, list) or len(shape) > _MAX_TENSOR_RANK or \
                not all(type(d) is int and d >= 0 for d in shape):
            raise CorruptArtifactError(f"{where}: tensor {name!r} has the malformed shape {shape!r} (at most "
                                       f"{_MAX_TENSOR_RANK} non-negative integers); {fix}")
        if not isinstance(offsets, list) or len(offsets) != 2 or not all(type(o) is int for o in offsets) or \
                not 0 <= offsets[0] <= offsets[1]:
            raise CorruptArtifactError(f"{where}: tensor {name!r} has the malformed data_offsets {offsets!r}; {fix}")
        begin, end = offsets
        if end > data_bytes:
            raise CorruptArtifactError(f"{where} is truncated or damaged: tensor {name!r} lies at bytes {begin:,} to "
                                       f"{end:,} of its data, past the end of the file ({data_bytes:,} bytes of "
                                       f"data); {fix}")
        size = _SAFETENSORS_ITEM_BYTES[dtype] * math.prod(shape)
        if end - begin != size:
            raise CorruptArtifactError(f"{where}: tensor {name!r} is {dtype}{shape} ({size:,} bytes), but its "
                                       f"data_offsets span {end - begin:,} bytes; {fix}")
        tensors[name] = (dtype, tuple(shape))
        spans.append((begin, end, name))
    position = 0
    for begin, end, name in sorted(spans):
        if begin != position:
            raise CorruptArtifactError(f"{where}: tensor {name!r} starts at byte {begin:,} of the data, not at "
                                       f"{position:,} (a gap or an overlap); {fix}")
        position = end
    if position != data_bytes:
        raise CorruptArtifactError(f"{where} holds {data_bytes - position:,} bytes past its last tensor; {fix}")
    return tensors


def check_weights_header(data: bytes, arch: Architecture, source: str = "<weights>",
                         limits: ArtifactLimits = DEFAULT_LIMITS) -> None:
    """Compare a safetensors file's header (see :func:`weights_header`) with ``arch``: every name
    of :meth:`Architecture.parameter_shapes` present with its shape and a floating-point dtype,
    nothing extra. Nothing is loaded.

    Raises:
        WeightsMismatchError: naming the first difference and the tensors expected.
        ArtifactTooLargeError, CorruptArtifactError: as :func:`weights_header`.
    """
    listed = weights_header(data, source, limits)
    expected = arch.parameter_shapes()
    missing = [n for n in expected if n not in listed]
    extra = sorted(set(listed) - set(expected))
    described = f"the {arch.family} family with sizes {arch.sizes()} and obs_dim {arch.obs_dim}"
    if missing or extra:
        parts = ([f"missing {', '.join(missing)}"] if missing else []) + \
            ([f"unexpected {', '.join(extra[:8])}{' ...' if len(extra) > 8 else ''}"] if extra else [])
        raise WeightsMismatchError(f"{source}: {WEIGHTS_FILE} does not hold the tensors of {described} that "
                                   f"{MANIFEST_FILE} declares: {'; '.join(parts)}. Expected tensors: "
                                   + ", ".join(f"{n} {list(s)}" for n, s in expected.items()))
    for name, shape in expected.items():
        dtype, found = listed[name]
        if dtype not in _WEIGHT_DTYPES:
            raise WeightsMismatchError(f"{source}: weight {name} has dtype {dtype}; weights are floating point "
                                       f"({', '.join(_WEIGHT_DTYPES)}): save float32 tensors")
        if found != shape:
            raise WeightsMismatchError(f"{source}: weight {name} has shape {list(found)}, but {described} needs "
                                       f"{list(shape)}; save the weights of the policy {MANIFEST_FILE} declares, or "
                                       "fix its sizes")


def _read_exact(path: Path, size: int) -> bytes:
    with path.open("rb") as handle:
        data = handle.read(size + 1)
    if len(data) != size:
        raise CorruptArtifactError(f"{path} changed size while it was read ({size} bytes, then {len(data)}); "
                                   "submit it again once it is written")
    return data


def _head(path: Path) -> bytes:
    with path.open("rb") as handle:
        return handle.read(_HEAD_BYTES)


def read_artifact(source: str | os.PathLike[str], limits: ArtifactLimits = DEFAULT_LIMITS) -> AgentArtifact:
    """Read an agent artifact (ONNX file, arena-policy folder, or ``scripted:<name>``), refusing
    code-carrying formats and over-size files before their content is read.

    An ONNX file's external data (``model.onnx.data`` beside ``model.onnx``) is read from the
    file's folder and folded into the artifact, or refused, as the module docstring says.
    """
    if isinstance(source, str) and source.startswith(SCRIPTED_PREFIX):
        return AgentArtifact("scripted", {"scripted.json": scripted_descriptor(source)}, source)
    path = Path(source).expanduser()
    if not path.exists():
        hint = f"; built-in agents: {', '.join(SCRIPTED_PREFIX + n for n in SCRIPTED_NAMES)}" \
            if isinstance(source, str) and "/" not in source and "." not in source else ""
        raise ArtifactError(f"no agent file or folder at {path}{hint}")
    if path.is_dir():
        return _read_policy_folder(path, limits)
    size = _stat_size(path, limits.max_onnx_bytes, "an ONNX agent")
    head = _head(path)
    refused = refused_format(head, path)
    if refused:
        raise _refuse(refused, str(path))
    if _is_safetensors(head):
        raise ManifestError(f"{path} is a bare safetensors weights file; put it in an arena-policy folder as "
                            f"{WEIGHTS_FILE} next to a {MANIFEST_FILE} naming its family, sizes and game")
    if head.lstrip()[:1] == b"{":
        return _read_json_agent(path, size, limits)
    if size == 0:
        raise CorruptArtifactError(f"{path} is empty; submit the exported ONNX file")
    data = _fold_external_data(path, size, _read_exact(path, size), limits)
    return AgentArtifact("onnx", {"model.onnx": data}, str(path))


# --- ONNX external data ----------------------------------------------------------------------------

@dataclass(frozen=True)
class _ExternalSlice:
    """One tensor's bytes in a data file beside the model."""

    place: TensorPlace
    location: str
    offset: int
    #: None: to the end of the file.
    length: int | None


def _fold_external_data(path: Path, size: int, data: bytes, limits: ArtifactLimits) -> bytes:
    """``data`` (the bytes of the ONNX file at ``path``) with the tensors it keeps in data files
    beside it folded in; ``data`` itself when it keeps none (see the module docstring)."""
    try:
        model = onnx.load_model_from_string(data)
    except (DecodeError, ValueError, RuntimeError):
        return data  # not readable as ONNX: parse_onnx names the problem when the agent is loaded
    places = [place for place in model_tensors(model) if uses_external_data(place.tensor)]
    if not places:
        return data
    slices = [_external_slice(path, place) for place in places]
    folder = path.absolute().parent
    sizes = {name: _data_file_stat(path, folder, name).st_size for name in sorted({s.location for s in slices})}
    total = size + sum(sizes.values())
    limit = min(limits.max_onnx_bytes, _PROTOBUF_MAX_BYTES)  # the folded file is one protobuf message
    if total > limit:
        raise ArtifactTooLargeError(f"{path} and its external data ({', '.join(sizes)}) are {total} bytes together "
                                    f"({human_size(total)}), over the limit of {human_size(limit)} for an ONNX agent; "
                                    "the data was not read. Shrink the agent (fewer or smaller layers) or raise the "
                                    "limit (ArtifactLimits, at most 2 GiB: one ONNX file)")
    for piece in slices:
        _check_slice(path, piece, sizes[piece.location])
    for name, file_size in sizes.items():
        _read_slices(path, folder, name, file_size, [s for s in slices if s.location == name])
    return model.SerializeToString(deterministic=True)


def _external_slice(path: Path, place: TensorPlace) -> _ExternalSlice:
    """Where a tensor's external data lies, its entries checked (nothing is opened yet)."""
    tensor, where = place.tensor, place.where
    again = f"export the model again and {EXTERNAL_DATA_FIX}"
    if not place.main:
        raise ArtifactError(f"{path}: {where} keeps its data in an external file ({external_location(tensor)!r}) "
                            "inside a subgraph (If / Loop / Scan branch), function or sparse tensor; the league folds "
                            "external data only for the main graph's tensors. Export one self-contained file: "
                            f"{ONE_FILE_EXPORT}")
    if tensor.data_location != onnx.TensorProto.EXTERNAL:
        raise CorruptArtifactError(f"{path}: {where} has external-data entries but is not marked external; {again}")
    inline = [name for name in _INLINE_FIELDS if len(getattr(tensor, name))]
    if inline:
        raise CorruptArtifactError(f"{path}: {where} holds data both inline ({inline[0]}) and in an external file; "
                                   f"{again}")
    entries: dict[str, str] = {}
    for entry in tensor.external_data:
        if entry.key in entries and entry.key in ("location", "offset", "length"):
            raise CorruptArtifactError(f"{path}: {where} names its external data {entry.key} twice; {again}")
        entries[entry.key] = entry.value
    location = entries.get("location", "")
    if not location:
        raise CorruptArtifactError(f"{path}: {where} keeps its data externally but names no file; {again}")
    _check_location(path, where, location)
    numbers: dict[str, int | None] = {}
    for key in ("offset", "length"):
        text = entries.get(key)
        if text is not None and not (text.isascii() and text.isdigit()):
            raise CorruptArtifactError(f"{path}: {where} has external data {key} {text!r}, not a byte count; {again}")
        numbers[key] = int(text) if text is not None else None
    return _ExternalSlice(place, location, numbers["offset"] or 0, numbers["length"])


def _check_location(path: Path, where: str, location: str) -> None:
    """Refuse a ``location`` that is not a plain file name in the model's folder."""
    parts = location.replace("\\", "/").split("/")
    problem = None
    if "\x00" in location:
        problem = f"{location!r}, which holds a NUL character"
    elif (location.startswith(("/", "\\")) or PurePosixPath(location).is_absolute()
          or PureWindowsPath(location).is_absolute() or PureWindowsPath(location).drive):
        problem = f"by the absolute path {location!r}"
    elif ".." in parts:
        problem = f"{location!r}, which climbs out of the model's folder (..)"
    elif len(parts) > 1 or location == ".":
        problem = f"{location!r}, which has a directory part"
    if problem is not None:
        raise UnsafeArtifactError(f"{path}: {where} names its external data {problem}; it is never read: the data "
                                  f"file sits beside the model, named by its file name alone (such as "
                                  f"{path.name}.data); {EXTERNAL_DATA_FIX}")


def _data_file_stat(path: Path, folder: Path, name: str) -> os.stat_result:
    """``lstat`` of the data file ``name`` in ``folder``: a regular file, not a link."""
    data_path = folder / name
    try:
        info = os.lstat(data_path)
    except FileNotFoundError:
        raise ArtifactError(f"{path} keeps tensors in {name!r}, but {folder} holds no such file; "
                            f"{EXTERNAL_DATA_FIX}") from None
    except OSError as error:
        raise ArtifactError(f"{path} keeps tensors in {name!r}, which cannot be read ({error.strerror}); "
                            f"{EXTERNAL_DATA_FIX}") from None
    if stat.S_ISLNK(info.st_mode):
        raise UnsafeArtifactError(f"{path} keeps tensors in {name!r}, which is a link and is never followed; copy the "
                                  f"real file in its place beside {path.name}, or export one self-contained file: "
                                  f"{ONE_FILE_EXPORT}")
    if not stat.S_ISREG(info.st_mode):
        raise ArtifactError(f"{path} keeps tensors in {name!r}, which is not a regular file; {EXTERNAL_DATA_FIX}")
    return info


def _check_slice(path: Path, piece: _ExternalSlice, file_size: int) -> None:
    tensor, where = piece.place.tensor, piece.place.where
    end = file_size if piece.length is None else piece.offset + piece.length
    fix = f"{piece.location} is truncated or comes from another export; export the model again and {EXTERNAL_DATA_FIX}"
    if piece.offset > file_size or end > file_size:
        raise CorruptArtifactError(f"{path}: {where} reads bytes {piece.offset} to {end} of {piece.location} "
                                   f"(offset {piece.offset}, length {end - piece.offset}), but that file is "
                                   f"{file_size} bytes; {fix}")
    item = _ITEM_BYTES.get(tensor.data_type)
    if item is not None:
        expected = item * int(np.prod(tensor.dims, dtype=np.int64))
        if end - piece.offset != expected:
            kind = onnx.TensorProto.DataType.Name(tensor.data_type).lower()
            raise CorruptArtifactError(f"{path}: {where} is {kind}[{', '.join(map(str, tensor.dims))}] ({expected} "
                                       f"bytes), but its external data in {piece.location} is {end - piece.offset} "
                                       f"bytes long; {fix}")


def _read_slices(path: Path, folder: Path, name: str, file_size: int, slices: list[_ExternalSlice]) -> None:
    """Read each slice's bytes from ``folder / name`` into its tensor (opened without following a
    link, and checked to be the file that was stat'ed)."""
    flags = (os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
             | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0))
    before = _data_file_stat(path, folder, name)
    try:
        handle = os.fdopen(os.open(folder / name, flags), "rb")
    except OSError as error:
        if error.errno == errno.ELOOP:  # replaced by a link since it was stat'ed
            raise UnsafeArtifactError(f"{path} keeps tensors in {name!r}, which is a link and is never followed; "
                                      f"copy the real file in its place beside {path.name}") from None
        raise ArtifactError(f"{path} keeps tensors in {name!r}, which cannot be read ({error.strerror}); "
                            f"{EXTERNAL_DATA_FIX}") from None
    with handle:
        after = os.fstat(handle.fileno())
        if (not stat.S_ISREG(after.st_mode) or (after.st_dev, after.st_ino) != (before.st_dev, before.st_ino)
                or after.st_size != file_size):
            raise CorruptArtifactError(f"{path}: {name} changed while it was read; submit again once it is written")
        for piece in sorted(slices, key=lambda s: s.offset):
            length = (file_size - piece.offset) if piece.length is None else piece.length
            handle.seek(piece.offset)
            chunk = handle.read(length)
            if len(chunk) != length:
                raise CorruptArtifactError(f"{path}: {name} changed size while it was read; submit again once it "
                                           "is written")
            tensor = piece.place.tensor
            tensor.raw_data = chunk
            tensor.ClearField("external_data")
            tensor.ClearField("data_location")


def _is_safetensors(head: bytes) -> bool:
    if len(head) < 10:
        return False
    header_len = int.from_bytes(head[:8], "little")
    return 2 <= header_len < (100 * MiB) and head[8:9] == b"{"


def _read_json_agent(path: Path, size: int, limits: ArtifactLimits) -> AgentArtifact:
    if size > limits.max_manifest_bytes:
        raise ArtifactTooLargeError(f"{path} is a {size}-byte JSON file; agent descriptions are at most "
                                    f"{limits.max_manifest_bytes} bytes")
    data = _read_exact(path, size)
    try:
        document = load_json(data, "the JSON agent description", str(path), limits.max_manifest_bytes, limits)
    except CorruptArtifactError as error:
        raise CorruptArtifactError(f"{error}; an agent file is ONNX, or JSON naming a scripted agent") from None
    if isinstance(document, dict) and document.get("format") == SCRIPTED_FORMAT:
        name = document.get("name")
        if not is_scripted_name(name):
            raise ArtifactError(f"{path} names scripted agent {name!r}; built-in agents: {', '.join(SCRIPTED_NAMES)} "
                                "and, where the game has one, search-wW-rR-hH[-eE][-vV] within its bounds")
        return AgentArtifact("scripted", {"scripted.json": scripted_descriptor(name)}, str(path))
    if isinstance(document, dict) and "family" in document:
        raise ArtifactError(f"{path} is an arena-policy manifest; pass the folder that holds it and "
                            f"{WEIGHTS_FILE}, not the manifest alone")
    raise ArtifactError(f"{path} is a JSON file but not an agent; {_SUBMIT_INSTEAD}")


def _read_policy_folder(folder: Path, limits: ArtifactLimits) -> AgentArtifact:
    allowed = {MANIFEST_FILE: limits.max_manifest_bytes, WEIGHTS_FILE: limits.max_weights_bytes,
               README_FILE: limits.max_readme_bytes}
    sizes: dict[str, int] = {}
    with os.scandir(folder) as entries:
        for entry in entries:
            if entry.is_symlink():
                raise ArtifactError(f"{folder} holds a link ({entry.name}); copy the real file in its place")
            if entry.name not in allowed:
                kind = "folder" if entry.is_dir(follow_symlinks=False) else "file"
                raise ArtifactError(f"{folder} holds the {kind} {entry.name!r}; an arena-policy folder holds only "
                                    f"{MANIFEST_FILE}, {WEIGHTS_FILE} and optionally {README_FILE}")
            sizes[entry.name] = _stat_size(Path(entry.path), allowed[entry.name], entry.name)
    for required in (MANIFEST_FILE, WEIGHTS_FILE):
        if required not in sizes:
            if not sizes:
                raise ArtifactError(f"{folder} is an empty folder; an agent folder holds {MANIFEST_FILE} and "
                                    f"{WEIGHTS_FILE}")
            raise ManifestError(f"{folder} has no {required}; an arena-policy folder holds {MANIFEST_FILE} (family, "
                                f"sizes, game, spaces) and {WEIGHTS_FILE}")
    weights_path = folder / WEIGHTS_FILE
    refused = refused_format(_head(weights_path), weights_path)
    if refused:
        raise _refuse(refused, str(weights_path))
    files = {name: _read_exact(folder / name, size) for name, size in sorted(sizes.items())}
    artifact = AgentArtifact("arena-policy", files, str(folder))
    artifact.manifest(limits)  # checked now, so a bad folder is refused when read
    weights_header(files[WEIGHTS_FILE], str(folder), limits)
    return artifact


def parse_manifest(data: bytes, source: str = MANIFEST_FILE, limits: ArtifactLimits = DEFAULT_LIMITS
                   ) -> dict[str, Any]:
    """Parse ``manifest.json`` and check its fields (not yet against a game): its size and depth,
    and the size of the policy it declares, within ``limits`` (see the module docstring)."""
    manifest = load_json(data, MANIFEST_FILE, source, limits.max_manifest_bytes, limits, ManifestError)
    if not isinstance(manifest, dict):
        raise ManifestError(f"{source}: {MANIFEST_FILE} must be a JSON object")
    if manifest.get("format", MANIFEST_FORMAT) != MANIFEST_FORMAT or \
            manifest.get("format_version", MANIFEST_VERSION) != MANIFEST_VERSION:
        raise ManifestError(f"{source}: manifest format {manifest.get('format')!r} version "
                            f"{manifest.get('format_version')!r} is not known; use \"format\": \"{MANIFEST_FORMAT}\", "
                            f"\"format_version\": {MANIFEST_VERSION}")
    unknown = sorted(set(manifest) - _MANIFEST_KEYS)
    if unknown:
        raise ManifestError(f"{source}: unknown manifest field(s) {', '.join(map(repr, unknown))}; valid fields: "
                            f"{', '.join(sorted(_MANIFEST_KEYS))}")
    missing = [k for k in ("family", "game", "spaces", "sizes") if k not in manifest]
    if missing:
        raise ManifestError(f"{source}: the manifest lacks {', '.join(missing)}; it names the family (mlp, cnn, gru), "
                            "its sizes, the game id and the game's spaces")
    if not isinstance(manifest["game"], str):
        raise ManifestError(f"{source}: manifest 'game' must be a game id string such as 'Crossroads-2T2P-v1'")
    if not isinstance(manifest["spaces"], dict):
        raise ManifestError(f"{source}: manifest 'spaces' must be an object such as "
                            "{\"obs_dim\": 25, \"action_type\": \"discrete\", \"n_actions\": 5}")
    try:
        arch = manifest_architecture(manifest)
    except ManifestError as error:
        raise ManifestError(f"{source}: {error}") from None
    check_architecture_limits(arch, limits, source)
    return manifest


def manifest_architecture(manifest: Mapping[str, Any]) -> Architecture:
    """The :class:`Architecture` a manifest describes."""
    return architecture_from_manifest(manifest.get("family"), manifest.get("sizes"), manifest.get("spaces", {}))


def artifact_digest(source: str | os.PathLike[str], limits: ArtifactLimits = DEFAULT_LIMITS) -> str:
    """The content address (SHA-256 hex) of an artifact: of the file's bytes (an ONNX file's with
    its external data folded in), or of a folder's ``sha256sum`` listing (see the module
    docstring). Refuses what :func:`read_artifact` refuses."""
    return read_artifact(source, limits).digest


# --- writing, packing ------------------------------------------------------------------------------

def manifest_for(arch: Architecture, game_id: str, *, name: str | None = None, description: str | None = None,
                 provenance: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The manifest of an agent of ``arch`` for ``game_id``."""
    manifest: dict[str, Any] = {"format": MANIFEST_FORMAT, "format_version": MANIFEST_VERSION, "family": arch.family,
                                "game": game_id, "spaces": arch.spaces(), "sizes": arch.sizes()}
    if name is not None:
        manifest["name"] = name
    if description is not None:
        manifest["description"] = description
    if provenance is not None:
        manifest["provenance"] = dict(provenance)
    return manifest


def policy_folder_artifact(arch: Architecture, params: Mapping[str, Any], game_id: str, **manifest_fields: Any
                           ) -> AgentArtifact:
    """An arena-policy artifact in memory (canonical bytes: sorted-key JSON, safetensors)."""
    manifest = manifest_for(arch, game_id, **manifest_fields)
    files = {MANIFEST_FILE: (json.dumps(manifest, indent=2, sort_keys=True) + "\n").encode(),
             WEIGHTS_FILE: save_safetensors(check_parameters(arch, params))}
    return AgentArtifact("arena-policy", files, manifest.get("name") or "<policy>")


def save_arena_policy(folder: str | os.PathLike[str], arch: Architecture, params: Mapping[str, Any], game_id: str,
                      **manifest_fields: Any) -> Path:
    """Write an arena-policy folder (``manifest.json`` + ``weights.safetensors``); returns its path.

    ``manifest_fields``: ``name``, ``description``, ``provenance`` (a JSON object).
    """
    return write_artifact(policy_folder_artifact(arch, params, game_id, **manifest_fields), folder)


def write_artifact(artifact: AgentArtifact, dest: str | os.PathLike[str]) -> Path:
    """Restore an artifact to disk: a file for ``onnx``/``scripted``, a folder for ``arena-policy``."""
    dest = Path(dest)
    if artifact.kind == "arena-policy":
        dest.mkdir(parents=True, exist_ok=True)
        for name, data in artifact.files.items():
            (dest / name).write_bytes(data)
    else:
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_bytes(artifact.content)
    return dest


def pack_artifact(artifact: AgentArtifact) -> bytes:
    """One blob for any artifact (to send to a worker or keep in a database column): an ONNX or
    scripted artifact is its own file; a folder becomes a small container (a header line, one
    ``<name> <size> <sha256>`` line per file, a blank line, then the files' bytes)."""
    if artifact.kind != "arena-policy":
        return artifact.content
    names = sorted(artifact.files)
    header = b"".join(f"{n} {len(artifact.files[n])} {hashlib.sha256(artifact.files[n]).hexdigest()}\n".encode()
                      for n in names)
    return _PACK_MAGIC + header + b"\n" + b"".join(artifact.files[n] for n in names)


def unpack_artifact(blob: bytes, limits: ArtifactLimits = DEFAULT_LIMITS, source: str = "<packed artifact>"
                    ) -> AgentArtifact:
    """The artifact packed by :func:`pack_artifact`, with the same checks as :func:`read_artifact`."""
    if blob.startswith(_PACK_MAGIC):
        header_end = blob.find(b"\n\n", len(_PACK_MAGIC) - 1)
        if header_end < 0:
            raise CorruptArtifactError(f"{source}: packed arena-policy has no end of header (truncated)")
        lines = blob[len(_PACK_MAGIC): header_end + 1].decode("utf-8", "replace").splitlines()
        offset = header_end + 2
        files: dict[str, bytes] = {}
        limit = {MANIFEST_FILE: limits.max_manifest_bytes, WEIGHTS_FILE: limits.max_weights_bytes,
                 README_FILE: limits.max_readme_bytes}
        for line in lines:
            parts = line.split(" ")
            if len(parts) != 3 or parts[0] not in limit or not parts[1].isdigit():
                raise CorruptArtifactError(f"{source}: bad entry {line!r} in a packed arena-policy")
            name, size = parts[0], int(parts[1])
            if size > limit[name]:
                raise ArtifactTooLargeError(f"{source}: {name} is {size} bytes, over the limit of {limit[name]}")
            data = blob[offset: offset + size]
            if len(data) != size or hashlib.sha256(data).hexdigest() != parts[2]:
                raise CorruptArtifactError(f"{source}: {name} in the packed arena-policy is truncated or damaged")
            files[name] = data
            offset += size
        if offset != len(blob) or MANIFEST_FILE not in files or WEIGHTS_FILE not in files:
            raise CorruptArtifactError(f"{source}: packed arena-policy is incomplete or has trailing bytes")
        refused = refused_format(files[WEIGHTS_FILE][:_HEAD_BYTES])
        if refused:
            raise _refuse(refused, f"{source} ({WEIGHTS_FILE})")
        artifact = AgentArtifact("arena-policy", files, source)
        artifact.manifest(limits)
        weights_header(files[WEIGHTS_FILE], source, limits)
        return artifact
    if len(blob) > limits.max_onnx_bytes:
        raise ArtifactTooLargeError(f"{source} is {len(blob)} bytes, over the limit of {limits.max_onnx_bytes}")
    refused = refused_format(blob[:_HEAD_BYTES])
    if refused:
        raise _refuse(refused, source)
    if blob.lstrip()[:1] == b"{":
        try:
            document = load_json(blob, "the JSON agent description", source, limits.max_manifest_bytes, limits)
        except CorruptArtifactError:
            document = None
        if isinstance(document, dict) and document.get("format") == SCRIPTED_FORMAT and \
                is_scripted_name(document.get("name")):
            return AgentArtifact("scripted", {"scripted.json": scripted_descriptor(document["name"])}, source)
        raise ArtifactError(f"{source} is JSON but not a scripted agent descriptor")
    return AgentArtifact("onnx", {"model.onnx": bytes(blob)}, source)


# --- loading as a policy ---------------------------------------------------------------------------

@dataclass(frozen=True)
class AgentInfo:
    """What a loaded agent is, for logs, the registry and validation reports."""

    kind: str
    digest: str
    size_bytes: int
    game_id: str
    action_type: str
    obs_dim: int
    n_actions: int
    act_dim: int
    recurrent: bool
    state_shape: tuple[int, ...]
    #: ``mlp`` / ``cnn`` / ``gru`` for arena-policy folders, ``random`` / ``heuristic`` for
    #: scripted agents, None for ONNX.
    family: str | None
    #: The ONNX model's fixed batch size, None when dynamic (and for other kinds).
    fixed_batch: int | None
    name: str

    def as_dict(self) -> dict[str, Any]:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class LoadedAgent:
    policy: Policy
    artifact: AgentArtifact
    info: AgentInfo


def load_agent(source: str | os.PathLike[str] | AgentArtifact, game_id: str, *, action_type: str | None = None,
               limits: ArtifactLimits = DEFAULT_LIMITS, greedy: bool = False, intra_op_threads: int = 1,
               compute_dtype: torch.dtype = torch.float64) -> LoadedAgent:
    """Load an agent to play ``game_id``: its policy, its artifact (bytes and digest) and a summary.

    Args:
        source: an ONNX file, an arena-policy folder, ``scripted:random`` / ``scripted:heuristic``,
            or an artifact already read.
        game_id: the game it will play (unknown ids raise ``ValueError`` listing the valid ones).
        action_type: the game's action variant; by default the one the agent declares (manifest
            spaces, or an ONNX output ``logits`` / ``action``), else the game's default.
        limits: size limits.
        greedy: discrete agents play their most likely legal action instead of sampling.
        intra_op_threads: onnxruntime threads for ONNX agents.
        compute_dtype: dtype torch families compute in (float64: actions do not depend on batching).

    Raises:
        ArtifactError: a ``ValueError``; one of UnsafeArtifactError, ArtifactTooLargeError,
            CorruptArtifactError, ManifestError and SpaceMismatchError says which check refused it.
    """
    offered = action_types(game_id)  # raises for an unknown game id
    artifact = source if isinstance(source, AgentArtifact) else read_artifact(source, limits)
    label = artifact.source
    if artifact.kind == "scripted":
        name = json.loads(artifact.content)["name"]
        policy = scripted_policy(name, game_id, action_type)
        return LoadedAgent(policy, artifact, _info(artifact, game_id, policy.spec, False, (), name, None, name))
    if artifact.kind == "arena-policy":
        manifest = artifact.manifest(limits)  # the declared policy's size checked before anything is allocated
        arch = manifest_architecture(manifest)
        if manifest["game"] != game_id:
            raise SpaceMismatchError(f"{label} was made for {manifest['game']}, not {game_id}; submit it for "
                                     f"{manifest['game']} or train an agent on {game_id}")
        spec = _game_spec(game_id, action_type or arch.action_type, offered, label)
        _check_spaces(arch.spec, spec, game_id, label)
        check_weights_header(artifact.files[WEIGHTS_FILE], arch, label, limits)
        try:
            weights = load_safetensors(artifact.files[WEIGHTS_FILE])
        except (SafetensorError, ValueError, RuntimeError) as error:
            raise CorruptArtifactError(f"{label}: {WEIGHTS_FILE} is truncated or not a safetensors file ({error}); "
                                       "save it again with safetensors.torch.save_file") from None
        name = manifest.get("name") or f"{arch.family}:{artifact.digest[:12]}"
        policy = TorchPolicy(arch, weights, name=str(name), greedy=greedy, compute_dtype=compute_dtype)
        return LoadedAgent(policy, artifact, _info(artifact, game_id, spec, arch.recurrent, arch.state_shape,
                                                   arch.family, None, policy.name))
    model = parse_onnx(artifact.content, label)
    if action_type is None and len(offered) > 1:
        outputs = {v.name for v in model.graph.output}
        action_type = next((a for a, out in (("discrete", "logits"), ("continuous", "action"))
                            if out in outputs and a in offered), None)
    spec = _game_spec(game_id, action_type, offered, label)
    policy = OnnxPolicy(artifact.content, spec, game_id, digest=artifact.digest, greedy=greedy,
                        intra_op_threads=intra_op_threads, source=label, model=model)
    sig = policy.signature
    return LoadedAgent(policy, artifact, _info(artifact, game_id, spec, sig.recurrent, sig.state_shape, None,
                                               sig.batch, policy.name))


def load_policy(source: str | os.PathLike[str] | AgentArtifact, game_id: str, **kwargs: Any) -> Policy:
    """The policy of :func:`load_agent` alone."""
    return load_agent(source, game_id, **kwargs).policy


def _game_spec(game_id: str, action_type: str | None, offered: tuple[str, ...], label: str) -> ActionSpec:
    if action_type is not None and action_type not in offered:
        raise SpaceMismatchError(f"{label} plays {action_type} actions, but {game_id} offers "
                                 f"{' and '.join(offered)} actions")
    return game_action_spec(game_id, action_type)


def _check_spaces(agent: ActionSpec, game: ActionSpec, game_id: str, label: str) -> None:
    def text(spec: ActionSpec) -> str:
        out = f"n_actions {spec.n_actions}" if spec.action_type == "discrete" else f"act_dim {spec.act_dim}"
        return f"obs_dim {spec.obs_dim}, {spec.action_type} actions, {out}"

    if agent != game:
        raise SpaceMismatchError(f"{label} declares {text(agent)}, but {game_id} has {text(game)}; fix the manifest's "
                                 "spaces or train the agent for this game")


def _info(artifact: AgentArtifact, game_id: str, spec: ActionSpec, recurrent: bool, state_shape: tuple[int, ...],
          family: str | None, fixed_batch: int | None, name: str) -> AgentInfo:
    return AgentInfo(kind=artifact.kind, digest=artifact.digest, size_bytes=artifact.size_bytes, game_id=game_id,
                     action_type=spec.action_type, obs_dim=spec.obs_dim, n_actions=spec.n_actions,
                     act_dim=spec.act_dim, recurrent=recurrent, state_shape=tuple(state_shape), family=family,
                     fixed_batch=fixed_batch, name=name)
