"""dypho.Engine: mapping the built-in synthetic sequence from Python gives the
map the C++ system gives for the same options; rendering, keyframe pose
corrections, status, saving; the GIL is released while the engine works."""

import os
import pathlib
import signal
import subprocess
import sys
import threading
import time

import pathlib

import numpy as np
import pytest

import dypho
from conftest import QUICK, run_cli

# `dypho run` with ground-truth poses and no masking pushes every frame's RGB,
# depth and pose to the engine and nothing else (no tracker features), so a
# Python loop that pushes the same frames must give the same map, bit for bit.
SAME = dict(QUICK, keyframes__min_new_content=0, keyframes__max_translation=0.04, mapper__train_downscale=1, iterations_per_keyframe=10, poses="gt", map_features=False, eval_every=40, keyframe_renders=0, overlay_every=0,
            write_splat=False, write_glb=False, write_spz=False)


def test_engine_map_is_identical_to_the_cpp_system(static_synthetic, cli, workdir):
    synthetic = static_synthetic  # no walkers: masking is off in both
    sets = [f"--set={k.replace('__', '.')}={dypho._option_text(k, v)}" for k, v in SAME.items()]
    run_cli(cli, "run", synthetic.folder, "--out", workdir / "cpp", "--sequential", "--disable", "masking", *sets)
    cpp = dypho.load_map(workdir / "cpp" / "map.ply")

    options = {k: v for k, v in SAME.items()}
    engine = dypho.Engine(synthetic.camera, synchronous=True, track_when_no_pose=False, disable="masking", **options)
    keyframes = []
    for frame in synthetic:
        result = engine.push_frame(frame.rgb, frame.depth, pose=frame.pose, timestamp=frame.timestamp,
                                   depth_timestamp=frame.depth_timestamp)
        assert result["has_pose"]
        np.testing.assert_allclose(result["pose"], dypho.pose_matrix(frame.pose), atol=1e-12)
        if result["keyframe"]:
            keyframes.append(result["keyframe_id"])
    assert keyframes == list(range(len(keyframes))) and len(keyframes) >= 3
    assert engine.finish() == 10
    mine = engine.map()
    assert mine["means"].shape[0] > 1000
    for key in ("means", "log_scales", "quats", "opacity_logits", "sh"):
        assert mine[key].dtype == np.float32
        np.testing.assert_array_equal(mine[key], cpp[key], err_msg=key)
    status = engine.status()
    assert status["frames"] == len(synthetic)
    assert status["keyframes"] == status["mapped_keyframes"] == len(keyframes)
    assert status["iterations"] == 10 * len(keyframes) + 10
    assert status["num_gaussians"] == mine["means"].shape[0]

    # The C++ keyframe poses are the ones the engine holds.
    times, poses = dypho.read_trajectory(workdir / "cpp" / "keyframes.txt")
    assert len(times) == len(keyframes)
    for i in keyframes:
        np.testing.assert_allclose(engine.keyframe_pose(i), poses[i], atol=1e-8)

    # A render at a frame between keyframes looks like the frame.
    frame = synthetic[7]
    view = engine.render(synthetic.camera, frame.pose)
    assert view["color"].shape == (120, 160, 3) and view["depth"].shape == (120, 160)
    static = view["alpha"] > 0.5
    image = frame.rgb / 255.0
    error = np.abs(np.clip(view["color"], 0, 1) - image)[static].mean()
    flat = np.abs(image[static].mean(axis=0) - image)[static].mean()  # the frame's mean colour everywhere
    assert error < 0.6 * flat, (error, flat)
    depth_error = np.abs(view["depth"] - frame.depth)[static & (frame.depth > 0)].mean()
    assert depth_error < 0.1, depth_error
    oit = engine.render(synthetic.camera, dypho.pose_matrix(frame.pose), mode="oit")
    assert not np.array_equal(oit["color"], view["color"])

    engine.save(workdir / "saved")
    saved = dypho.load_map(workdir / "saved" / "map.ply")
    np.testing.assert_array_equal(saved["means"], mine["means"])
    # The mapped keyframes: what save wrote to keyframes.txt, in mapping order.
    times, poses = engine.mapped_keyframes()
    assert poses.shape == (len(keyframes), 4, 4)
    saved_times, saved_poses = dypho.read_trajectory(workdir / "saved" / "keyframes.txt")
    np.testing.assert_allclose(times, saved_times, atol=1e-6)
    np.testing.assert_allclose(poses, saved_poses, atol=1e-8)
    for i in keyframes:
        np.testing.assert_allclose(poses[i], engine.keyframe_pose(i), atol=1e-12)


