"""Map files in every format from Python, render_map, trajectories, and ATE / RPE agreeing with `dypho eval`."""

import re

import numpy as np
import pytest

import dypho
from conftest import random_map, run_cli


def sigmoid(x):
    return 1 / (1 + np.exp(-x))


def test_save_and_load_every_format(workdir):
    m = random_map(300, 16, seed=1)
    for ext in ("ply", "splat", "spz", "glb", "gltf"):
        dypho.save_map(m, workdir / f"m.{ext}")
    ply = dypho.load_map(workdir / "m.ply")
    for key in m:
        np.testing.assert_array_equal(ply[key], m[key], err_msg=key)  # lossless
    for ext in ("glb", "gltf"):
        gl = dypho.load_map(workdir / f"m.{ext}")
        np.testing.assert_allclose(gl["means"], m["means"], atol=1e-6)
        np.testing.assert_allclose(gl["sh"], m["sh"], atol=1e-6)
    # .spz within its documented quantisation error (engine/export/spz.h).
    spz = dypho.load_map(workdir / "m.spz")
    assert spz["sh"].shape == (300, 16, 3)
    assert np.abs(spz["means"] - m["means"]).max() <= 2.0**-13 + 1e-6
    assert np.abs(spz["log_scales"] - m["log_scales"]).max() <= 1 / 32 + 1e-5
    assert np.abs(sigmoid(spz["opacity_logits"]) - sigmoid(m["opacity_logits"])).max() <= 0.5 / 255 + 1e-6
    assert np.abs(spz["sh"][:, 0] - m["sh"][:, 0]).max() <= 0.5 / (255 * 0.15) + 1e-5
    assert np.abs(spz["sh"][:, 1:4] - m["sh"][:, 1:4]).max() <= 1 / 32 + 1e-6
    assert np.abs(spz["sh"][:, 4:] - m["sh"][:, 4:]).max() <= 1 / 16 + 1e-6
    dypho.save_map(m, workdir / "v2.spz", spz_version=2)
    assert dypho.load_map(workdir / "v2.spz")["means"].shape == (300, 3)
    # .splat keeps the base colour only.
    assert dypho.load_map(workdir / "m.splat")["sh"].shape == (300, 1, 3)
    with pytest.raises(dypho.InvalidInput, match="no such file"):
        dypho.load_map(workdir / "missing.spz")


def test_render_map_matches_the_engine_renderer_and_the_spz_copy(workdir):
    camera = dypho.Camera(120.0, 120.0, 47.5, 35.5, 96, 72)
    m = random_map(2000, 4, seed=2)
    pose = np.eye(4)
    view = dypho.render_map(m, camera, pose)
    assert view["color"].shape == (72, 96, 3) and view["color"].dtype == np.float32
    assert view["alpha"].max() > 0.9
    covered = view["alpha"] > 0.5
    assert (view["depth"][covered] > 2).all() and (view["depth"][~covered] == 0).all()
    dypho.save_map(m, workdir / "m.spz")
    copy = dypho.render_map(dypho.load_map(workdir / "m.spz"), camera, pose)
    assert np.abs(copy["color"] - view["color"]).mean() < 0.01
    # The same pose as a (quaternion, translation) pair renders the same image.
    same = dypho.render_map(m, camera, (np.array([1.0, 0, 0, 0]), np.zeros(3)))
    np.testing.assert_array_equal(same["color"], view["color"])
    dc_only = dypho.render_map(m, camera, pose, sh_degree=0, background=(1, 1, 1), mode="oit")
    assert not np.array_equal(dc_only["color"], view["color"])


def cli_numbers(text):
    return {k: float(v) for k, v in re.findall(r"^(\S+) (-?[0-9.]+) (?:m|deg)$", text, re.M)}


def test_ate_and_rpe_agree_with_dypho_eval(synthetic, cli, workdir):
    times, poses = synthetic.ground_truth
    assert poses.shape == (len(times), 4, 4)
    rng = np.random.default_rng(3)
    noisy = poses.copy()
    noisy[:, :3, 3] += rng.normal(0, 0.01, (len(times), 3))
    angle = 0.02
    turn = np.eye(4)
    turn[:2, :2] = [[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]
    noisy = noisy @ turn
    dypho.write_trajectory(workdir / "est.txt", times + 0.001, noisy)
    t2, p2 = dypho.read_trajectory(workdir / "est.txt")
    np.testing.assert_allclose(p2, noisy, atol=1e-8)
    np.testing.assert_allclose(t2, times + 0.001, atol=1e-9)

    gt_path = synthetic.folder + "/groundtruth.txt"
    for scale in (False, True):
        args = ["eval", "--gt", gt_path, "--est", workdir / "est.txt", "--rpe-delta", "0.2"]
        printed = cli_numbers(run_cli(cli, *args, *(["--scale"] if scale else [])).stdout)
        a = dypho.ate(gt_path, workdir / "est.txt", scale=scale)
        r = dypho.rpe(gt_path, (t2, p2), delta=0.2, scale=a["scale"] if scale else 1.0)
        for name in ("rmse", "mean", "median", "std", "min", "max"):
            assert a[name] == pytest.approx(printed[f"absolute_translational_error.{name}"], abs=1e-6)
            assert r["translation"][name] == pytest.approx(printed[f"translational_error.{name}"], abs=1e-6)
            assert r["rotation"][name] == pytest.approx(printed[f"rotational_error.{name}"], abs=1e-6)
        assert a["count"] == len(times)
        assert a["rmse"] > 0.005
    # (N, 8) TUM rows give the same as the file.
    rows = np.loadtxt(gt_path, comments="#")
    assert dypho.ate(rows, workdir / "est.txt")["rmse"] == pytest.approx(dypho.ate(gt_path, workdir / "est.txt")["rmse"])
    with pytest.raises(dypho.InvalidInput):
        dypho.ate(gt_path, (times[:1] + 100, noisy[:1]))  # nothing matches
    with pytest.raises(ValueError, match="timestamps must increase"):
        dypho.ate(gt_path, (times[::-1], noisy))


def test_dataset_reader(synthetic):
    assert len(synthetic) == 16 and synthetic.format == "generic"
    assert "Camera" in repr(synthetic)
    frame = synthetic[3]
    assert frame.index == 3
    assert frame.rgb.shape == (120, 160, 3) and frame.rgb.dtype == np.uint8
    assert frame.depth.shape == (120, 160) and frame.depth.dtype == np.float32
    assert frame.mask.shape == (120, 160) and frame.mask.any()
    q, t = frame.pose
    assert q.shape == (4,) and t.shape == (3,)
    times, poses = synthetic.ground_truth
    np.testing.assert_allclose(dypho.pose_matrix(frame.pose), poses[3], atol=1e-9)
    assert synthetic[-1].index == 15
    with pytest.raises(IndexError):
        synthetic[16]
    assert [f.index for f in synthetic] == list(range(16))
    with pytest.raises(dypho.InvalidInput, match="no-such-folder"):
        dypho.open_dataset("no-such-folder")
