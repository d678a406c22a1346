"""The mapper end to end: rendered boxes with known 3D centres, through a mount and a yawed robot pose."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any, Sequence

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pipeline.catalog import Catalog, CatalogEntry
from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.models.ground_truth import GroundTruthBundle, GroundTruthDepth, GroundTruthDetector, GroundTruthSegmenter
from pipeline.mapper import Mapper, MapperConfig, MapperError, prompts_from_words
from pipeline.models.base import DepthMap, ModelError

SHARED = Path(__file__).resolve().parents[2].parent / "shared"

INTR = Intrinsics(260.0, 260.0, 160.0, 120.0, 320, 240)
MOUNT = CameraMount(position=(0.1, 0.0, 1.0), pitch=math.radians(15.0))
ROBOT = Pose.from_xyz_yaw(2.0, 1.0, 0.0, math.pi / 2)  # facing world +y

# (label, centre in world [m], size (w, h, l) [m], yaw of the length axis in world [rad])
OBJECTS = [
    ("crate", (2.3, 5.0, 0.5), (0.8, 1.0, 0.6), 0.3),
    ("barrel", (1.0, 4.0, 0.45), (0.6, 0.9, 0.6), 0.0),
    ("rock", (3.0, 3.5, 0.2), (0.5, 0.4, 0.5), 0.0),
]


def make_catalog(sizes: dict[str, tuple[float, float, float] | None]) -> Catalog:
    return Catalog(
        CatalogEntry(name, (f"a {name}",), (), size, f"{name}.glb", (200, 100, 50)) for name, size in sizes.items()
    )


CATALOG = make_catalog({"crate": (0.8, 1.0, 0.6), "barrel": (0.6, 0.9, 0.6), "rock": None})


def render(objects: Sequence[tuple[str, Sequence[float], Sequence[float], float]], intr: Intrinsics,
           world_from_cam: Pose) -> dict[str, Any]:
    """Ray-cast oriented boxes: RGB image, per-object masks and 2D boxes, metric depth (camera z) [m]."""
    cam_from_world = world_from_cam.inverse()
    u, v = np.meshgrid(np.arange(intr.width) + 0.5, np.arange(intr.height) + 0.5)
    rays = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones_like(u)], axis=-1)  # z = 1
    depth = np.full(u.shape, np.inf)
    owner = np.full(u.shape, -1)
    for k, (_, c_world, size, yaw) in enumerate(objects):
        w, h, l = size
        # object axes (length, width, up) in the world, then in the camera frame
        R = Rotation.from_euler("z", yaw).as_matrix()
        axes_cam = cam_from_world.rotation.as_matrix() @ R  # columns
        c_cam = cam_from_world.apply(c_world)
        half = np.array([l, w, h]) / 2
        d_loc = rays @ axes_cam  # ray direction in the object frame
        o_loc = -(axes_cam.T @ c_cam)  # camera origin in the object frame
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-half - o_loc) / d_loc
            t2 = (half - o_loc) / d_loc
        t_near = np.nanmax(np.minimum(t1, t2), axis=-1)
        t_far = np.nanmin(np.maximum(t1, t2), axis=-1)
        hit = (t_near <= t_far) & (t_near > 0) & (t_near < depth)
        depth[hit] = t_near[hit]  # rays have z = 1: t is the depth
        owner[hit] = k
    image = np.full((intr.height, intr.width, 3), 90, dtype=np.uint8)
    masks, boxes = [], []
    for k in range(len(objects)):
        m = owner == k
        image[m] = (60 + 60 * k, 200 - 50 * k, 120)
        ys, xs = np.nonzero(m)
        masks.append(m)
        boxes.append((float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1)))
    depth[~np.isfinite(depth)] = 0.0
    return {"image": image, "masks": masks, "boxes": boxes, "depth": depth.astype(np.float32),
            "labels": [o[0] for o in objects]}


WORLD_FROM_CAM = camera_pose_in_world(ROBOT, MOUNT)
SCENE = render(OBJECTS, INTR, WORLD_FROM_CAM)


def gt_bundle(depth: Any = None) -> GroundTruthBundle:
    return GroundTruthBundle(
        GroundTruthDetector(SCENE["boxes"], SCENE["labels"]),
        GroundTruthSegmenter(SCENE["masks"]),
        GroundTruthDepth(SCENE["depth"]) if depth is None else depth,
    )


class MetricModelDepth:
    """A metric depth *model* (not exact): the same map, but the mapper may rescale and fuse it."""

    name = "stub metric depth"
    kind = "metric"

    def estimate(self, image_rgb: np.ndarray) -> DepthMap:
        return DepthMap(SCENE["depth"].astype(np.float32), "metric")


class InverseDepth:
    """A relative-inverse-depth model: disparity = 2 / z + 0.1 where something was hit."""

    name = "stub inverse depth"
    kind = "inverse_relative"

    def estimate(self, image_rgb: np.ndarray) -> DepthMap:
        z = SCENE["depth"]
        return DepthMap(np.where(z > 0, 2.0 / np.maximum(z, 1e-6) + 0.1, 0.0).astype(np.float32), "inverse_relative")


def _by_label(scene: Any) -> dict[str, Any]:
    return {o.label: o for o in scene.objects}


@pytest.mark.parametrize("placement", ["box_fit", "ray"])
def test_objects_land_at_their_world_positions(placement: str) -> None:
    with Mapper(gt_bundle(MetricModelDepth()), CATALOG, MapperConfig(placement=placement, segment="all")) as mapper:
        result = mapper.run(SCENE["image"], INTR, MOUNT, ROBOT, capture_id="cap-1")
    scene = result.scene
    objs = _by_label(scene)
    assert set(objs) == {"crate", "barrel", "rock"}
    cam = np.array(WORLD_FROM_CAM.translation)
    for label, centre, size, _ in OBJECTS:
        o = objs[label]
        # unknown size: the depth of its visible surface plus half its measured width, shape unknown
        tol = 0.1 if label == "rock" else 0.05 if placement == "box_fit" else 0.12
        err = np.linalg.norm(np.array(o.position) - centre) / np.linalg.norm(np.array(centre) - cam)
        assert err < tol, (label, o.position, centre)
        assert o.frame == "world" and o.source.capture == "cap-1"
        # the camera and robot frame positions are the same point
        assert np.allclose(WORLD_FROM_CAM.apply(o.source.positions["camera"]), o.position, atol=1e-6)
        assert np.allclose(ROBOT.apply(o.source.positions["robot"]), o.position, atol=1e-6)
        assert o.source.distances["fused"] == pytest.approx(o.source.positions["camera"][2])
    assert objs["crate"].size == (0.8, 1.0, 0.6) and objs["crate"].size_known
    assert objs["crate"].source.method == "fused"
    # the rock (unknown size) stands on the floor: depth and its floor contact, fused
    assert objs["rock"].source.method == "fused" and not objs["rock"].size_known
    rock = next(o for o in result.objects if o.detection.label == "rock")
    assert {c.name for c in rock.cues} == {"ground_contact", "depth"}
    assert objs["rock"].source.distances["geometric"] is None
    assert 0.3 < objs["rock"].size[0] < 0.9  # measured from the mask at its depth
    assert objs["barrel"].source.mask_area == int(SCENE["masks"][1].sum())
    cap = scene.captures[0]
    assert {"detect", "depth", "segment", "distance", "total"} <= set(cap.timings)
    assert all(v >= 0 for v in cap.timings.values())
    assert cap.models["detector"].startswith("ground-truth perception")
    assert np.allclose(cap.camera_position, WORLD_FROM_CAM.translation)


@pytest.mark.parametrize("untrusted", [False, True])
def test_objects_face_the_camera_without_yaw_from_depth(untrusted: bool) -> None:
    """Exact depth with ``yaw_from_depth=False``, or by default an untrusted metric depth model."""
    if untrusted:
        bundle, config = gt_bundle(MetricModelDepth()), MapperConfig()
    else:
        bundle, config = gt_bundle(), MapperConfig(yaw_from_depth=False)
    with Mapper(bundle, CATALOG, config) as mapper:
        scene = mapper.map_image(SCENE["image"], INTR, MOUNT, ROBOT)
    cam = np.array(WORLD_FROM_CAM.translation)
    for o in scene.objects:
        to_camera = cam[:2] - np.array(o.position[:2])
        assert o.yaw == pytest.approx(math.atan2(to_camera[1], to_camera[0]), abs=1e-6)


def test_relative_inverse_depth_becomes_metric_from_the_known_objects() -> None:
    with Mapper(gt_bundle(InverseDepth()), CATALOG) as mapper:
        result = mapper.run(SCENE["image"], INTR, MOUNT, ROBOT)
    assert result.depth_scale is not None and result.depth_scale.kind == "inverse_relative"
    assert result.depth_scale.n_refs == 2
    rock = _by_label(result.scene)["rock"]
    cam = np.array(WORLD_FROM_CAM.translation)
    centre = np.array(OBJECTS[2][1])
    assert np.linalg.norm(np.array(rock.position) - centre) / np.linalg.norm(centre - cam) < 0.1


def test_relative_depth_without_reference_objects_places_nothing() -> None:
    only_rock = GroundTruthBundle(GroundTruthDetector([SCENE["boxes"][2]], ["rock"]), None, InverseDepth())
    with Mapper(only_rock, CATALOG, MapperConfig(ground_contact=False)) as mapper:
        result = mapper.run(SCENE["image"], INTR, MOUNT, ROBOT)
    assert result.scene.objects == ()
    assert result.objects[0].skipped and "no distance" in result.objects[0].skipped
    # with the camera height known, the rock standing on the floor is placed from its floor contact
    with Mapper(only_rock, CATALOG) as mapper:
        result = mapper.run(SCENE["image"], INTR, MOUNT, ROBOT)
    (rock,) = result.scene.objects
    assert rock.source.method == "ground_contact"
    true = np.array(OBJECTS[2][1])
    assert np.linalg.norm(np.array(rock.position) - true) < 0.1 * np.linalg.norm(true - WORLD_FROM_CAM.translation)
    assert rock.sigma is not None and rock.sigma > 0


def test_segment_auto_runs_the_segmenter_only_for_objects_that_need_a_mask() -> None:
    assert MapperConfig().segment == "auto"  # the default
    with Mapper(gt_bundle(MetricModelDepth()), CATALOG, MapperConfig(segment="auto")) as mapper:
        result = mapper.run(SCENE["image"], INTR, MOUNT, ROBOT)
    masked = {o.detection.label for o in result.objects if o.mask is not None}
    assert masked == {"rock"}  # unknown size: its extent comes from the mask
    # exact depth (a simulator's ground truth): every known-size object's yaw is fitted to its mask's depth points
    with Mapper(gt_bundle(), CATALOG, MapperConfig(segment="auto")) as mapper:
        result = mapper.run(SCENE["image"], INTR, MOUNT, ROBOT)
    assert {o.detection.label for o in result.objects if o.mask is not None} == {"rock", "crate", "barrel"}


def test_prompts_select_classes_and_free_words_become_classes() -> None:
    assert prompts_from_words(CATALOG, None) == [("a crate", "crate"), ("a barrel", "barrel"), ("a rock", "rock")]
    assert prompts_from_words(CATALOG, ["Barrel", "a red fire-extinguisher"]) == [
        ("Barrel", "barrel"), ("a red fire-extinguisher", "a_red_fire_extinguisher")]
    with Mapper(gt_bundle(), CATALOG) as mapper:
        scene = mapper.map_image(SCENE["image"], INTR, MOUNT, ROBOT, prompts=["barrel"])
    assert [o.label for o in scene.objects] == ["barrel"]


def test_one_object_called_two_names_is_kept_once() -> None:
    box = SCENE["boxes"][0]
    twice = GroundTruthBundle(GroundTruthDetector([box, box], ["barrel", "crate"], scores=[0.5, 0.9]))
    with Mapper(twice, CATALOG) as mapper:
        assert [o.label for o in mapper.map_image(SCENE["image"], INTR, MOUNT, ROBOT).objects] == ["crate"]
    with Mapper(twice, CATALOG, MapperConfig(same_object_iou=None)) as mapper:
        assert len(mapper.map_image(SCENE["image"], INTR, MOUNT, ROBOT).objects) == 2


# --- bad input -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("prompts, match", [([], "empty"), (["  "], "empty"), ([""], "empty")])
def test_empty_prompts_are_refused(prompts: list[str], match: str) -> None:
    with Mapper(gt_bundle(), CATALOG) as mapper, pytest.raises(MapperError, match=match):
        mapper.map_image(SCENE["image"], INTR, MOUNT, ROBOT, prompts=prompts)


def test_prompts_the_detector_cannot_find_are_refused() -> None:
    class ClosedDetector(GroundTruthDetector):
        def vocabulary(self, prompts: Any) -> frozenset[str]:
            return frozenset()

    bundle = GroundTruthBundle(ClosedDetector(SCENE["boxes"], SCENE["labels"]))
    with Mapper(bundle, CATALOG) as mapper, pytest.raises(MapperError, match="cannot find any"):
        mapper.map_image(SCENE["image"], INTR, MOUNT, ROBOT, prompts=["teapot"])


@pytest.mark.parametrize(
    "image, match",
    [
        (np.zeros((240, 320, 3), np.uint16), "dtype"),
        (np.zeros((240, 320, 3), np.float32), "dtype"),
        (np.zeros((8001, 8, 3), np.uint8), "8000"),
        (np.zeros((240, 320, 2), np.uint8), "shape"),
        (np.zeros((0, 320, 3), np.uint8), "empty"),
        ("photo.jpg", "numpy array"),
    ],
)
def test_bad_images_get_specific_errors(image: Any, match: str) -> None:
    with Mapper(gt_bundle(), CATALOG) as mapper, pytest.raises(MapperError, match=match):
        mapper.map_image(image, INTR, MOUNT, ROBOT)


def test_intrinsics_for_another_image_size_are_refused() -> None:
    with Mapper(gt_bundle(), CATALOG) as mapper, pytest.raises(MapperError, match="640x480"):
        mapper.map_image(SCENE["image"], INTR.scaled(640, 480), MOUNT, ROBOT)


def test_grayscale_and_rgba_images_are_converted() -> None:
    gray = cv2.cvtColor(SCENE["image"], cv2.COLOR_RGB2GRAY)
    rgba = np.dstack([SCENE["image"], np.full(gray.shape, 255, np.uint8)])
    with Mapper(gt_bundle(), CATALOG) as mapper:
        ref = mapper.map_image(SCENE["image"], INTR, MOUNT, ROBOT)
        for img in (gray, rgba):
            scene = mapper.map_image(img, INTR, MOUNT, ROBOT)
            assert [o.position for o in scene.objects] == [o.position for o in ref.objects]


def test_bad_configuration_is_refused() -> None:
    with pytest.raises(MapperError, match="weights"):
        MapperConfig(w_geometric=0.0, w_depth=0.0)
    with pytest.raises(MapperError, match="placement"):
        MapperConfig(placement="guess")  # type: ignore[arg-type]
    with pytest.raises(MapperError, match="segment"):
        MapperConfig(segment="some")  # type: ignore[arg-type]


# --- the CLI never leaves a partial scene file -----------------------------------------------------


def _cli(argv: list[str]) -> int:
    from console.cli.map_bench_cmd import add_map_parser

    parser = argparse.ArgumentParser(prog="morphonavi")
    add_map_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return int(args.func(args))


def _camera_toml(path: Path, fx: float = 260.0, cx: float = 160.0) -> Path:
    path.write_text(f"[intrinsics]\nfx = {fx}\nfy = 260.0\ncx = {cx}\ncy = 120.0\nwidth = 320\nheight = 240\n"
                    "[mount]\nposition = [0.1, 0.0, 1.0]\npitch_deg = 15.0\n", encoding="utf-8")
    return path


def test_cli_map_writes_a_scene_with_a_stub_model_set(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    import console.cli.map_bench_cmd as cc

    monkeypatch.setattr(cc, "load_mapping_models", lambda *a, **k: gt_bundle())
    monkeypatch.setattr(cc, "_catalog", lambda args: CATALOG)
    image = tmp_path / "photo.png"
    cv2.imwrite(str(image), SCENE["image"][:, :, ::-1])
    out = tmp_path / "scene.json"
    rc = _cli(["map", str(image), "--camera", str(_camera_toml(tmp_path / "cam.toml")), "--pose", "2,1,0,90",
               "--out", str(out), "--debug", str(tmp_path / "debug")])
    assert rc == 0, capsys.readouterr().err
    data = json.loads(out.read_text())
    assert {o["label"] for o in data["objects"]} == {"crate", "barrel", "rock"}
    crate = next(o for o in data["objects"] if o["label"] == "crate")
    assert np.linalg.norm(np.array(crate["position"]) - OBJECTS[0][1]) < 0.25
    assert sorted(p.name for p in (tmp_path / "debug").iterdir()) == ["depth.png", "detections.png", "masks.png"]


@pytest.mark.parametrize("case", ["corrupt image", "zero focal length", "principal point outside", "empty prompts",
                                  "detector fails"])
def test_cli_map_failures_leave_no_scene_file(case: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    import console.cli.map_bench_cmd as cc

    class FailingDetector(GroundTruthDetector):
        def detect(self, image_rgb: np.ndarray, prompts: Any) -> Any:
            raise ModelError("model 'stub': inference failed: out of memory")

    bundle = GroundTruthBundle(FailingDetector(SCENE["boxes"], SCENE["labels"])) if case == "detector fails" else gt_bundle()
    monkeypatch.setattr(cc, "load_mapping_models", lambda *a, **k: bundle)
    monkeypatch.setattr(cc, "_catalog", lambda args: CATALOG)
    image = tmp_path / "photo.png"
    cv2.imwrite(str(image), SCENE["image"][:, :, ::-1])
    camera = _camera_toml(tmp_path / "cam.toml")
    extra: list[str] = []
    if case == "corrupt image":
        image.write_bytes(b"\x89PNG\r\n\x1a\n not really a png")
    elif case == "zero focal length":
        camera = _camera_toml(tmp_path / "cam.toml", fx=0.0)
    elif case == "principal point outside":
        camera = _camera_toml(tmp_path / "cam.toml", cx=900.0)
    elif case == "empty prompts":
        extra = ["--prompts"]
    out = tmp_path / "scene.json"
    out.write_text("previous scene\n")
    rc = _cli(["map", str(image), "--camera", str(camera), "--out", str(out), *extra])
    err = capsys.readouterr().err
    assert rc == 2 and "morphonavi map: error:" in err
    assert out.read_text() == "previous scene\n"  # untouched
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".scene.json")] == []


# --- the real offline models on one dev photo --------------------------------------------------------


@pytest.mark.skipif(not (SHARED / "models" / "yolox_nano").is_dir() or not (SHARED / "bench" / "dev").is_dir(),
                    reason="needs ../shared/models (offline model set) and ../shared/bench/dev")
def test_offline_models_map_a_real_bedroom() -> None:
    from pipeline.bench.evaluate import load_dataset, mount_from_gravity
    from pipeline.mapper import load_mapping_models
    from pipeline.camera.image_io import load_image

    catalog = Catalog.load()
    sample = next(s for s in load_dataset(SHARED / "bench" / "dev", catalog) if s.id == "sunrgbd/000017")
    models = load_mapping_models("offline", SHARED / "models", catalog)
    with Mapper(models, catalog, MapperConfig(segment="all")) as mapper:  # every object through MobileSAM
        result = mapper.run(load_image(sample.image_path), sample.intrinsics, mount_from_gravity(sample.gravity_cam))
    scene = result.scene
    assert scene.objects, "no object found in a photo of a bed"
    for o in scene.objects:
        z = o.source.positions["camera"][2]
        assert 0.3 < z < 15.0 and o.label in catalog
        assert o.source.mask_area and o.source.mask_area > 0
    bed_gt = next(g for g in sample.objects if g.cls == "bed")
    beds = [o for o in scene.objects if o.label == "bed"]
    assert beds, [o.label for o in scene.objects]
    err = min(np.linalg.norm(np.array(b.source.positions["camera"]) - bed_gt.center_cam) for b in beds)
    assert err / np.linalg.norm(bed_gt.center_cam) < 0.35
    # the offline set adds the Open Images SSD (class-aware merge) when its files are present
    expected = "yolox_nano+oidv4_ssd (class-aware)" if (SHARED / "models" / "oidv4_ssd").is_dir() else "yolox_nano"
    assert scene.captures[0].models["detector"] == expected
    assert scene.captures[0].timings["segment_encoder"] > 0


# --- tiled detection -------------------------------------------------------------------------------


class ResolutionLimitedDetector:
    """Finds white blobs, but only those at least 10 px large once the image is shrunk to 100 px."""

    name = "stub blob detector"
    score_threshold = 0.5
    input_size = (100, 100)

    def vocabulary(self, prompts: Any) -> frozenset[str]:
        return frozenset(c for _, c in prompts)

    def detect(self, image_rgb: np.ndarray, prompts: Any) -> list[Any]:
        from pipeline.models.base import Detection

        r = min(100 / image_rgb.shape[0], 100 / image_rgb.shape[1])
        n, _, stats, _ = cv2.connectedComponentsWithStats((image_rgb[:, :, 0] == 255).astype(np.uint8))
        return [Detection((float(x), float(y), float(x + w), float(y + h)), 0.9, "crate", "a crate")
                for x, y, w, h, _ in stats[1:n] if max(w, h) * r >= 10]


def test_tiles_find_small_far_objects_once() -> None:
    from pipeline.models.tiled_detection import detect_tiled, tile_grid

    tiles = tile_grid(1000, 500, 150, overlap=0.2)
    covered = np.zeros((500, 1000), bool)
    for x0, y0, x1, y1 in tiles:
        assert x1 - x0 == 150 and y1 - y0 == 150 and 0 <= x0 and x1 <= 1000 and y1 <= 500
        covered[y0:y1, x0:x1] = True
    assert covered.all()
    image = np.zeros((500, 1000, 3), np.uint8)
    image[200:230, 610:640] = 255  # small: 3 px at the detector's scale
    image[20:480, 20:400] = 255  # large: spans many tiles
    det = ResolutionLimitedDetector()
    whole = det.detect(image, [("a crate", "crate")])
    assert [d.box for d in whole] == [(20.0, 20.0, 400.0, 480.0)]
    found = sorted(d.box for d in detect_tiled(det, image, [("a crate", "crate")], tile_px=150))
    assert found == [(20.0, 20.0, 400.0, 480.0), (610.0, 200.0, 640.0, 230.0)]
    # a photo no larger than 1.25 tiles is detected whole only
    assert len(detect_tiled(det, image[:150, :180], [("a crate", "crate")], tile_px=150)) == 1


# --- ground-truth perception ---------------------------------------------------------------------


def test_ground_truth_backends_serve_the_given_arrays() -> None:
    ids = np.zeros((40, 60), np.int32)
    ids[5:15, 10:30] = 3
    ids[20:35, 40:55] = 7
    seg = GroundTruthSegmenter(ids)
    image = np.zeros((40, 60, 3), np.uint8)
    seg.set_image(image)
    m = seg.segment_box((38.0, 19.0, 56.0, 36.0))
    assert m.area == 15 * 15 and m.values[25, 45] and not m.values[10, 20]
    assert seg.segment_box((0.0, 36.0, 5.0, 40.0)).area == 0  # nothing there
    with pytest.raises(ModelError, match="masks are"):
        seg.set_image(np.zeros((20, 20, 3), np.uint8))

    det = GroundTruthDetector([(-5, 5, 30, 15), (40, 20, 55, 35)], ["crate", "rock"], scores=[0.4, 0.9])
    found = det.detect(image, [("a crate", "crate"), ("a rock", "rock")])
    assert [(d.label, d.box) for d in found] == [("rock", (40.0, 20.0, 55.0, 35.0)), ("crate", (0.0, 5.0, 30.0, 15.0))]
    assert [d.label for d in det.detect(image, [("a crate", "crate")])] == ["crate"]
    with pytest.raises(ModelError, match="labels"):
        GroundTruthDetector([(0, 0, 1, 1)], [])

    depth = GroundTruthDepth(np.where(ids > 0, 2.0, np.nan))
    d = depth.estimate(image)
    assert d.kind == "metric" and d.values[10, 20] == 2.0 and d.values[0, 0] == 0.0
    assert depth.name.startswith("ground-truth perception")


def test_exact_depth_decides_and_is_not_rescaled() -> None:
    """Ground-truth depth (``exact = True``) places known-size objects by depth, unscaled."""
    with Mapper(gt_bundle(), CATALOG) as mapper:
        res = mapper.run(SCENE["image"], INTR, MOUNT, ROBOT, capture_id="cap-1")
    objs = _by_label(res.scene)
    assert objs["crate"].source.method == "depth"
    assert objs["crate"].source.distances["fused"] == pytest.approx(objs["crate"].source.distances["depth"])
    assert "exact depth" in " ".join(res.scene.captures[0].models.values())


def _yaw_error_mod_pi(a: float, b: float) -> float:
    d = (a - b) % math.pi
    return min(d, math.pi - d)


def test_exact_depth_gives_objects_their_yaw() -> None:
    """With exact depth the crate (yaw 0.3 rad, w 0.8 / l 0.6 m) gets its yaw from its depth points;
    without the option it faces the camera, about 70 degrees off."""
    crate_yaw = OBJECTS[0][3]
    with Mapper(gt_bundle(), CATALOG) as mapper:
        res = mapper.run(SCENE["image"], INTR, MOUNT, ROBOT, capture_id="cap-1")
    crate = _by_label(res.scene)["crate"]
    assert _yaw_error_mod_pi(crate.yaw, crate_yaw) < math.radians(3.0)
    with Mapper(gt_bundle(), CATALOG, MapperConfig(yaw_from_depth=False)) as mapper:
        off = _by_label(mapper.run(SCENE["image"], INTR, MOUNT, ROBOT, capture_id="cap-1").scene)["crate"]
    assert _yaw_error_mod_pi(off.yaw, crate_yaw) > math.radians(30.0)
    assert off.position == pytest.approx(crate.position)  # the yaw does not move the centre


def test_untrusted_metric_depth_keeps_objects_facing_the_camera() -> None:
    """A metric depth *model* with too few references to be trusted: no yaw from its points by
    default; forced on, it gives the crate's yaw too (the stub is exact)."""
    crate_yaw = OBJECTS[0][3]
    with Mapper(gt_bundle(MetricModelDepth()), CATALOG) as mapper:
        res = mapper.run(SCENE["image"], INTR, MOUNT, ROBOT, capture_id="cap-1")
    crate = _by_label(res.scene)["crate"]
    cam = np.asarray(WORLD_FROM_CAM.translation)
    to_cam = cam[:2] - np.asarray(crate.position[:2])
    assert crate.yaw == pytest.approx(math.atan2(to_cam[1], to_cam[0]), abs=1e-6)
    with Mapper(gt_bundle(MetricModelDepth()), CATALOG, MapperConfig(yaw_from_depth=True)) as mapper:
        forced = _by_label(mapper.run(SCENE["image"], INTR, MOUNT, ROBOT, capture_id="cap-1").scene)["crate"]
    assert _yaw_error_mod_pi(forced.yaw, crate_yaw) < math.radians(3.0)


