"""Tests for the proxy models: one normalised, coloured GLB per catalog class, kept up to date."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from assets import FALLBACK_MODEL, PROXY_DIR
from assets.make_proxy_models import build_model, main, normalize, write_models
from pipeline.catalog import Catalog, CatalogError, load_proxy_mesh

CATALOG = Catalog.load()
MODEL_FILES = sorted({e.model for e in CATALOG} | {FALLBACK_MODEL})
UNIT_BOUNDS = np.array([[-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]])


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("proxy_models")
    written = write_models(out)
    assert set(written) == set(MODEL_FILES)
    return out


def test_every_entry_has_a_model_and_no_stale_files() -> None:
    for entry in CATALOG:
        assert entry.model_path.is_file(), entry.name
    on_disk = sorted(p.name for p in PROXY_DIR.glob("*.glb"))
    assert on_disk == MODEL_FILES


@pytest.mark.parametrize("model", MODEL_FILES)
def test_model_is_normalised_coloured_and_small(model: str) -> None:
    path = PROXY_DIR / model
    assert path.stat().st_size < 100_000
    mesh = load_proxy_mesh(path)
    assert len(mesh.faces) > 0
    np.testing.assert_allclose(mesh.bounds, UNIT_BOUNDS, atol=1e-6)
    colors = mesh.visual.vertex_colors
    assert colors.shape == (len(mesh.vertices), 4)
    assert len(np.unique(colors[:, :3], axis=0)) >= 2, "parts should have varied shades"


@pytest.mark.parametrize("model", MODEL_FILES)
def test_committed_models_are_up_to_date(model: str, regenerated: Path) -> None:
    committed = load_proxy_mesh(PROXY_DIR / model)
    fresh = load_proxy_mesh(regenerated / model)
    assert len(fresh.vertices) == len(committed.vertices), "run: python -m assets.make_proxy_models"
    np.testing.assert_array_equal(fresh.faces, committed.faces)
    np.testing.assert_allclose(fresh.vertices, committed.vertices, atol=1e-6)
    np.testing.assert_array_equal(fresh.visual.vertex_colors, committed.visual.vertex_colors)


def test_model_colour_derives_from_the_class_colour() -> None:
    for entry in CATALOG:
        colors = load_proxy_mesh(entry.model_path).visual.vertex_colors[:, :3].astype(float)
        distance = np.linalg.norm(colors - np.array(entry.color, float), axis=1)
        assert distance.min() < 60, f"{entry.name}: no part close to the class colour {entry.color}"


@pytest.mark.parametrize("name", ["chair", "office_chair", "sofa", "bench", "bed", "toilet"])
def test_front_faces_plus_x(name: str) -> None:
    """Seats face +x: the tall part (backrest, headboard, tank) is at the back, -x."""
    v = load_proxy_mesh(CATALOG.get(name).model_path).vertices
    top = v[v[:, 2] > 0.35]
    assert len(top) > 0
    assert top[:, 0].mean() < -0.1


def test_z_is_up_for_a_person() -> None:
    """The head (the vertices near the top) is narrow in y; the feet rest on z = -0.5."""
    v = load_proxy_mesh(CATALOG.get("person").model_path).vertices
    head = v[v[:, 2] > 0.4]
    assert np.ptp(head[:, 1]) < 0.5
    assert v[:, 2].min() == pytest.approx(-0.5)


def test_build_model_unknown_kind_falls_back_to_a_box() -> None:
    mesh = build_model("no_such_builder", (2.0, 1.0, 3.0), (10, 200, 30))
    np.testing.assert_allclose(mesh.bounds, UNIT_BOUNDS, atol=1e-12)
    assert len(mesh.faces) > 12


def test_build_model_unknown_size_uses_nominal_size() -> None:
    mesh = build_model("rock", None, (100, 100, 100))
    np.testing.assert_allclose(mesh.bounds, UNIT_BOUNDS, atol=1e-12)


def test_normalize_rejects_flat_mesh() -> None:
    flat = trimesh.Trimesh(
        vertices=[[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=[[0, 1, 2]], process=False
    )
    with pytest.raises(ValueError, match="flat"):
        normalize(flat)


def test_cli_builds_selected_models(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--out", str(tmp_path), "--only", "chair", "desk"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["chair.glb", "desk.glb"]
    assert "chair.glb" in capsys.readouterr().out
    assert main(["--out", str(tmp_path), "--catalog", str(tmp_path / "missing.toml")]) == 1
    assert "error" in capsys.readouterr().err


def test_load_proxy_mesh_errors(tmp_path: Path) -> None:
    with pytest.raises(CatalogError, match="not found"):
        load_proxy_mesh(tmp_path / "missing.glb")
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"not a glb at all")
    with pytest.raises(CatalogError, match="bad.glb"):
        load_proxy_mesh(bad)
