"""Cloud open-vocabulary detector: Grounding DINO 1.5 Pro / DINO-X through the DeepDataSpace v2 API.

Protocol (asynchronous task):

1. ``POST {base}/v2/task/grounding_dino/detection`` (``.../dinox/detection`` for DINO-X models) with
   header ``Token: <key>`` and JSON ``{"model", "image": "data:image/jpeg;base64,...",
   "prompt": {"type": "text", "text": "a desk.an office chair"}, "targets": ["bbox"],
   "bbox_threshold", "iou_threshold"}`` -> ``{"code": 0, "data": {"task_uuid": ...}}``;
2. ``GET {base}/v2/task_status/{task_uuid}`` until ``data.status`` is ``success`` (or ``failed``)
   -> ``data.result.objects = [{"bbox": [x1, y1, x2, y2], "score", "category"}, ...]``.

The API key comes from ``MORPHONAVI_CLOUD_API_KEY``, the base URL from ``MORPHONAVI_CLOUD_URL``
(default ``https://api.deepdataspace.com``). Only the standard library is used. Every failure
(missing key, HTTP 401/403/429/5xx, timeouts, malformed JSON, a failed task) raises
:class:`CloudAPIError` with a message saying what happened and what to do.
"""

from __future__ import annotations

import base64
import http.client
import json
import os
import re
import socket
import time
import urllib.error
import urllib.request
from typing import Any, Callable, Sequence

import cv2
import numpy as np

from pipeline.models.base import Detection, ModelError, Prompt, check_image, check_prompts

API_KEY_ENV = "MORPHONAVI_CLOUD_API_KEY"
URL_ENV = "MORPHONAVI_CLOUD_URL"
DEFAULT_URL = "https://api.deepdataspace.com"
DEFAULT_MODEL = "GroundingDino-1.5-Pro"


class CloudAPIError(ModelError):
    """The cloud detector failed; ``status`` is the HTTP status when there was one."""

    def __init__(self, message: str, status: int | None = None) -> None:
        super().__init__(message)
        self.status = status


def api_path_for(model: str) -> str:
    """Task endpoint of a model name: DINO-X models use ``dinox``, the rest ``grounding_dino``."""
    return "/v2/task/dinox/detection" if model.lower().startswith("dino-x") else "/v2/task/grounding_dino/detection"


def _prompt_key(text: str) -> str:
    return " ".join(re.sub(r"[^a-z0-9]+", " ", text.lower()).split())


