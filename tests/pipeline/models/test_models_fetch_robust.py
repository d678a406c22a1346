"""``morphonavi models fetch / list / verify`` robustness: read-only folders, the console line of a
recorded checksum, concurrent fetches, a modified converted file, the real size in ``models list`` and
the hint of a broken second detector. Never downloads: the fake npm tarball of ``tests/pipeline/models/test_ssd_fetch.py``
on a 127.0.0.1 server."""

from __future__ import annotations

import json
import os
import pickle
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from pipeline.models import cli_support, registry, ssd_convert
from pipeline.models.base import ModelError
from pipeline.models.fetch import fetch
from pipeline.models.fetch_lock import LOCK_FILE, FetchLock
from pipeline.models.registry import CHECKSUMS_FILE, list_models, verify
from tests.pipeline.models import test_ssd_fetch as ssd_tests
from tests.pipeline.models.test_ssd_fetch import fake, fake_spec, run, server, sha  # noqa: F401 - fixtures

ROOT = Path(__file__).resolve().parents[3]
WAIT = 120.0  # generous: a loaded 2-core machine


def wait_for(condition: Callable[[], bool], what: str, timeout: float = WAIT) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.01)


@pytest.fixture()
def probe(fake: dict, monkeypatch: pytest.MonkeyPatch) -> dict:
    """The probe statistics of the fake reference conversion (so the outputs check can pass)."""
    boxes, scores = run(Path(fake["reference"]), ssd_convert.probe_input())
    stats = ssd_convert.probe_stats(boxes, scores)
    monkeypatch.setattr(ssd_tests, "PROBE", stats)
    return stats


def nudge_weights(path: Path) -> None:
    """Change one float of the largest initializer by one part in a million: other bytes, nearly the same
    outputs (what a flipped low bit does, and what the probe alone cannot tell from another toolchain)."""
    import onnx
    from onnx import numpy_helper

    model = onnx.load(str(path))
    init = max(model.graph.initializer, key=lambda t: len(t.raw_data))
    values = numpy_helper.to_array(init).copy()
    values.flat[0] = values.flat[0] * np.float32(1 + 1e-6) + np.float32(1e-7)
    init.CopyFrom(numpy_helper.from_array(values, init.name))
    onnx.save(model, str(path))


# -- 1. read-only folders ------------------------------------------------------------------------------

READ_ONLY_CLI = """
import pickle, sys
from pipeline.models import cli_support, registry
import tests.pipeline.models.test_ssd_fetch as t
spec, probe = pickle.loads(bytes.fromhex(sys.argv[1]))
t.PROBE = probe
registry.CONVERTERS["raw_onnx"] = ("tests.pipeline.models.test_ssd_fetch", "convert_raw", "check_raw")
registry.MODELS["oidv4_ssd"] = spec
sys.exit(cli_support.models_fetch(["oidv4_ssd"], sys.argv[2], progress=False))
"""


def fetch_read_only(spec: object, probe: dict, models: Path) -> subprocess.CompletedProcess:
    """``models fetch oidv4_ssd --dir models`` (the CLI's function, in a child process) with ``models/oidv4_ssd``
    read-only: chmod for a normal user; for root (whom chmod does not stop) a read-only bind mount in a
    private mount namespace, skipped where that is not permitted."""
    folder = models / "oidv4_ssd"
    args = [sys.executable, "-c", READ_ONLY_CLI, pickle.dumps((spec, probe)).hex(), str(models)]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    if os.geteuid() != 0:
        folder.chmod(0o555)
        try:
            return subprocess.run(args, capture_output=True, text=True, env=env, cwd=ROOT, timeout=600)
        finally:
            folder.chmod(0o755)
    if shutil.which("unshare") is None:
        pytest.skip("running as root (chmod does not stop root) and no unshare for a read-only bind mount")
    script = 'mount --bind "$1" "$1" && mount -o remount,bind,ro "$1" && shift && exec "$@"'
    proc = subprocess.run(["unshare", "-m", "sh", "-c", script, "sh", str(folder), *args], capture_output=True,
                          text=True, env=env, cwd=ROOT, timeout=600)
    if "mount:" in proc.stderr or "unshare:" in proc.stderr:
        pytest.skip(f"running as root and a read-only bind mount is not permitted here: {proc.stderr.strip()}")
    return proc


def test_read_only_folder_with_a_good_copy_is_ok(fake: dict, probe: dict, tmp_path: Path) -> None:
    """A present copy without a record (e.g. the shared folder) in a read-only folder: ok, the checksum
    is not recorded (said so), exit 0, no traceback."""
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], "a" * 64)  # bytes not the pinned ones
    fetch(spec, tmp_path / "models", progress=False, log=lambda m: None)
    folder = tmp_path / "models" / "oidv4_ssd"
    (folder / CHECKSUMS_FILE).unlink()  # a copy made elsewhere: no record yet
    proc = fetch_read_only(spec, probe, tmp_path / "models")
    assert "Traceback" not in proc.stderr, proc.stderr
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert f"could not record sha256 {fake['onnx_sha']} in {folder / CHECKSUMS_FILE}" in proc.stdout
    assert f"oidv4_ssd: 2 file(s) ready in {tmp_path / 'models' / 'oidv4_ssd'}" in proc.stdout
    assert sorted(p.name for p in folder.iterdir()) == ["labelmap.txt", "oidv4_ssd.onnx"]


