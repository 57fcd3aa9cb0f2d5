"""dypho.run writes what `dypho run` writes (the same files, the same map and
trajectory in sequential mode), options read like --config / --set, and
Ctrl-C stops a long run cleanly with its outputs written."""

import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import dypho
from conftest import QUICK, run_cli

RUN = dict(QUICK, poses="gt", eval_every=10, keyframe_renders=2, overlay_every=8)


def test_run_gives_the_outputs_of_dypho_run(synthetic, cli, workdir):
    sets = [f"--set={k.replace('__', '.')}={dypho._option_text(k, v)}" for k, v in RUN.items()]
    run_cli(cli, "run", synthetic.folder, "--out", workdir / "cli", "--sequential", *sets)
    result = dypho.run(synthetic.folder, workdir / "py", sequential=True, progress=False, **RUN)

    def files(root):
        return sorted(str(p.relative_to(root)) for p in pathlib.Path(root).rglob("*") if p.is_file())

    assert files(workdir / "py") == files(workdir / "cli")
    for name in ("map.ply", "map.spz", "map.splat", "map.glb", "trajectory.txt", "keyframes.txt", "options.yaml"):
        assert (workdir / "py" / name).read_bytes() == (workdir / "cli" / name).read_bytes(), name
    metrics = json.loads((workdir / "cli" / "metrics.json").read_text())
    assert result["frames"] == len(synthetic) == result["tracked"]
    assert result["num_gaussians"] == dypho.load_map(workdir / "py" / "map.ply")["means"].shape[0]
    assert result["ate_rmse"] == pytest.approx(0.0, abs=1e-6)  # ground-truth poses
    assert result["psnr"] > 15
    assert result["report_path"].endswith("report.md")
    times, poses = result["trajectory"]
    assert len(times) == len(synthetic) and poses.shape == (len(synthetic), 4, 4)
    mine = json.loads((workdir / "py" / "metrics.json").read_text())
    for key in ("dataset", "tracked", "ate_rmse_m", "depth_l1_m"):
        assert mine[key] == metrics[key], key
    assert mine["tracked"] == result["tracked"]


def test_options_are_read_like_config_and_set(workdir):
    config = workdir / "options.yaml"
    config.write_text("preset: tum\nmapper:\n  lr_means: 0.0003\nkeyframes.max_frame_gap: 7\n")
    o = dypho.options(config=config, values={"mapper": {"sh_degree": 2}}, iterations_per_keyframe=12,
                      masking__flow__scale=0.5, disable=["refine"])
    assert o.preset == "tum"
    assert float(o.get("mapper.lr_means")) == pytest.approx(3e-4)
    assert o.get("keyframes.max_frame_gap") == "7"
    assert o.get("mapper.sh_degree") == "2"
    assert o.get("iterations_per_keyframe") == "12"
    assert float(o.get("masking.flow.scale")) == 0.5
    assert o.get("masking.use_background") == "false"
    # An explicit preset wins over the file's; the file's other keys stay.
    o = dypho.options(config=config, preset="bonn")
    assert o.preset == "bonn" and o.get("keyframes.max_frame_gap") == "7"
    # Options as an object, with keyword options on top.
    base = dypho.options(iterations_per_keyframe=3)
    again = dypho.options(base=base, final_iterations=9)
    assert again.get("iterations_per_keyframe") == "3" and again.get("final_iterations") == "9"
    assert base.get("final_iterations") != "9"  # the base is not changed
    assert "mapper.lr_means" in o.keys() and "mapper:" in o.format()
    with pytest.raises(dypho.InvalidInput, match="unknown key 'masking.flow.scael'"):
        dypho.options(masking__flow__scael=0.5)
    with pytest.raises(dypho.InvalidInput, match="out of range|must be"):
        dypho.options(values={"masking": {"flow": {"scale": 7}}})
    with pytest.raises(dypho.InvalidInput, match="--disable"):
        dypho.options(disable="everything")
    with pytest.raises(ValueError, match="out"):
        dypho.run(None)


SCRIPT = """
import sys, dypho
try:
    dypho.run(None, sys.argv[1], progress=False, sequential=True, synth__frames=150, synth__width=160,
              synth__height=120, overlay_every=2, iterations_per_keyframe=20, final_iterations=10, finish_seconds=0)
except KeyboardInterrupt as e:
    print("KeyboardInterrupt:", e)
    sys.exit(130)
print("finished")
"""


def test_ctrl_c_stops_a_long_run_cleanly(workdir):
    out = workdir / "out"
    env = dict(os.environ, OMP_WAIT_POLICY="passive")
    process = subprocess.Popen([sys.executable, "-c", SCRIPT, str(out)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline = time.time() + 240
        while time.time() < deadline and process.poll() is None:
            overlays = list((out / "overlays").glob("*.jpg")) if (out / "overlays").is_dir() else []
            if len(overlays) >= 3:  # a few frames processed
                break
            time.sleep(0.2)
        assert process.poll() is None, process.communicate()
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=240)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130, stdout + stderr
    assert "KeyboardInterrupt: dypho.run interrupted after" in stdout
    assert "interrupted; writing the outputs" in stderr
    times, _ = dypho.read_trajectory(out / "trajectory.txt")
    assert 3 <= len(times) < 150
    for name in ("map.ply", "map.spz", "keyframes.txt", "report.md", "metrics.json"):
        assert (out / name).is_file(), name
    assert dypho.load_map(out / "map.ply")["means"].shape[0] > 0
    assert not list(out.glob("*.tmp*"))  # nothing half-written
