"""Tests for the object catalog: the packaged file, label resolution and load-time validation."""

from __future__ import annotations

from pathlib import Path

import pytest

from assets import CATALOG_PATH, PROXY_DIR
from pipeline.catalog import (
    Catalog,
    CatalogEntry,
    CatalogError,
    default_catalog,
    normalize_label,
    parse_color,
)

PAPER_ROOM = (
    "desk",
    "office_chair",
    "suitcase",
    "compressor",
    "office_cabinet",
    "cardboard_box",
    "sports_mat",
    "robot_dog",
)
COMMON = (
    "table", "chair", "sofa", "bed", "door", "person", "car", "bicycle", "trash_bin", "shelf",
    "monitor", "plant", "ladder", "pallet", "barrel", "nightstand", "dresser", "toilet", "sink",
    "bathtub", "refrigerator", "bench", "motorcycle", "truck", "traffic_cone", "backpack", "laptop",
    "bottle",
)  # fmt: skip


@pytest.fixture(scope="module")
def catalog() -> Catalog:
    return Catalog.load()


# --- The packaged catalog ------------------------------------------------------------------------


def test_packaged_catalog_has_enough_unique_classes(catalog: Catalog) -> None:
    assert len(catalog) >= 30
    assert len(set(catalog.names)) == len(catalog)
    assert catalog.names == tuple(e.name for e in catalog)
    assert catalog.source == CATALOG_PATH


@pytest.mark.parametrize("name", PAPER_ROOM + COMMON)
def test_required_classes_present(catalog: Catalog, name: str) -> None:
    entry = catalog.get(name)
    assert entry.name == name
    assert name in catalog
    assert entry.prompts, "every class needs a detector prompt"
    assert entry.model_path.is_file()
    assert entry.model_path.parent == PROXY_DIR


def test_paper_reference_sizes(catalog: Catalog) -> None:
    mat = catalog.get("sports_mat").size
    assert mat is not None
    assert mat[0] == pytest.approx(1.0) and mat[2] == pytest.approx(1.0)
    assert mat[1] == pytest.approx(0.05, abs=0.02)
    dog = catalog.get("robot_dog").size  # Unitree Go1 standing: l 0.645, w 0.28, h 0.40
    assert dog == pytest.approx((0.28, 0.40, 0.645), abs=0.03)
    compressor = catalog.get("compressor").size
    assert compressor is not None and sorted(compressor) == pytest.approx(
        [0.35, 0.45, 0.5], abs=0.1
    )


def test_sizes_are_plausible(catalog: Catalog) -> None:
    for entry in catalog:
        if entry.size is None:
            continue
        w, h, l = entry.size
        assert all(0.01 < v < 15.0 for v in entry.size), entry
        assert entry.height == h
    car = catalog.get("car").size
    person = catalog.get("person").size
    assert car is not None and person is not None
    assert car[2] > 2 * car[0], "a car is longer (l) than wide (w)"
    assert 1.5 < person[1] < 1.9, "h is the vertical extent"
    assert catalog.get("door").size[2] < 0.2 < catalog.get("door").size[1]  # type: ignore[index]


def test_unknown_size_entries_take_the_depth_only_path(catalog: Catalog) -> None:
    unknown = [e for e in catalog if e.size is None]
    assert unknown, "at least one class must have size = 'unknown'"
    for entry in unknown:
        assert entry.height is None
        assert not entry.size_known
        assert entry.model_path.is_file()
    assert catalog.get("unknown_object").size is None
    assert catalog.get("chair").size_known


def test_colors_are_rgb_bytes(catalog: Catalog) -> None:
    for entry in catalog:
        assert len(entry.color) == 3
        assert all(isinstance(c, int) and 0 <= c <= 255 for c in entry.color)
    assert catalog.get("office_chair").color == (0x33, 0x66, 0xCC)


def test_default_catalog_is_cached_and_equal() -> None:
    assert default_catalog() is default_catalog()
    assert default_catalog().entries == Catalog.load(CATALOG_PATH).entries


