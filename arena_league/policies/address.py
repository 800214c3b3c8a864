"""An artifact's content address: the one rule the policy layer and the artifact store share.

A single file's address is the SHA-256 of its bytes. A folder's (an arena-policy folder) is the
SHA-256 of its ``sha256sum`` listing: one line ``<sha256 of the file>  <relative POSIX path>\\n``
per file, sorted by path, so the same files give the same address wherever the folder lies, and
``sha256sum`` can check a folder by hand. Pure hashlib: the store uses it without loading torch.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable

__all__ = ["file_address", "folder_address"]


def file_address(content: bytes) -> str:
    """The address (SHA-256 hex) of one file's bytes."""
    return hashlib.sha256(content).hexdigest()


def folder_address(file_addresses: Iterable[tuple[str, str]]) -> str:
    """The address of a folder given ``(relative POSIX path, address of that file)`` for each of
    its files, in any order."""
    listing = "".join(f"{digest}  {name}\n" for name, digest in sorted(file_addresses))
    return hashlib.sha256(listing.encode()).hexdigest()
