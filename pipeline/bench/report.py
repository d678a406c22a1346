"""The benchmark's report: per-sample records summed into the paper's metrics, and their text table.

:func:`summarise` turns the records of :func:`pipeline.bench.evaluate.run_bench` (one per photo, with its
matches: camera-frame centres [m], per-cue distances and sigmas [m]) into the summary; :class:`BenchReport`
holds both (JSON through :meth:`BenchReport.to_dict`); :func:`format_report` prints the tables.
"""

from __future__ import annotations

import json
import math
import statistics
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from pipeline.scene import write_text_atomic

STAGES = ("detect", "depth", "segment_encoder", "segment_decoder", "segment", "distance", "total")
CUES = ("size_prior", "ground_contact", "depth")
"""The distance cues the bench scores one by one (optical-axis depth of the centre against the truth)."""


@dataclass
class BenchReport:
    """Summary and per-sample records of one benchmark run (JSON-ready through :meth:`to_dict`)."""

    dataset: str
    mode: str
    models: dict[str, str]
    summary: dict[str, Any]
    samples: list[dict[str, Any]] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"dataset": self.dataset, "mode": self.mode, "models": self.models, "summary": self.summary,
                "samples": self.samples}

    def save(self, path: str | Path) -> Path:
        """Write the report as JSON (atomically)."""
        return write_text_atomic(Path(path), json.dumps(self.to_dict(), indent=1) + "\n")



def models_line(models: dict[str, Any]) -> str:
    """``models: detector=..., segmenter=..., depth=..., placement=...`` (bench header, ``map``'s line)."""
    return "models: " + ", ".join(f"{k}={v}" for k, v in models.items() if k in ("detector", "segmenter", "depth", "placement"))



def _stats(values: Sequence[float]) -> dict[str, float | None]:
    if not values:
        return {"mean": None, "median": None}
    return {"mean": float(statistics.fmean(values)), "median": float(statistics.median(values))}