def test_update_keyframe_pose_moves_its_gaussians(synthetic):
    engine = dypho.Engine(synthetic.camera, synchronous=True, track_when_no_pose=False,
                          **dict(QUICK, iterations_per_keyframe=0))
    for frame in list(synthetic)[:6]:
        engine.push_frame(frame.rgb, frame.depth, pose=frame.pose, timestamp=frame.timestamp)
    before = engine.map()["means"]
    pose = engine.keyframe_pose(0)
    moved = pose.copy()
    moved[:3, 3] += [0.1, 0.0, 0.0]
    engine.update_keyframe_pose(0, moved)
    np.testing.assert_allclose(engine.keyframe_pose(0), moved, atol=1e-9)
    after = engine.map()["means"]
    shift = after - before
    moved_rows = np.abs(shift).max(axis=1) > 1e-6
    assert moved_rows.any()
    np.testing.assert_allclose(shift[moved_rows], np.tile([0.1, 0, 0], (moved_rows.sum(), 1)), atol=1e-5)


def _read_dense_ply(path):
    data = pathlib.Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    assert "property float nx" in header
    n = int(header.split("element vertex ")[1].split()[0])
    rows = np.frombuffer(data[end:], dtype=np.dtype([("xyz", "<f4", 3), ("n", "<f4", 3), ("rgb", "u1", 3)]), count=n)
    return rows["xyz"]


def test_save_dense_cloud_follows_keyframe_pose_updates(synthetic, workdir):
    engine = dypho.Engine(synthetic.camera, synchronous=True, track_when_no_pose=False,
                          **dict(QUICK, iterations_per_keyframe=0))
    frame = list(synthetic)[0]  # one keyframe: all of the dense map is its points
    engine.push_frame(frame.rgb, frame.depth, pose=frame.pose, timestamp=frame.timestamp)
    engine.save_dense_cloud(workdir / "before.ply")
    before = _read_dense_ply(workdir / "before.ply")
    assert len(before) > 500
    moved = engine.keyframe_pose(0).copy()
    moved[:3, 3] += [1.0, 0.0, 0.0]  # 50 cells of 2 cm along x
    engine.update_keyframe_pose(0, moved)
    engine.save_dense_cloud(workdir / "after.ply")
    after = _read_dense_ply(workdir / "after.ply")
    assert abs(len(after) - len(before)) <= 0.01 * len(before)
    np.testing.assert_allclose(after.mean(axis=0) - before.mean(axis=0), [1.0, 0.0, 0.0], atol=0.01)


def test_the_gil_is_released_while_mapping_and_rendering(synthetic):
    engine = dypho.Engine(synthetic.camera, synchronous=True, track_when_no_pose=False,
                          **dict(QUICK, iterations_per_keyframe=40))
    frames = list(synthetic)[:3]
    counter = [0]
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            counter[0] += 1

    worker = threading.Thread(target=spin)
    worker.start()
    try:
        during = []
        for frame in frames:
            start = counter[0]
            result = engine.push_frame(frame.rgb, frame.depth, pose=frame.pose, timestamp=frame.timestamp)
            if result["keyframe"]:
                during.append(counter[0] - start)
        # Python bytecode of the other thread ran while the first keyframe
        # was mapped: with the GIL held it could not have run at all.
        assert during and during[0] > 0
    finally:
        stop.set()
        worker.join()

    # One thread renders while another pushes frames (threaded engine).
    engine = dypho.Engine(synthetic.camera, track_when_no_pose=False, **QUICK)
    first = synthetic[0]
    engine.push_frame(first.rgb, first.depth, pose=first.pose, timestamp=first.timestamp)
    engine.wait_until_idle()
    renders = []
    done = threading.Event()

    def render_loop():
        while not done.is_set():
            renders.append(engine.render(synthetic.camera, first.pose)["alpha"].mean())

    renderer = threading.Thread(target=render_loop)
    renderer.start()
    try:
        for frame in list(synthetic)[1:8]:
            engine.push_frame(frame.rgb, frame.depth, pose=frame.pose, timestamp=frame.timestamp)
        engine.wait_until_idle()
        time.sleep(0.05)
    finally:
        done.set()
        renderer.join()
    assert len(renders) >= 1 and renders[-1] > 0.5
    assert engine.status()["frames"] == 8


