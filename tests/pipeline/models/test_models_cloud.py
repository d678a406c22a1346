"""Cloud detector against a local fake of the DeepDataSpace v2 task API (127.0.0.1, no internet)."""

from __future__ import annotations

import base64
import json
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, Iterator

import cv2
import numpy as np
import pytest

from pipeline.models.cloud import API_KEY_ENV, URL_ENV, CloudAPIError, CloudDetector

KEY = "test-key"


class FakeAPI(ThreadingHTTPServer):
    daemon_threads = True

    def __init__(self) -> None:
        super().__init__(("127.0.0.1", 0), Handler)
        self.mode = "success"
        self.requests: list[tuple[str, str, dict[str, Any] | None]] = []
        self.polls = 0
        self.fail_first = 0

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server_address[1]}"


class Handler(BaseHTTPRequestHandler):
    server: FakeAPI

    def log_message(self, *args: Any) -> None:  # keep test output clean
        pass

    def _send(self, status: int, body: Any, headers: dict[str, str] | None = None) -> None:
        data = body if isinstance(body, bytes) else json.dumps(body).encode()
        self.send_response(status)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        for k, v in (headers or {}).items():
            self.send_header(k, v)
        self.end_headers()
        self.wfile.write(data)

    def _common(self) -> bool:
        srv, mode = self.server, self.server.mode
        if self.headers.get("Token") != KEY or mode == "401":
            self._send(401, {"code": 401, "msg": "invalid token"})
            return False
        if mode == "429":
            self._send(429, {"code": 429, "msg": "too many requests"}, {"Retry-After": "0"})
            return False
        if srv.fail_first > 0:
            srv.fail_first -= 1
            self._send(503, {"code": 503, "msg": "busy"})
            return False
        if mode == "slow":
            time.sleep(1.0)
        if mode == "malformed":
            self._send(200, b"<html>oops</html>")
            return False
        return True

    def do_POST(self) -> None:  # noqa: N802
        body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
        self.server.requests.append(("POST", self.path, body))
        if not self._common():
            return
        if self.path != "/v2/task/grounding_dino/detection":
            self._send(404, {"code": 404, "msg": "no such path"})
            return
        self._send(200, {"code": 0, "msg": "ok", "data": {"task_uuid": "task-1"}})

    def do_GET(self) -> None:  # noqa: N802
        self.server.requests.append(("GET", self.path, None))
        if not self._common():
            return
        srv = self.server
        srv.polls += 1
        if srv.mode == "never":
            self._send(200, {"code": 0, "data": {"status": "running"}})
        elif srv.mode == "failed":
            self._send(200, {"code": 0, "data": {"status": "failed", "error": "image too small"}})
        elif srv.polls < 3:
            self._send(200, {"code": 0, "data": {"status": "waiting" if srv.polls == 1 else "running"}})
        else:
            objects = [
                {"bbox": [100.0, 50.0, 300.0, 250.0], "score": 0.81, "category": "an office chair"},
                {"bbox": [10.0, 10.0, 60.0, 90.0], "score": 0.55, "category": "a desk"},
                {"bbox": [0.0, 0.0, 5.0, 5.0], "score": 0.9, "category": "something else"},
                {"bbox": [1.0, 1.0, 2.0, 2.0], "score": 0.1, "category": "a desk"},
            ]
            self._send(200, {"code": 0, "data": {"status": "success", "result": {"objects": objects}}})


@pytest.fixture()
def api() -> Iterator[FakeAPI]:
    server = FakeAPI()
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True)
    thread.start()
    yield server
    server.shutdown()
    server.server_close()


PROMPTS = [("an office chair", "office_chair"), ("a desk", "desk")]


def _client(api: FakeAPI, **kw: Any) -> CloudDetector:
    kw.setdefault("poll_interval", 0.01)
    kw.setdefault("retry_backoff", 0.01)
    return CloudDetector(KEY, api.url, **kw)


