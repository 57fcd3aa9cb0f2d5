"""Wrong arrays and arguments raise a ValueError naming the argument, before anything is mapped."""

import numpy as np
import pytest

import dypho
from conftest import random_map

CAMERA = dypho.Camera(100.0, 100.0, 39.5, 29.5, 80, 60)


@pytest.fixture(scope="module")
def engine():
    return dypho.Engine(CAMERA, synchronous=True, track_when_no_pose=False, iterations_per_keyframe=0,
                        final_iterations=0)


RGB = np.zeros((60, 80, 3), np.uint8)
DEPTH = np.ones((60, 80), np.float32)
POSE = np.eye(4)


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        (dict(rgb=np.zeros((60, 80, 3), np.float32)), r"rgb must have dtype uint8, got float32 \(60, 80, 3\)"),
        (dict(rgb=np.zeros((60, 80), np.uint8)), r"rgb must have shape \(60, 80, 3\)"),
        (dict(rgb=np.zeros((80, 60, 3), np.uint8)), r"rgb must have shape \(60, 80, 3\).*got uint8 \(80, 60, 3\)"),
        (dict(rgb=np.zeros((60, 160, 3), np.uint8)[:, ::2]), r"rgb must be C-contiguous"),
        (dict(rgb=[[0, 0, 0]]), r"rgb must be a NumPy array"),
        (dict(depth=np.ones((60, 80), np.float64)), r"depth must be uint16 .* or float32 .*got float64"),
        (dict(depth=np.ones((60, 80), np.int32)), r"depth must be uint16"),
        (dict(depth=np.ones((60, 81), np.uint16)), r"depth must have shape \(60, 80\)"),
        (dict(depth=np.ones((80, 60), np.float32).T), r"depth must be C-contiguous"),
        (dict(mask=np.zeros((60, 80), np.int64)), r"mask must have dtype uint8"),
        (dict(mask=np.zeros((60, 80, 1), np.uint8)), r"mask must have shape \(60, 80\)"),
        (dict(pose=np.eye(3)), r"pose must have shape \(4, 4\)"),
        (dict(pose=np.eye(4, dtype=np.int64)), r"pose must be a float array"),
        (dict(pose=np.diag([1.0, 2.0, 1.0, 1.0])), r"pose: the upper-left 3x3 block is not a rotation"),
        (dict(pose=np.vstack([np.eye(4)[:3], [1.0, 0, 0, 1]])), r"pose: the last row"),
        (dict(pose=np.full((4, 4), np.nan)), r"pose holds a non-finite value"),
        (dict(pose=(np.zeros(4), np.zeros(3))), r"quaternion\) is zero"),
        (dict(pose=(np.ones(3), np.zeros(3))), r"pose\[0\] \(quaternion w x y z\) must have shape \(4,\)"),
        (dict(pose=(np.ones(4), np.zeros(3), 1)), r"pose must be a 4x4 array or a pair"),
        (dict(timestamp=float("nan")), r"timestamp must be finite"),
        (dict(angular_velocity=np.zeros(2)), r"angular_velocity must have shape \(3,\)"),
        (dict(depth_timestamp=1.5), r"depth_timestamp must be finite and within 0.1 s of timestamp"),
    ],
)
def test_push_frame_rejects_wrong_arrays(engine, kwargs, pattern):
    args = dict(rgb=RGB, depth=DEPTH, pose=POSE, mask=None, timestamp=1.0)
    args.update(kwargs)
    before = engine.status()["frames"]
    with pytest.raises(ValueError, match=pattern):
        engine.push_frame(**args)
    assert engine.status()["frames"] == before  # nothing was pushed


def test_good_arrays_of_every_accepted_kind(engine):
    depth16 = np.full((60, 80), 5000, np.uint16)
    mask = np.zeros((60, 80), bool)
    quaternion_pose = (np.array([1.0, 0, 0, 0], np.float32), np.zeros(3))
    for depth, pose in [(DEPTH, POSE), (depth16, quaternion_pose), (None, np.eye(4, dtype=np.float32).T)]:
        result = engine.push_frame(RGB, depth, pose=pose, mask=mask)
        assert result["has_pose"]


def test_other_arguments(engine):
    with pytest.raises(ValueError, match="camera must be a dypho.Camera"):
        engine.render("camera", POSE)
    with pytest.raises(ValueError, match="mode must be 'sorted' or 'oit'"):
        engine.render(CAMERA, POSE, mode="fast")
    with pytest.raises(ValueError, match="fx"):
        dypho.Camera(-1.0, 100.0, 39.5, 29.5, 80, 60)
    with pytest.raises(dypho.InvalidInput, match="unknown key 'mapper.lr_meanz'"):
        dypho.Engine(CAMERA, mapper__lr_meanz=1.0)
    with pytest.raises(dypho.InvalidInput, match="iterations_per_keyframe"):
        dypho.Engine(CAMERA, {"iterations_per_keyframe": -3})
    with pytest.raises(ValueError, match="options must be a dict"):
        dypho.Engine(CAMERA, [1, 2])
    with pytest.raises(ValueError, match="no pose given and EngineOptions.track_when_no_pose is off"):
        engine.push_frame(RGB, DEPTH)
    with pytest.raises(ValueError):
        engine.keyframe_pose(12345)


def test_map_dicts_are_checked(tmp_path):
    good = random_map(5, 4)
    for key, value, pattern in [
        ("means", good["means"].astype(np.float64), r"map\['means'\] must have dtype float32"),
        ("means", good["means"][:4], r"map\['means'\] must have shape \(5, 3\)"),
        ("quats", np.asfortranarray(np.zeros((5, 4), np.float32)), r"map\['quats'\] must be C-contiguous"),
        ("sh", np.zeros((5, 5, 3), np.float32), r"map\['sh'\] must have shape \(N, K, 3\) with K = 1, 4, 9 or 16"),
    ]:
        bad = dict(good)
        bad[key] = value
        with pytest.raises(ValueError, match=pattern):
            dypho.save_map(bad, tmp_path / "m.ply")
    bad = dict(good)
    del bad["log_scales"]
    with pytest.raises(ValueError, match="map has no 'log_scales' array"):
        dypho.render_map(bad, CAMERA, POSE)
    with pytest.raises(ValueError, match="map must be a dict"):
        dypho.save_map([1], tmp_path / "m.ply")
    with pytest.raises(ValueError, match="spz_version must be 2 or 3"):
        dypho.save_map(good, tmp_path / "m.spz", spz_version=1)
    with pytest.raises(dypho.InvalidInput, match="unknown map format"):
        dypho.save_map(good, tmp_path / "m.obj")
    assert not any(tmp_path.iterdir())  # nothing half-written