# --- Label resolution ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("label", "expected"),
    [
        ("office_chair", "office_chair"),
        ("Office Chair", "office_chair"),
        ("an office chair", "office_chair"),
        ("swivel-chair", "office_chair"),
        ("chair", "chair"),
        ("tvmonitor", "monitor"),
        ("TV monitor", "monitor"),
        ("tv", "monitor"),
        ("night_stand", "nightstand"),
        ("diningtable", "table"),
        ("dining table", "table"),
        ("pottedplant", "plant"),
        ("potted plant", "plant"),
        ("couch", "sofa"),
        ("Pedestrian", "person"),
        ("bookshelf", "shelf"),
        ("motorbike", "motorcycle"),
        ("fridge", "refrigerator"),
        ("garbage_bin", "trash_bin"),
        ("The Robot Dog", "robot_dog"),
        ("quadruped robot", "robot_dog"),
        ("a portable air compressor", "compressor"),
        ("boxes", "cardboard_box"),
        ("chairs", "chair"),
        ("  Traffic   Cone ", "traffic_cone"),
        ("misc", "unknown_object"),
    ],
)
def test_lookup_resolves_names_synonyms_and_prompts(
    catalog: Catalog, label: str, expected: str
) -> None:
    entry = catalog.lookup(label)
    assert entry is not None, label
    assert entry.name == expected


@pytest.mark.parametrize("label", ["spaceship", "", "   ", "a", "the", "--"])
def test_lookup_unknown_label_returns_none(catalog: Catalog, label: str) -> None:
    assert catalog.lookup(label) is None


def test_every_prompt_resolves_to_its_own_class(catalog: Catalog) -> None:
    pairs = catalog.prompts()
    assert len(pairs) == sum(len(e.prompts) for e in catalog)
    assert {name for _, name in pairs} == set(catalog.names)
    for prompt, name in pairs:
        resolved = catalog.lookup(prompt)
        assert resolved is not None and resolved.name == name, prompt
    for entry in catalog:
        for synonym in entry.synonyms:
            resolved = catalog.lookup(synonym)
            assert resolved is not None and resolved.name == entry.name, synonym


def test_get_unknown_name_suggests_close_names(catalog: Catalog) -> None:
    with pytest.raises(CatalogError, match="office_chair") as info:
        catalog.get("ofice_chair")
    assert isinstance(info.value, KeyError)
    assert "did you mean" in str(info.value)
    assert not str(info.value).startswith("'"), "message must not be quoted like a bare KeyError"


def test_get_synonym_points_to_lookup(catalog: Catalog) -> None:
    with pytest.raises(CatalogError, match="resolves to class 'sofa'"):
        catalog.get("couch")
    with pytest.raises(CatalogError, match="known classes"):
        catalog.get("zzzzzzzz")


@pytest.mark.parametrize(
    ("label", "key"),
    [
        ("An Office-Chair", "officechair"),
        ("night_stand", "nightstand"),
        ("TV monitor", "tvmonitor"),
        ("the  bed", "bed"),
        ("another", "another"),  # "an" is only an article when followed by a space
        ("a", "a"),
    ],
)
def test_normalize_label(label: str, key: str) -> None:
    assert normalize_label(label) == key


def test_parse_color() -> None:
    assert parse_color("#ff8000") == (255, 128, 0)
    assert parse_color("#F80") == (255, 136, 0)
    for bad in ("ff8000", "#ff80", "#gg0000", "red"):
        with pytest.raises(CatalogError):
            parse_color(bad)


def test_catalog_from_entries_rejects_shared_spellings() -> None:
    def entry(name: str, synonyms: tuple[str, ...] = ()) -> CatalogEntry:
        return CatalogEntry(name, (f"a {name}",), synonyms, (1.0, 1.0, 1.0), "box.glb", (0, 0, 0))

    assert len(Catalog([entry("a1"), entry("b1", ("thing",))])) == 2
    with pytest.raises(CatalogError, match="already resolves to class 'a1'"):
        Catalog([entry("a1", ("thing",)), entry("b1", ("Thing",))])


# --- Validation of malformed files ---------------------------------------------------------------

GOOD_A = """
[[object]]
name = "alpha"
prompts = ["an alpha"]
synonyms = ["first"]
size = [0.5, 1.0, 0.4]
model = "alpha.glb"
color = "#102030"
"""