def summarise(records: list[dict[str, Any]], excluded: dict[str, int]) -> dict[str, Any]:
    n_gt = sum(r["n_gt"] for r in records)
    n_gt_vocab = sum(r["n_gt_vocab"] for r in records)
    n_m = sum(r["n_matched"] for r in records)
    n_m_vocab = sum(r["n_matched_vocab"] for r in records)
    matches = [m for r in records for m in r["matches"]]
    by_source: dict[str, Any] = {}
    for src in sorted({r["source"] for r in records}):
        rs = [r for r in records if r["source"] == src]
        ms = [m for r in rs for m in r["matches"]]
        by_source[src] = {
            "images": len(rs),
            "gt": sum(r["n_gt"] for r in rs),
            "matched": len(ms),
            "error_m": _stats([m["error_m"] for m in ms]),
            "error_rel": _stats([m["error_rel"] for m in ms]),
        }
    by_class: dict[str, Any] = {}
    complete_recs = [r for r in records if not r["partial_annotation"]]
    false_dets = [u["label"] for r in complete_recs for u in r["unmatched_detections"]]
    partial_unmatched = [u["label"] for r in records if r["partial_annotation"] for u in r["unmatched_detections"]]
    for cls in sorted({m["label"] for m in matches} | {c for r in records for c in r["missed"]} | set(false_dets)
                      | set(partial_unmatched)):
        ms = [m for m in matches if m["label"] == cls]
        missed = sum(r["missed"].count(cls) for r in records)
        hits = sum(1 for r in complete_recs for m in r["matches"] if m["label"] == cls)
        dets = hits + false_dets.count(cls)  # placed detections of the class on fully annotated samples
        by_class[cls] = {"gt": len(ms) + missed, "matched": len(ms), "error_rel": _stats([m["error_rel"] for m in ms]),
                         "detections_complete": dets, "precision": hits / dets if dets else None,
                         "unmatched_partial": partial_unmatched.count(cls)}
    timings = {k: _stats([r["timings"][k] for r in records if k in r["timings"]])["mean"] for k in STAGES}
    cues: dict[str, Any] = {}
    for name in CUES:
        cs = [m["cues"][name] for m in matches if name in m.get("cues", {})]
        rel = [c["error_rel"] for c in cs]
        cues[name] = {"n": len(cs), "error_rel": _stats(rel), **_calibration([(c["error_m"], c["sigma"]) for c in cs])}
    fz = [m for m in matches if m.get("sigma_z") is not None]
    cues["fused"] = {"n": len(fz), "error_rel": _stats([m["error_z"] / abs(m["gt_center"][2]) for m in fz]),
                     **_calibration([(m["error_z"], m["sigma_z"]) for m in fz])}
    complete = [r for r in records if not r["partial_annotation"]]
    placed_complete = sum(r["n_placed"] for r in complete)
    matched_complete = sum(r["n_matched"] for r in complete)
    return {
        "images": len(records),
        "gt_objects_catalog": n_gt,
        "gt_objects_in_vocabulary": n_gt_vocab,
        "excluded_labels": dict(sorted(excluded.items())),
        "matched": n_m,
        "detection_ratio": n_m / n_gt if n_gt else None,
        "detection_ratio_vocabulary": n_m_vocab / n_gt_vocab if n_gt_vocab else None,
        "unmatched_detections": sum(r["n_unmatched_detections"] for r in records),
        "complete_annotation": {
            "images": len(complete),
            "detections": placed_complete,
            "unmatched_detections": placed_complete - matched_complete,
            "precision": matched_complete / placed_complete if placed_complete else None,
        },
        "error_m": _stats([m["error_m"] for m in matches]),
        "error_rel": _stats([m["error_rel"] for m in matches]),
        "mean_time_s": timings,
        "cues": cues,
        "truncated": {"matched": sum(1 for m in matches if m.get("cut")),
                      "error_rel": _stats([m["error_rel"] for m in matches if m.get("cut")])},
        "hidden_contact": {"matched": sum(1 for m in matches if m.get("contact_hidden_by")),
                           "error_rel": _stats([m["error_rel"] for m in matches if m.get("contact_hidden_by")])},
        "raised_height": {"matched": sum(1 for m in matches if (m.get("height") or {}).get("how") == "at_least_visible"),
                          "error_rel": _stats([m["error_rel"] for m in matches
                                               if (m.get("height") or {}).get("how") == "at_least_visible"])},
        "by_source": by_source,
        "by_class": by_class,
        "by_pose": {key: {"images": sum(1 for r in records if r.get("pose_given", True) == given),
                          "matched": len(ms), "error_rel": _stats([m["error_rel"] for m in ms]),
                          **_calibration([(m["error_z"], m["sigma_z"]) for m in ms if m.get("sigma_z") is not None])}
                    for key, given in (("given", True), ("not_given", False))
                    for ms in [[m for r in records if r.get("pose_given", True) == given for m in r["matches"]]]},
        "pose_warnings": [f"{r['id']}: {r['camera_pose_warning']}" for r in records if r.get("camera_pose_warning")],
    }


def _calibration(pairs: Sequence[tuple[float, float]]) -> dict[str, float | None]:
    """Fractions of ``(error, sigma)`` pairs with ``error <= sigma`` and ``<= 2 sigma`` (a calibrated
    Gaussian sigma gives 68 % and 95 %)."""
    if not pairs:
        return {"within_1_sigma": None, "within_2_sigma": None}
    n = len(pairs)
    return {"within_1_sigma": sum(1 for e, s in pairs if e <= s) / n,
            "within_2_sigma": sum(1 for e, s in pairs if e <= 2 * s) / n}


def _fmt(v: float | None, spec: str) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)


