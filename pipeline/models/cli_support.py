"""What ``morphonavi models list|fetch|verify`` do, as functions returning text and exit codes.

The CLI only parses arguments and prints; every decision lives here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Sequence

from pipeline.models.base import ModelError
from pipeline.models.fetch import fetch
from pipeline.models.registry import (
    MODEL_SET_ALIASES,
    MODEL_SETS,
    model_set_name,
    format_table,
    get_spec,
    list_models,
    resolve_models_dir,
    search_dirs,
    verify,
)


def models_list(model_dir: Path | str | None = None) -> str:
    """The table of known models with their status, and where models are looked for."""
    rows = [r.as_row() for r in list_models(model_dir)]
    dirs = ", ".join(str(d) for d in search_dirs(model_dir))
    sets = "; ".join(f"{s}: {', '.join(m)}" for s, m in MODEL_SETS.items())
    sets += "".join(f" ({old} is the old name of {new})" for old, new in MODEL_SET_ALIASES.items())
    from pipeline.mapper_config import AUTO_SECOND  # the mapper adds these detectors when present
    from pipeline.models.registry import locate

    extras = "".join(f"\n{s} also runs {n} beside its detector when present: "
                     f"{'present' if locate(n, model_dir) else f'missing, so {s} runs without it'}"
                     for s, n in AUTO_SECOND.items())
    return f"{format_table(rows)}\n\nsearched: {dirs}\nsets: {sets}{extras}"


def expand_names(names: Sequence[str]) -> list[str]:
    """Model names, with set names (``offline``, ``hub`` or its old name ``default``, ``cloud``) replaced by their
    downloadable members, and the detector the mapper runs beside a set's own when present
    (``offline``: the Open Images SSD, ``pipeline.mapper_config.AUTO_SECOND``), so that fetching a set
    gets what its figures were measured with; :class:`ModelError` for unknown names."""
    from pipeline.mapper_config import AUTO_SECOND

    out: list[str] = []
    for name in names:
        name = model_set_name(name)  # "default" is the hub set's old name
        members = MODEL_SETS.get(name, (name,)) + ((AUTO_SECOND[name],) if name in AUTO_SECOND else ())
        for m in members:
            spec = get_spec(m)
            if (not spec.remote or m == name) and m not in out:
                out.append(m)
    if not out:
        raise ModelError("no model named: give a model or set name, e.g. 'offline' or 'yolox_nano'")
    return out


def models_fetch(
    names: Sequence[str],
    model_dir: Path | str | None = None,
    *,
    progress: bool = True,
    log: Callable[[str], None] = print,
) -> int:
    """Download models (or every downloadable model of a set) into the models directory.

    Returns 0 when all succeeded, 1 otherwise (each failure is logged with its reason).
    """
    try:
        wanted = expand_names(names)
    except ModelError as exc:
        log(f"error: {exc}")
        return 1
    dest = resolve_models_dir(model_dir)
    failed = 0
    for name in wanted:
        try:
            files = fetch(name, dest, progress=progress, log=log)
        except ModelError as exc:
            failed += 1
            log(f"error: {name}: {exc}")
            continue
        except OSError as exc:  # a file-system failure fetch did not foresee: one line, no traceback
            failed += 1
            log(f"error: {name}: {exc.strerror or exc}: {getattr(exc, 'filename', '') or dest / name}")
            continue
        log(f"{name}: {len(files)} file(s) ready in {dest / name}")
    return 1 if failed else 0


def models_verify(model_dir: Path | str | None = None, names: Sequence[str] | None = None) -> tuple[str, int]:
    """``(report table, exit code)`` of checksum and signature checks of present models."""
    try:
        wanted = expand_names(names) if names else None
        results = verify(model_dir, wanted)
    except ModelError as exc:
        return f"error: {exc}", 1
    if not results:
        return f"no models found in {', '.join(str(d) for d in search_dirs(model_dir))}", 1
    table = format_table([r.as_row() for r in results])
    return table, 0 if all(r.ok for r in results) else 1


__all__ = ["expand_names", "models_fetch", "models_list", "models_verify"]