GOOD_B = """
[[object]]
name = "beta"
prompts = ["a beta"]
synonyms = ["second"]
size = "unknown"
model = "alpha.glb"
color = "#405060"
"""


def write_catalog(tmp_path: Path, body: str, header: str = "version = 1\n") -> Path:
    (tmp_path / "proxy_models").mkdir(exist_ok=True)
    (tmp_path / "proxy_models" / "alpha.glb").write_bytes(b"placeholder")
    path = tmp_path / "catalog.toml"
    path.write_text(header + body, encoding="utf-8")
    return path


def test_minimal_catalog_loads(tmp_path: Path) -> None:
    cat = Catalog.load(write_catalog(tmp_path, GOOD_A + GOOD_B))
    assert cat.names == ("alpha", "beta")
    alpha, beta = cat.get("alpha"), cat.get("beta")
    assert alpha.size == (0.5, 1.0, 0.4) and alpha.height == 1.0
    assert alpha.color == (0x10, 0x20, 0x30)
    assert alpha.model_path == tmp_path / "proxy_models" / "alpha.glb"
    assert beta.size is None and beta.height is None
    assert cat.lookup("second") is beta
    assert cat.prompts() == [("an alpha", "alpha"), ("a beta", "beta")]
    # no spread / on_floor given: the defaults
    assert alpha.spread == (0.2, 0.2, 0.2) and alpha.on_floor
    cat = Catalog.load(write_catalog(tmp_path, GOOD_A.replace(
        "size = [0.5, 1.0, 0.4]", "size = [0.5, 1.0, 0.4]\nspread = [0.3, 0.07, 0.25]\non_floor = false") + GOOD_B))
    assert cat.get("alpha").spread == (0.3, 0.07, 0.25) and not cat.get("alpha").on_floor


def test_packaged_size_spreads_say_how_much_each_class_varies(catalog: Catalog) -> None:
    """People and cars vary little in height (cars: sedans to SUVs, 10 %), cabinets and tables a lot; table-top things are not on the floor."""
    sh = {name: catalog.get(name).spread[1] for name in ("person", "car", "cabinet", "table")}
    assert sh["person"] < 0.1 and sh["car"] <= 0.1 and sh["cabinet"] >= 0.4 and sh["table"] >= 0.15
    assert all(0 < v <= 2 for e in catalog for v in e.spread)
    assert not catalog.get("monitor").on_floor and not catalog.get("cup").on_floor
    assert catalog.get("office_cabinet").on_floor and catalog.get("person").on_floor


def test_models_dir_override(tmp_path: Path) -> None:
    path = write_catalog(tmp_path, GOOD_A.replace("alpha.glb", "box.glb"))
    with pytest.raises(CatalogError, match="model"):
        Catalog.load(path)
    assert Catalog.load(path, models_dir=PROXY_DIR).get("alpha").model_path == PROXY_DIR / "box.glb"


