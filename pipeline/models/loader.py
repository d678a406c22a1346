"""Building the detector, segmenter and depth estimator of a model set."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from pipeline.models.base import DepthEstimator, Detector, ModelMissingError, Segmenter
from pipeline.models.registry import ModelSpec, get_spec, locate, search_dirs, set_members


@dataclass
class ModelBundle:
    """The three perception models the mapper runs, and the registry names they came from."""

    detector: Detector
    segmenter: Segmenter
    depth: DepthEstimator
    names: tuple[str, str, str] = ("", "", "")


def _folder(spec: ModelSpec, model_dir: Path | str | None) -> Path:
    folder = locate(spec.name, model_dir)
    if folder is None:
        dirs = ", ".join(str(d) for d in search_dirs(model_dir))
        raise ModelMissingError(spec.name, f"looked in {dirs}")
    return folder


def load_model(
    name: str,
    model_dir: Path | str | None = None,
    *,
    threads: int | None = None,
    label_map: Mapping[str, str] | None = None,
    **options: Any,
) -> Any:
    """One model by registry name, ready to run.

    Args:
        name: Registry name (``"yolox_nano"``, ``"oidv4_ssd"``, ``"owlv2"``, ``"mobilesam"``, ...).
        model_dir: Models directory (default: ``$MORPHONAVI_MODELS`` / user cache, see registry).
        threads: onnxruntime intra-op threads (default: every core).
        label_map: Closed-vocabulary detectors: backend label -> class name (default: identity).
        options: Backend keyword arguments (``score_threshold``, ``input_size``, ...).

    Raises:
        ModelMissingError: Files are missing; names ``morphonavi models fetch NAME``.
        ModelError: The files do not load or have the wrong signature.
    """
    from pipeline.models import depth, owl, sam, yolox

    spec = get_spec(name)
    kwargs = {**dict(spec.options), **options}
    if spec.backend == "cloud":
        from pipeline.models.cloud import CloudDetector

        return CloudDetector(**kwargs)
    folder = _folder(spec, model_dir)
    if spec.backend == "yolox":
        return yolox.YoloxDetector.from_dir(folder, label_map, threads=threads, name=name, **kwargs)
    if spec.backend == "ssd":
        from pipeline.models.ssd import SsdDetector

        return SsdDetector.from_dir(folder, label_map, threads=threads, name=name, **kwargs)
    if spec.backend == "owl":
        return owl.OwlDetector.from_dir(folder, threads=threads, name=name, **kwargs)
    if spec.backend == "sam":
        return sam.SamSegmenter.from_dir(folder, threads=threads, name=name, **kwargs)
    if spec.backend == "depth_anything":
        return depth.DepthAnythingEstimator.from_dir(folder, threads=threads, name=name, **kwargs)
    if spec.backend == "fastdepth":
        return depth.FastDepthEstimator.from_dir(folder, threads=threads, name=name, **kwargs)
    raise AssertionError(f"registry entry {name!r} has an unknown backend {spec.backend!r}")


def present_set_members(set_name: str, model_dir: Path | str | None = None) -> tuple[str, str, str]:
    """The set's model names (detector, segmenter, depth), after checking their files are present.

    Raises:
        ModelMissingError: Naming ``morphonavi models fetch NAME`` for every missing model.
    """
    names = set_members(set_name)
    missing = [n for n in names if not get_spec(n).remote and locate(n, model_dir) is None]
    if missing:
        dirs = ", ".join(str(d) for d in search_dirs(model_dir))
        raise ModelMissingError(missing, f"model set {set_name!r}; looked in {dirs}")
    return names


def load_models(
    set_name: str = "offline",
    model_dir: Path | str | None = None,
    threads: int | None = None,
    *,
    label_map: Mapping[str, str] | None = None,
) -> ModelBundle:
    """The detector, segmenter and depth estimator of a model set (``"offline"``, ``"hub"``,
    ``"cloud"``; ``"default"`` is the hub set's old name).

    Raises:
        ModelMissingError: Some files are missing; the message names ``morphonavi models fetch NAME``
            for every missing model of the set.
        ModelError: Unknown set, or a model does not load.
    """
    names = present_set_members(set_name, model_dir)
    det_name, seg_name, depth_name = names
    return ModelBundle(
        detector=load_model(det_name, model_dir, threads=threads, label_map=label_map),
        segmenter=load_model(seg_name, model_dir, threads=threads),
        depth=load_model(depth_name, model_dir, threads=threads),
        names=names,
    )