class CloudDetector:
    """Open-vocabulary detector served by the DeepDataSpace API.

    Args:
        api_key: API token; default ``$MORPHONAVI_CLOUD_API_KEY``.
        base_url: API root; default ``$MORPHONAVI_CLOUD_URL`` or ``https://api.deepdataspace.com``.
        model: ``"GroundingDino-1.5-Pro"``, ``"DINO-X-1.0"``, ...
        score_threshold: ``bbox_threshold`` sent to the API and applied to the answer.
        iou_threshold: The API's NMS IoU.
        request_timeout: Seconds per HTTP request.
        total_timeout: Seconds for the whole task, polling included.
        poll_interval: Seconds between status requests.
        max_retries: Retries of a request answered 429 or 5xx (or a connection error).
        max_side: Images are downscaled so the longest side is at most this [px] before upload
            (boxes are scaled back).
    """

    def __init__(
        self,
        api_key: str | None = None,
        base_url: str | None = None,
        *,
        model: str = DEFAULT_MODEL,
        score_threshold: float = 0.25,
        iou_threshold: float = 0.8,
        request_timeout: float = 10.0,
        total_timeout: float = 60.0,
        poll_interval: float = 0.5,
        max_retries: int = 2,
        retry_backoff: float = 1.0,
        max_side: int = 1536,
        jpeg_quality: int = 90,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        key = api_key if api_key is not None else os.environ.get(API_KEY_ENV, "")
        if not key.strip():
            raise CloudAPIError(
                f"the cloud detector needs an API key: set the environment variable {API_KEY_ENV} "
                "(a DeepDataSpace API token)"
            )
        url = (base_url or os.environ.get(URL_ENV) or DEFAULT_URL).strip().rstrip("/")
        if not re.match(r"^https?://[^/\s]+", url):
            raise CloudAPIError(
                f"cloud API base URL must start with http:// or https://, got {url!r} (see {URL_ENV})"
            )
        self.api_key = key.strip()
        self.base_url = url
        self.model = model
        self.name = f"cloud:{model}"
        self.score_threshold = float(score_threshold)
        self.iou_threshold = float(iou_threshold)
        self.request_timeout = float(request_timeout)
        self.total_timeout = float(total_timeout)
        self.poll_interval = float(poll_interval)
        self.max_retries = int(max_retries)
        self.retry_backoff = float(retry_backoff)
        self.max_side = int(max_side)
        self.jpeg_quality = int(jpeg_quality)
        self._sleep = sleep
        self.last_timings: dict[str, float] = {}

    def vocabulary(self, prompts: Sequence[Prompt]) -> frozenset[str]:
        """Every class named in ``prompts`` (open vocabulary)."""
        return frozenset(c for _, c in check_prompts(prompts, self.name))

    # -- HTTP ---------------------------------------------------------------------------------

    def _request(self, method: str, url: str, body: dict[str, Any] | None = None) -> dict[str, Any]:
        data = json.dumps(body).encode("utf-8") if body is not None else None
        headers = {"Token": self.api_key, "Accept": "application/json"}
        if data is not None:
            headers["Content-Type"] = "application/json"
        attempt = 0
        while True:
            req = urllib.request.Request(url, data=data, headers=headers, method=method)
            retry_after: float | None = None
            try:
                with urllib.request.urlopen(req, timeout=self.request_timeout) as resp:
                    raw = resp.read()
                    status = resp.status
                break
            except urllib.error.HTTPError as exc:
                status = exc.code
                try:
                    detail = exc.read()[:300].decode("utf-8", "replace").strip()
                except OSError:
                    detail = ""
                if status in (401, 403):
                    raise CloudAPIError(
                        f"cloud API rejected the API key (HTTP {status} from {method} {url}): check {API_KEY_ENV}"
                        + (f"; server said: {detail}" if detail else ""),
                        status,
                    ) from None
                if status == 429 or status >= 500:
                    if attempt < self.max_retries:
                        ra = exc.headers.get("Retry-After") if exc.headers else None
                        retry_after = float(ra) if ra and ra.strip().isdigit() else None
                    else:
                        what = "rate limit reached (HTTP 429)" if status == 429 else f"server error (HTTP {status})"
                        raise CloudAPIError(
                            f"cloud API {what} from {method} {url} after {attempt + 1} attempt(s)"
                            + (f"; server said: {detail}" if detail else ""),
                            status,
                        ) from None
                else:
                    raise CloudAPIError(
                        f"cloud API answered HTTP {status} to {method} {url}" + (f": {detail}" if detail else ""),
                        status,
                    ) from None
            except (socket.timeout, TimeoutError):
                raise CloudAPIError(
                    f"cloud API did not answer within {self.request_timeout:g} s ({method} {url})"
                ) from None
            except urllib.error.URLError as exc:
                if isinstance(exc.reason, (socket.timeout, TimeoutError)):
                    raise CloudAPIError(
                        f"cloud API did not answer within {self.request_timeout:g} s ({method} {url})"
                    ) from None
                if attempt >= self.max_retries:
                    raise CloudAPIError(f"cannot reach the cloud API at {url}: {exc.reason}") from None
            except (OSError, http.client.HTTPException) as exc:
                if attempt >= self.max_retries:
                    raise CloudAPIError(f"connection to the cloud API failed ({method} {url}): {exc}") from None
            attempt += 1
            self._sleep(min(retry_after if retry_after is not None else self.retry_backoff * attempt, 30.0))
        try:
            payload = json.loads(raw.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError):
            snippet = raw[:200].decode("utf-8", "replace")
            raise CloudAPIError(
                f"cloud API returned malformed JSON (HTTP {status}, {method} {url}): {snippet!r}", status
            ) from None
        if not isinstance(payload, dict):
            raise CloudAPIError(
                f"cloud API returned {type(payload).__name__}, expected a JSON object ({method} {url})", status
            )
        code = payload.get("code", 0)
        if code != 0:
            raise CloudAPIError(f"cloud API error code {code} ({method} {url}): {payload.get('msg', '')}", status)
        data_obj = payload.get("data")
        if not isinstance(data_obj, dict):
            raise CloudAPIError(
                f"cloud API answer has no 'data' object ({method} {url}): {str(payload)[:200]}", status
            )
        return data_obj

    # -- detection ----------------------------------------------------------------------------

    def encode_image(self, image_rgb: np.ndarray) -> tuple[str, float]:
        """``(data URL of a JPEG, scale)``; scale < 1 when the image was downscaled for upload."""
        h, w = image_rgb.shape[:2]
        scale = min(1.0, self.max_side / max(h, w))
        img = image_rgb
        if scale < 1.0:
            size = (max(1, round(w * scale)), max(1, round(h * scale)))
            img = cv2.resize(image_rgb, size, interpolation=cv2.INTER_AREA)
        ok, buf = cv2.imencode(".jpg", img[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality])
        if not ok:
            raise CloudAPIError("could not JPEG-encode the image for upload")
        return "data:image/jpeg;base64," + base64.b64encode(buf.tobytes()).decode("ascii"), scale

    def detect(self, image_rgb: np.ndarray, prompts: Sequence[Prompt]) -> list[Detection]:
        """Detections of ``prompts`` (text, class name), best first; blocks until the task ends."""
        image = check_image(image_rgb, self.name)
        pairs = list(dict.fromkeys(check_prompts(prompts, self.name)))
        if not pairs:
            return []
        t0 = time.perf_counter()
        # '.' separates prompts in the API's text; keep it out of the prompts themselves.
        texts = list(dict.fromkeys(" ".join(t.replace(".", " ").split()) for t, _ in pairs))
        by_key: dict[str, tuple[str, str]] = {}
        for t, c in pairs:
            by_key.setdefault(_prompt_key(t), (t, c))
        image_url, scale = self.encode_image(image)
        body = {
            "model": self.model,
            "image": image_url,
            "prompt": {"type": "text", "text": ".".join(texts)},
            "targets": ["bbox"],
            "bbox_threshold": self.score_threshold,
            "iou_threshold": self.iou_threshold,
        }
        created = self._request("POST", self.base_url + api_path_for(self.model), body)
        task = created.get("task_uuid")
        if not isinstance(task, str) or not task:
            raise CloudAPIError(f"cloud API did not return a task_uuid: {str(created)[:200]}")
        result = self._wait(task, t0)
        objects = result.get("objects") if isinstance(result, dict) else None
        if not isinstance(objects, list):
            raise CloudAPIError(f"cloud API task {task} result has no 'objects' list: {str(result)[:200]}")
        h, w = image.shape[:2]
        out: list[Detection] = []
        for i, obj in enumerate(objects):
            try:
                x1, y1, x2, y2 = (float(v) / scale for v in obj["bbox"])
                score = float(obj.get("score", 1.0))
                category = str(obj["category"])
            except (KeyError, TypeError, ValueError):
                raise CloudAPIError(f"cloud API task {task}: malformed object {i}: {str(obj)[:200]}") from None
            match = by_key.get(_prompt_key(category))
            if match is None and len(by_key) == 1:
                match = next(iter(by_key.values()))
            if match is None or score < self.score_threshold:
                continue
            x1, x2 = sorted((min(max(x1, 0.0), w), min(max(x2, 0.0), w)))
            y1, y2 = sorted((min(max(y1, 0.0), h), min(max(y2, 0.0), h)))
            if x2 > x1 and y2 > y1:
                out.append(Detection((x1, y1, x2, y2), score, match[1], match[0]))
        out.sort(key=lambda d: -d.score)
        self.last_timings = {"detect": time.perf_counter() - t0}
        return out

    def _wait(self, task: str, t0: float) -> dict[str, Any]:
        url = f"{self.base_url}/v2/task_status/{task}"
        status = "unknown"
        while True:
            data = self._request("GET", url)
            status = str(data.get("status", "unknown"))
            if status == "success":
                result = data.get("result")
                if not isinstance(result, dict):
                    raise CloudAPIError(f"cloud API task {task} succeeded without a result object")
                return result
            if status == "failed":
                raise CloudAPIError(f"cloud API task {task} failed: {data.get('error') or 'no reason given'}")
            if status not in ("waiting", "running", "triggering"):
                raise CloudAPIError(f"cloud API task {task} has an unknown status {status!r}")
            if time.perf_counter() - t0 + self.poll_interval > self.total_timeout:
                raise CloudAPIError(
                    f"cloud API task {task} did not finish within {self.total_timeout:g} s (last status: {status})"
                )
            self._sleep(self.poll_interval)