@pytest.mark.parametrize(
    ("body", "field", "message"),
    [
        (GOOD_A + GOOD_A, "object[1] (alpha).name", "duplicate class name"),
        (GOOD_A + GOOD_B.replace('"second"', '"First"'), "object[1] (beta).synonyms[0]", "alpha"),
        (GOOD_A + GOOD_B.replace('"second"', '"alpha"'), "object[1] (beta).synonyms[0]", "alpha"),
        (
            GOOD_A + GOOD_B.replace('"a beta"', '"the alpha"'),
            "object[1] (beta).prompts[0]",
            "alpha",
        ),
        (GOOD_A.replace("[0.5, 1.0, 0.4]", "[0.5, -1.0, 0.4]"), "object[0] (alpha).size[1]", "> 0"),
        (GOOD_A.replace("[0.5, 1.0, 0.4]", "[0.5, 0.0, 0.4]"), "object[0] (alpha).size[1]", "> 0"),
        (GOOD_A.replace("[0.5, 1.0, 0.4]", "[0.5, 1.0]"), "object[0] (alpha).size", "[w, h, l]"),
        (GOOD_A.replace("[0.5, 1.0, 0.4]", '"big"'), "object[0] (alpha).size", "unknown"),
        (
            GOOD_A.replace("[0.5, 1.0, 0.4]", '[0.5, "1", 0.4]'),
            "object[0] (alpha).size[1]",
            "number",
        ),
        (
            GOOD_A.replace("[0.5, 1.0, 0.4]", "[0.5, nan, 0.4]"),
            "object[0] (alpha).size[1]",
            "finite",
        ),
        (GOOD_A.replace('"alpha.glb"', '"missing.glb"'), "object[0] (alpha).model", "not found"),
        (GOOD_A.replace('"alpha.glb"', '""'), "object[0] (alpha).model", "file name"),
        (GOOD_A.replace('"#102030"', '"#1020"'), "object[0] (alpha).color", "#rrggbb"),
        (GOOD_A.replace('"#102030"', '"blue"'), "object[0] (alpha).color", "#rrggbb"),
        (GOOD_A.replace('["an alpha"]', "[]"), "object[0] (alpha).prompts", "at least one"),
        (GOOD_A.replace('["an alpha"]', '[""]'), "object[0] (alpha).prompts[0]", "non-empty"),
        (GOOD_A.replace('["an alpha"]', '"an alpha"'), "object[0] (alpha).prompts", "list"),
        (GOOD_A.replace('["first"]', "[3]"), "object[0] (alpha).synonyms[0]", "non-empty string"),
        (GOOD_A.replace('model = "alpha.glb"\n', ""), "object[0] (alpha).model", "missing"),
        (GOOD_A.replace("size =", "sizes ="), "object[0] (alpha).sizes", "unknown field"),
        (GOOD_A.replace('"alpha"', '"Alpha Class"', 1), "object[0].name", "snake_case"),
        (GOOD_A.replace('name = "alpha"\n', ""), "object[0].name", "snake_case"),
        (GOOD_A.replace("size = [0.5, 1.0, 0.4]", "size = [0.5, 1.0, 0.4]\nspread = [0.1, -0.1, 0.1]"),
         "object[0] (alpha).spread[1]", "within 0..2"),
        (GOOD_A.replace("size = [0.5, 1.0, 0.4]", "size = [0.5, 1.0, 0.4]\nspread = [0.1, 0.1]"),
         "object[0] (alpha).spread", "relative 1-sigma"),
        (GOOD_A.replace("size = [0.5, 1.0, 0.4]", "size = [0.5, 1.0, 0.4]\nspread = [0.1, nan, 0.1]"),
         "object[0] (alpha).spread[1]", "finite"),
        (GOOD_A.replace("size = [0.5, 1.0, 0.4]", 'size = [0.5, 1.0, 0.4]\non_floor = "yes"'),
         "object[0] (alpha).on_floor", "true or false"),
    ],
)
def test_validation_errors_name_the_entry_and_field(
    tmp_path: Path, body: str, field: str, message: str
) -> None:
    with pytest.raises(CatalogError) as info:
        Catalog.load(write_catalog(tmp_path, body))
    assert info.value.field == field
    assert str(info.value).startswith(field + ":")
    assert message in str(info.value)


@pytest.mark.parametrize(
    ("header", "body", "field", "message"),
    [
        ("", GOOD_A, "version", "missing"),
        ("version = 2\n", GOOD_A, "version", "newer"),
        ('version = "1"\n', GOOD_A, "version", "integer"),
        ("version = 1\n", "", "object", "at least one"),
        ("version = 1\nobjects = []\n", GOOD_A, "objects", "unknown top-level key"),
    ],
)
def test_top_level_validation(
    tmp_path: Path, header: str, body: str, field: str, message: str
) -> None:
    with pytest.raises(CatalogError) as info:
        Catalog.load(write_catalog(tmp_path, body, header=header))
    assert info.value.field == field
    assert message in str(info.value)


def test_invalid_toml_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(CatalogError, match="not valid TOML"):
        Catalog.load(write_catalog(tmp_path, "[[object]\nname = "))
    with pytest.raises(CatalogError, match="not found"):
        Catalog.load(tmp_path / "nope.toml")