def format_report(report: BenchReport) -> str:
    """A plain-text summary of a :class:`BenchReport`."""
    s = report.summary
    c = s["complete_annotation"]
    lines = [
        f"dataset {report.dataset} ({s['images']} images, mode: {report.mode})",
        models_line(report.models),
        *([f"note: {report.models['note']}"] if report.models.get("note") else []),
        "",
        f"detection ratio       {_fmt(s['detection_ratio'], '.1%')} of {s['gt_objects_catalog']} ground-truth objects of catalog classes",
        f"                      {_fmt(s['detection_ratio_vocabulary'], '.1%')} of {s['gt_objects_in_vocabulary']} in the detector's vocabulary",
        f"excluded (no class)   {sum(s['excluded_labels'].values())}: " + ", ".join(f"{k} {v}" for k, v in s["excluded_labels"].items()),
        f"unmatched detections  {s['unmatched_detections']}",
        f"precision             {_fmt(c['precision'], '.1%')} of {c['detections']} detections on the {c['images']} fully "
        f"annotated images ({c['unmatched_detections']} unmatched)",
        f"3D centre error       mean {_fmt(s['error_m']['mean'], '.3f')} m, median {_fmt(s['error_m']['median'], '.3f')} m "
        f"({s['matched']} matched)",
        f"relative to distance  mean {_fmt(s['error_rel']['mean'], '.1%')}, median {_fmt(s['error_rel']['median'], '.1%')}",
        "",
        "mean time per image [s]: " + "  ".join(f"{k} {_fmt(v, '.3f')}" for k, v in s["mean_time_s"].items()),
        "",
        f"{'source':10s} {'images':>6s} {'gt':>4s} {'found':>5s} {'err mean':>9s} {'err med':>8s} {'rel med':>8s}",
    ]
    for src, b in s["by_source"].items():
        lines.append(
            f"{src:10s} {b['images']:6d} {b['gt']:4d} {b['matched']:5d} {_fmt(b['error_m']['mean'], '8.2f')}m "
            f"{_fmt(b['error_m']['median'], '7.2f')}m {_fmt(b['error_rel']['median'], '8.1%')}"
        )
    lines.append("")
    lines.append("distance along the optical axis, per cue (matched objects; a calibrated sigma: 68 % / 95 %):")
    lines.append(f"{'cue':16s} {'n':>4s} {'rel mean':>9s} {'rel med':>8s} {'<=1 sigma':>10s} {'<=2 sigma':>10s}")
    for name, c in s.get("cues", {}).items():
        lines.append(f"{name:16s} {c['n']:4d} {_fmt(c['error_rel']['mean'], '9.1%')} {_fmt(c['error_rel']['median'], '8.1%')} "
                     f"{_fmt(c['within_1_sigma'], '10.0%')} {_fmt(c['within_2_sigma'], '10.0%')}")
    for key, what in (("given", "camera pose given"), ("not_given", "camera pose from the photo")):
        b = s.get("by_pose", {}).get(key)
        if b and b["images"]:
            lines.append(f"{what:26s} {b['images']:3d} images, {b['matched']:3d} matched: relative mean "
                         f"{_fmt(b['error_rel']['mean'], '.1%')}, median {_fmt(b['error_rel']['median'], '.1%')}, "
                         f"fused within 1 / 2 sigma {_fmt(b['within_1_sigma'], '.0%')} / {_fmt(b['within_2_sigma'], '.0%')}")
    for w in s.get("pose_warnings", []):
        lines.append(f"warning: {w}")
    t = s.get("truncated")
    if t:
        lines.append(f"cut by the border: {t['matched']} matched, 3D error relative mean "
                     f"{_fmt(t['error_rel']['mean'], '.1%')}, median {_fmt(t['error_rel']['median'], '.1%')}")
    for key, what in (("hidden_contact", "floor contact maybe hidden by a nearer box, used as an upper bound"),
                      ("raised_height", "top cut by the border, height raised to at least the visible")):
        h = s.get(key)
        if h and h["matched"]:
            lines.append(f"{what}: {h['matched']} matched, 3D error relative mean {_fmt(h['error_rel']['mean'], '.1%')}")
    lines.append("")
    lines.append(f"{'class':16s} {'gt':>4s} {'found':>5s} {'rel med':>8s}  {'precision (fully annotated)':>27s}  "
                 "unmatched on partially annotated")
    for cls, b in s["by_class"].items():
        prec = (f"{_fmt(b.get('precision'), '.0%')} of {b['detections_complete']}" if b.get("detections_complete")
                else "-")
        lines.append(f"{cls:16s} {b['gt']:4d} {b['matched']:5d} {_fmt(b['error_rel']['median'], '8.1%')}  {prec:>27s}  "
                     f"{b.get('unmatched_partial', 0)}")
    return "\n".join(lines)


__all__ = ["BenchReport", "CUES", "STAGES", "format_report", "models_line", "summarise"]