def test_floor_contact_places_an_object_twice_its_catalog_height() -> None:
    """The issue's cabinets: a 'crate' 2.0 m tall where the catalog says 1.0 m, its top cut by the border.
    The size prior alone (from the width: yaw unknown, a wide sigma) puts it far off; the floor under its
    box bottom (camera 1 m up, 15 deg down) puts it right and dominates the fusion."""
    tall = [("crate", (2.0, 5.5, 1.0), (0.8, 2.0, 0.6), 0.0)]
    shot = render(tall, INTR, WORLD_FROM_CAM)
    bundle = GroundTruthBundle(GroundTruthDetector(shot["boxes"], shot["labels"]), None, None)
    true = np.array(tall[0][1])
    rng = np.linalg.norm(true - WORLD_FROM_CAM.translation)
    with Mapper(bundle, CATALOG, MapperConfig(ground_contact=False)) as mapper:
        (alone,) = mapper.run(shot["image"], INTR, MOUNT, ROBOT).scene.objects
    assert np.linalg.norm(np.array(alone.position) - true) / rng > 0.3
    with Mapper(bundle, CATALOG) as mapper:
        res = mapper.run(shot["image"], INTR, MOUNT, ROBOT)
    (obj,) = res.scene.objects
    assert np.linalg.norm(np.array(obj.position)[:2] - true[:2]) / rng < 0.08
    (mapped,) = res.objects
    assert mapped.cut_sides == ("top",) and obj.cut == ("top",)
    sp, gc = mapped.cue("size_prior"), mapped.cue("ground_contact")
    assert sp is not None and gc is not None and gc.sigma < sp.sigma
    assert abs(mapped.fusion.distance - gc.distance) < abs(mapped.fusion.distance - sp.distance)  # type: ignore[union-attr]
    assert obj.source.distances["ground_contact"] == pytest.approx(gc.distance)
    # the reported sigma covers the remaining error along the ray
    assert abs(float(mapped.center_cam[2]) - float(WORLD_FROM_CAM.inverse().apply(true)[2])) < 2 * mapped.sigma_z