def test_read_only_folder_with_a_broken_copy_is_one_clear_error(fake: dict, probe: dict, tmp_path: Path) -> None:
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"])
    fetch(spec, tmp_path / "models", progress=False, log=lambda m: None)
    folder = tmp_path / "models" / "oidv4_ssd"
    (folder / "oidv4_ssd.onnx").write_bytes(b"not a model")
    proc = fetch_read_only(spec, probe, tmp_path / "models")
    assert "Traceback" not in proc.stderr, proc.stderr
    assert proc.returncode == 1
    errors = [line for line in proc.stdout.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, proc.stdout
    assert errors[0].startswith(f"error: oidv4_ssd: cannot write to {folder} (")
    assert "--dir DIR" in errors[0] and "$MORPHONAVI_MODELS" in errors[0]
    assert (folder / "oidv4_ssd.onnx").read_bytes() == b"not a model"


# -- 2. recording a checksum is said on the console ------------------------------------------------------


def test_recording_a_checksum_names_the_file(fake: dict, probe: dict, tmp_path: Path) -> None:
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], "a" * 64)
    fetch(spec, tmp_path, progress=False, log=lambda m: None)
    folder = tmp_path / "oidv4_ssd"
    (folder / CHECKSUMS_FILE).unlink()
    messages: list[str] = []
    model, _ = fetch(spec, tmp_path, progress=False, log=messages.append)
    assert (model.downloaded, model.checksum) == (False, "outputs match reference")
    line = f"oidv4_ssd/oidv4_ssd.onnx: recorded sha256 {fake['onnx_sha']} in {folder / CHECKSUMS_FILE} (present " \
           "without a record (first use)"
    assert any(m.startswith(line) for m in messages), messages
    record = json.loads((folder / CHECKSUMS_FILE).read_text())["oidv4_ssd.onnx"]
    assert record["sha256"] == fake["onnx_sha"] and "first use" in record["origin"]


# -- 3. concurrent fetches -----------------------------------------------------------------------------


def test_a_second_fetch_waits_for_the_first(fake: dict, server: object, tmp_path: Path) -> None:
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"])
    folder = tmp_path / "oidv4_ssd"
    folder.mkdir()
    messages: list[str] = []
    outcome: list[object] = []

    def second() -> None:
        try:
            outcome.append(fetch(spec, tmp_path, progress=False, log=messages.append))
        except BaseException as exc:  # noqa: BLE001 - reported by the assertion below
            outcome.append(exc)

    with FetchLock(folder, "oidv4_ssd", lambda m: None) as held:  # a first fetch in progress
        assert held.held and (folder / LOCK_FILE).read_text().strip() == str(os.getpid())
        thread = threading.Thread(target=second, daemon=True)
        thread.start()
        wait_for(lambda: any(m.startswith("waiting for another fetch of oidv4_ssd") for m in messages), "the wait")
        assert f"waiting for another fetch of oidv4_ssd (pid {os.getpid()}) into {folder}" in messages
        assert server.log == [] and not outcome  # nothing downloaded while waiting
    thread.join(WAIT)
    assert not thread.is_alive()
    (files,) = outcome
    assert not isinstance(files, BaseException), files
    assert [f.checksum for f in files] == ["published", "published"]
    assert sorted(p.name for p in folder.iterdir()) == [CHECKSUMS_FILE, "labelmap.txt", "oidv4_ssd.onnx"]