def test_success_round_trip(api: FakeAPI) -> None:
    img = np.zeros((400, 600, 3), np.uint8)
    found = _client(api).detect(img, PROMPTS)
    assert [(d.label, d.prompt) for d in found] == [("office_chair", "an office chair"), ("desk", "a desk")]
    assert found[0].box == (100.0, 50.0, 300.0, 250.0) and found[0].score == pytest.approx(0.81)
    method, path, body = api.requests[0]
    assert (method, path) == ("POST", "/v2/task/grounding_dino/detection")
    assert body is not None and body["prompt"] == {"type": "text", "text": "an office chair.a desk"}
    assert body["model"] == "GroundingDino-1.5-Pro" and body["targets"] == ["bbox"]
    assert body["image"].startswith("data:image/jpeg;base64,")
    decoded = cv2.imdecode(np.frombuffer(base64.b64decode(body["image"].split(",", 1)[1]), np.uint8), cv2.IMREAD_COLOR)
    assert decoded.shape == (400, 600, 3)
    assert [r[1] for r in api.requests[1:]] == ["/v2/task_status/task-1"] * 3


def test_large_images_are_downscaled_and_boxes_scaled_back(api: FakeAPI) -> None:
    found = _client(api, max_side=300).detect(np.zeros((400, 600, 3), np.uint8), PROMPTS)
    body = api.requests[0][2]
    assert body is not None
    img = cv2.imdecode(np.frombuffer(base64.b64decode(body["image"].split(",", 1)[1]), np.uint8), cv2.IMREAD_COLOR)
    assert img.shape[:2] == (200, 300)
    assert found[0].box == (200.0, 100.0, 600.0, 400.0)  # (100, 50, 300, 250) / 0.5, clipped


def test_missing_key_names_the_variable(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(API_KEY_ENV, raising=False)
    with pytest.raises(CloudAPIError, match=API_KEY_ENV):
        CloudDetector()
    monkeypatch.setenv(API_KEY_ENV, "k")
    monkeypatch.setenv(URL_ENV, "ftp://x")
    with pytest.raises(CloudAPIError, match=URL_ENV):
        CloudDetector()


def test_401_is_a_key_problem(api: FakeAPI) -> None:
    api.mode = "401"
    with pytest.raises(CloudAPIError, match=f"rejected the API key.*{API_KEY_ENV}") as err:
        _client(api).detect(np.zeros((20, 20, 3), np.uint8), PROMPTS)
    assert err.value.status == 401


def test_429_is_retried_then_reported(api: FakeAPI) -> None:
    api.mode = "429"
    with pytest.raises(CloudAPIError, match=r"rate limit reached \(HTTP 429\).*3 attempt") as err:
        _client(api, max_retries=2).detect(np.zeros((20, 20, 3), np.uint8), PROMPTS)
    assert err.value.status == 429 and len(api.requests) == 3


def test_5xx_is_retried(api: FakeAPI) -> None:
    api.fail_first = 2
    assert len(_client(api, max_retries=2).detect(np.zeros((400, 600, 3), np.uint8), PROMPTS)) == 2
    api.fail_first, api.polls = 5, 0
    with pytest.raises(CloudAPIError, match=r"server error \(HTTP 503\)"):
        _client(api, max_retries=1).detect(np.zeros((20, 20, 3), np.uint8), PROMPTS)


def test_slow_server_times_out(api: FakeAPI) -> None:
    api.mode = "slow"
    t0 = time.perf_counter()
    with pytest.raises(CloudAPIError, match=r"did not answer within 0.2 s"):
        _client(api, request_timeout=0.2).detect(np.zeros((20, 20, 3), np.uint8), PROMPTS)
    assert time.perf_counter() - t0 < 1.0


def test_task_that_never_finishes_is_bounded(api: FakeAPI) -> None:
    api.mode = "never"
    with pytest.raises(CloudAPIError, match=r"did not finish within 0.3 s \(last status: running\)"):
        _client(api, total_timeout=0.3, poll_interval=0.05).detect(np.zeros((20, 20, 3), np.uint8), PROMPTS)


def test_malformed_json_and_failed_task(api: FakeAPI) -> None:
    api.mode = "malformed"
    with pytest.raises(CloudAPIError, match="malformed JSON.*oops"):
        _client(api).detect(np.zeros((20, 20, 3), np.uint8), PROMPTS)
    api.mode = "failed"
    with pytest.raises(CloudAPIError, match="task task-1 failed: image too small"):
        _client(api).detect(np.zeros((20, 20, 3), np.uint8), PROMPTS)


def test_unreachable_server() -> None:
    client = CloudDetector(KEY, "http://127.0.0.1:9", max_retries=0, request_timeout=1.0)
    with pytest.raises(CloudAPIError, match="cannot reach the cloud API"):
        client.detect(np.zeros((20, 20, 3), np.uint8), PROMPTS)