def test_finish_reports_progress_and_respects_its_time_budget(synthetic):
    engine = dypho.Engine(synthetic.camera, synchronous=True, track_when_no_pose=False, final_seconds=0.3,
                          **dict(QUICK, iterations_per_keyframe=0, final_iterations=100000))
    frame = synthetic[0]
    engine.push_frame(frame.rgb, frame.depth, pose=frame.pose, timestamp=0.0)
    calls = []
    steps = engine.finish(progress=lambda done, planned: calls.append((done, planned)))
    assert 0 < steps < 100000
    assert calls and calls[-1] == (steps, 100000)
    # An exception in the progress callback stops the refinement and propagates.
    engine = dypho.Engine(synthetic.camera, synchronous=True, track_when_no_pose=False,
                          **dict(QUICK, iterations_per_keyframe=0, final_iterations=1000))
    engine.push_frame(frame.rgb, frame.depth, pose=frame.pose, timestamp=0.0)

    def stop(done, planned):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        engine.finish(progress=stop)
    assert engine.status()["iterations"] == 10  # one chunk of steps, then the callback stopped it


def test_orb_tracking_when_no_pose_is_given(synthetic):
    # Without a pose the engine's ORB tracker gives one (its accuracy is tested in C++).
    engine = dypho.Engine(synthetic.camera, synchronous=True, **dict(QUICK, iterations_per_keyframe=2))
    results = [engine.push_frame(f.rgb, f.depth, mask=f.mask > 0, timestamp=f.timestamp) for f in list(synthetic)[:6]]
    tracked = [r for r in results if r["has_pose"]]
    assert len(tracked) >= 4
    for r in tracked:
        rotation = r["pose"][:3, :3]
        np.testing.assert_allclose(rotation.T @ rotation, np.eye(3), atol=1e-9)
    lost = [r for r in results if not r["has_pose"]]
    assert all(r["message"].startswith("tracker: ") and r["pose"] is None for r in lost)
    assert results[0]["keyframe"] and engine.status()["mapped_keyframes"] >= 1


FINISH_SCRIPT = """
import sys, dypho
seq = dypho.make_synthetic_sequence(sys.argv[1], synth__frames=2, synth__width=96, synth__height=72)
engine = dypho.Engine(seq.camera, synchronous=True, track_when_no_pose=False, iterations_per_keyframe=0,
                      final_iterations=1000000, mapper__num_threads=1)
frame = seq[0]
engine.push_frame(frame.rgb, frame.depth, pose=frame.pose, timestamp=0.0)
print("ready", flush=True)
try:
    engine.finish()
except KeyboardInterrupt:
    steps = engine.status()["iterations"]
    print("interrupted after", steps, "steps; map of", engine.map()["means"].shape[0], "Gaussians", flush=True)
    sys.exit(130)
"""


def test_ctrl_c_stops_finish_between_steps(workdir):
    env = dict(os.environ, OMP_WAIT_POLICY="passive")
    process = subprocess.Popen([sys.executable, "-c", FINISH_SCRIPT, str(workdir / "seq")], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert process.stdout.readline().strip() == "ready"
        time.sleep(1.0)
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130, stdout + stderr
    steps = int(stdout.split("interrupted after ")[1].split()[0])
    assert 0 < steps < 1000000 and steps % 10 == 0  # stopped between chunks of 10 steps