def test_two_concurrent_fetches_both_succeed_with_one_download(fake: dict, server: object, tmp_path: Path) -> None:
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"])
    outcomes: list[object] = []
    start = threading.Barrier(2)

    def one() -> None:
        start.wait(WAIT)
        try:
            outcomes.append(fetch(spec, tmp_path, progress=False, log=lambda m: None))
        except BaseException as exc:  # noqa: BLE001
            outcomes.append(exc)

    threads = [threading.Thread(target=one, daemon=True) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(WAIT)
    assert len(outcomes) == 2 and not [o for o in outcomes if isinstance(o, BaseException)], outcomes
    assert sorted(tuple(f.downloaded for f in o) for o in outcomes) == [(False, False), (True, True)]
    assert len(server.log) == 1
    assert (tmp_path / "oidv4_ssd" / "oidv4_ssd.onnx").read_bytes() == Path(fake["reference"]).read_bytes()
    assert not (tmp_path / "oidv4_ssd" / LOCK_FILE).exists()


# -- 4. a converted file modified after it was fetched ----------------------------------------------------


def test_modified_converted_file_is_caught_and_made_again(fake: dict, probe: dict, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"])
    monkeypatch.setitem(registry.MODELS, "oidv4_ssd", spec)
    fetch(spec, tmp_path, progress=False, log=lambda m: None)
    path = tmp_path / "oidv4_ssd" / "oidv4_ssd.onnx"
    nudge_weights(path)
    modified = sha(path.read_bytes())
    assert modified != fake["onnx_sha"]
    assert ssd_convert.check_outputs(path, probe) < 1e-3  # the probe alone would accept it
    (result,) = verify(tmp_path, ["oidv4_ssd"])
    assert not result.ok
    assert any(f"oidv4_ssd.onnx: modified since it was fetched (sha256 {modified}, recorded {fake['onnx_sha']}" in m
               for m in result.messages), result.messages
    messages: list[str] = []
    model, _ = fetch(spec, tmp_path, progress=False, log=messages.append)
    assert model.downloaded and model.checksum == "published" and sha(path.read_bytes()) == fake["onnx_sha"]
    assert registry.recorded_checksums(path.parent) == {"oidv4_ssd.onnx": fake["onnx_sha"]}  # not the modified one
    assert any("modified since it was fetched" in m for m in messages)
    assert verify(tmp_path, ["oidv4_ssd"])[0].ok


def test_a_copy_without_a_record_is_checked_by_its_outputs_once(fake: dict, probe: dict, tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """First use: the probe decides and fetch records the bytes; a later change is then "modified"."""
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"])
    monkeypatch.setitem(registry.MODELS, "oidv4_ssd", spec)
    fetch(spec, tmp_path, progress=False, log=lambda m: None)
    folder = tmp_path / "oidv4_ssd"
    (folder / CHECKSUMS_FILE).unlink()
    nudge_weights(folder / "oidv4_ssd.onnx")
    first_use = sha((folder / "oidv4_ssd.onnx").read_bytes())
    (result,) = verify(tmp_path, ["oidv4_ssd"])
    assert result.ok and any("no recorded sha256 (first use)" in m for m in result.messages), result.messages
    model, _ = fetch(spec, tmp_path, progress=False, log=lambda m: None)
    assert (model.downloaded, model.checksum) == (False, "outputs match reference")
    assert registry.recorded_checksums(folder) == {"oidv4_ssd.onnx": first_use}
    nudge_weights(folder / "oidv4_ssd.onnx")
    assert not verify(tmp_path, ["oidv4_ssd"])[0].ok


# -- 5. models list shows the size on disk ----------------------------------------------------------------


def test_list_shows_the_size_on_disk_and_flags_a_mismatch(fake: dict, tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    size = Path(fake["reference"]).stat().st_size
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"], size=size)
    monkeypatch.setitem(registry.MODELS, "oidv4_ssd", spec)
    fetch(spec, tmp_path, progress=False, log=lambda m: None)

    def row() -> registry.ModelStatus:
        return next(r for r in list_models(tmp_path) if r.name == "oidv4_ssd")

    labels = len(ssd_tests.LABELS)
    assert (row().status, row().size, row().size_issue) == ("present", size + labels, "")
    path = tmp_path / "oidv4_ssd" / "oidv4_ssd.onnx"
    path.write_bytes(path.read_bytes()[:1000])  # a truncated copy
    status = row()
    assert status.size == 1000 + labels
    assert status.size_issue == f"oidv4_ssd.onnx has 1000 bytes, expected {size}"
    printed = status.as_row()
    assert printed["size"] == f"{1000 + labels} B (size differs!)"
    assert f"oidv4_ssd.onnx has 1000 bytes, expected {size}; run: morphonavi models verify oidv4_ssd" in printed["where"]
    assert "size differs!" in cli_support.models_list(tmp_path)


@pytest.mark.skipif(not (ssd_tests.SHARED_SSD / "oidv4_ssd.onnx").is_file(), reason="../shared/models/oidv4_ssd absent")
def test_list_does_not_flag_the_shared_conversion() -> None:
    """Another toolchain's conversion is a few hundred bytes off the reference's: within tolerance."""
    (status,) = [r for r in list_models(ssd_tests.SHARED_SSD.parent) if r.name == "oidv4_ssd"]
    on_disk = sum(p.stat().st_size for p in (ssd_tests.SHARED_SSD / "oidv4_ssd.onnx",
                                            ssd_tests.SHARED_SSD / "labelmap.txt"))
    assert status.status == "present" and status.size == on_disk and status.size_issue == ""


# -- 6. a broken second detector names the way out ----------------------------------------------------------


def test_broken_second_detector_names_refetch_and_the_set_without_it(fake: dict, tmp_path: Path) -> None:
    from pipeline.catalog import default_catalog
    from pipeline.mapper_config import _with_second_detector

    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"])
    fetch(spec, tmp_path, progress=False, log=lambda m: None)
    (tmp_path / "oidv4_ssd" / "oidv4_ssd.onnx").write_bytes(b"not a model")
    with pytest.raises(ModelError) as err:
        _with_second_detector(object(), "oidv4_ssd", tmp_path, default_catalog(), "offline")
    text = str(err.value)
    assert "cannot load the ONNX file" in text
    assert "re-fetch it with: morphonavi models fetch oidv4_ssd" in text
    assert text.endswith("or run without it: --models offline-oidv4_ssd")
