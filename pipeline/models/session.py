"""ONNX Runtime sessions with a checked input/output signature.

Every backend declares the tensors it feeds and reads as an :class:`IOSignature`; :func:`open_session`
loads the file, picks CUDA when this onnxruntime build has it (else CPU) and refuses a model whose
tensor names or ranks differ, naming the expected and the actual I/O.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from pipeline.models.base import ModelError, ModelMissingError


@dataclass(frozen=True)
class TensorSpec:
    """Name and rank of one model input or output; ``shape`` entries are ints or ``None`` (any)."""

    name: str
    rank: int
    shape: tuple[int | None, ...] | None = None

    def describe(self) -> str:
        dims = ",".join("?" if d is None else str(d) for d in self.shape) if self.shape else "x".join("?" * self.rank)
        return f"{self.name}[{dims}]"


@dataclass(frozen=True)
class IOSignature:
    """The inputs a backend feeds and the outputs it reads (extra outputs are allowed)."""

    inputs: tuple[TensorSpec, ...]
    outputs: tuple[TensorSpec, ...]

    def describe(self) -> str:
        ins = ", ".join(t.describe() for t in self.inputs)
        outs = ", ".join(t.describe() for t in self.outputs)
        return f"inputs ({ins}) -> outputs ({outs})"


def available_providers() -> list[str]:
    """Execution providers to use: CUDA first when this onnxruntime build offers it, then CPU."""
    import onnxruntime as ort

    have = ort.get_available_providers()
    return [p for p in ("CUDAExecutionProvider", "CPUExecutionProvider") if p in have] or ["CPUExecutionProvider"]


def default_threads() -> int:
    """Intra-op threads when none are given: every CPU core."""
    return max(1, os.cpu_count() or 1)


def actual_signature(session: Any) -> IOSignature:
    """The signature of a loaded session (dynamic dimensions become ``None``)."""

    def spec(arg: Any) -> TensorSpec:
        shape = tuple(d if isinstance(d, int) else None for d in (arg.shape or ()))
        return TensorSpec(arg.name, len(shape), shape)

    return IOSignature(tuple(spec(a) for a in session.get_inputs()), tuple(spec(a) for a in session.get_outputs()))


def check_signature(actual: IOSignature, expected: IOSignature, what: str) -> None:
    """Raise :class:`ModelError` when ``actual`` lacks an expected tensor, has a wrong rank or a fixed
    dimension that differs, or needs an input the backend does not feed."""
    problems: list[str] = []
    act_in = {t.name: t for t in actual.inputs}
    act_out = {t.name: t for t in actual.outputs}
    for kind, exp_list, act in (("input", expected.inputs, act_in), ("output", expected.outputs, act_out)):
        for exp in exp_list:
            got = act.get(exp.name)
            if got is None:
                problems.append(f"missing {kind} {exp.name!r}")
                continue
            if got.rank != exp.rank:
                problems.append(f"{kind} {exp.name!r} has rank {got.rank}, expected {exp.rank}")
                continue
            if exp.shape and got.shape:
                for i, (e, g) in enumerate(zip(exp.shape, got.shape)):
                    if e is not None and g is not None and e != g:
                        problems.append(f"{kind} {exp.name!r} dimension {i} is {g}, expected {e}")
    extra = sorted(set(act_in) - {t.name for t in expected.inputs})
    if extra:
        problems.append(f"unexpected input(s) {', '.join(map(repr, extra))}")
    if problems:
        raise ModelError(
            f"{what}: I/O signature mismatch: {'; '.join(problems)}. "
            f"Expected {expected.describe()}; the file has {actual.describe()}"
        )


def open_session(
    path: Path | str,
    signature: IOSignature | None,
    *,
    threads: int | None = None,
    model_name: str | None = None,
) -> Any:
    """An ``onnxruntime.InferenceSession`` for ``path`` with its signature checked.

    Args:
        path: The ``.onnx`` file.
        signature: Expected I/O, or ``None`` to skip the check.
        threads: Intra-op threads (default: every CPU core).
        model_name: Registry name used in error messages (default: the file name).

    Raises:
        ModelMissingError: The file does not exist.
        ModelError: The file is not a loadable ONNX model, or its signature differs.
    """
    path = Path(path)
    what = f"model {model_name!r} ({path})" if model_name else str(path)
    if not path.is_file():
        raise ModelMissingError(model_name or path.stem, f"no file {path}")
    session = session_from(str(path), what, threads)
    if signature is not None:
        check_signature(actual_signature(session), signature, what)
    return session


def session_from(source: str | bytes, what: str, threads: int | None = None) -> Any:
    """An ``onnxruntime.InferenceSession`` from a file name or a serialised model (CUDA first, else CPU).

    Raises:
        ModelError: Bad ``threads``, or onnxruntime cannot load the model.
    """
    import onnxruntime as ort

    if threads is not None and (not isinstance(threads, int) or threads < 1):
        raise ModelError(f"{what}: threads must be a positive integer, got {threads!r}")
    options = ort.SessionOptions()
    options.intra_op_num_threads = threads or default_threads()
    options.inter_op_num_threads = 1
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    options.log_severity_level = 3  # errors only: some exports carry unused initializers
    try:
        return ort.InferenceSession(source, sess_options=options, providers=available_providers())
    except Exception as exc:  # onnxruntime raises its own Fail/InvalidGraph/... types
        raise ModelError(f"{what}: cannot load the ONNX file: {exc}") from exc


def run(session: Any, outputs: Sequence[str] | None, feeds: dict[str, Any], what: str) -> list[Any]:
    """``session.run`` with onnxruntime failures turned into :class:`ModelError`."""
    try:
        return session.run(list(outputs) if outputs is not None else None, feeds)
    except Exception as exc:
        raise ModelError(f"{what}: inference failed: {exc}") from exc
