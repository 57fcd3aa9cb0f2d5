"""Shared fixtures of the dypho Python tests (run by CTest: see tools/python/CMakeLists.txt).

CTest sets PYTHONPATH to the built package and DYPHO_CLI, DYPHO_SHARED_DATA,
DYPHO_SOURCE_DIR and DYPHO_TEST_TMP; run by hand from the build folder:
``PYTHONPATH=build/tools/python DYPHO_CLI=build/tools/dypho python3 -m pytest tools/python/tests``.
"""

import os
import pathlib
import shutil
import subprocess

import numpy as np
import pytest

import dypho

SOURCE_DIR = pathlib.Path(os.environ.get("DYPHO_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[3]))
SHARED_DATA = pathlib.Path(os.environ.get("DYPHO_SHARED_DATA", SOURCE_DIR.parent / "shared" / "data"))


def in_ci() -> bool:
    return os.environ.get("CI", "") not in ("", "false")


@pytest.fixture
def cli() -> str:
    """The `dypho` program of the same build."""
    path = os.environ.get("DYPHO_CLI") or shutil.which("dypho")
    if not path:
        pytest.skip("DYPHO_CLI is not set (run the tests through ctest)")
    return path


@pytest.fixture
def shared_data() -> pathlib.Path:
    """../shared/data, required in CI, else the test skips."""
    if not (SHARED_DATA / "tum_fr1_rpy_head250").is_dir():
        if in_ci():
            pytest.fail(f"{SHARED_DATA} is missing (CI needs ../shared/data)")
        pytest.skip(f"{SHARED_DATA} is missing")
    return SHARED_DATA


@pytest.fixture
def workdir(request) -> pathlib.Path:
    """A fresh folder for the test under DYPHO_TEST_TMP (else pytest's tmp_path)."""
    root = os.environ.get("DYPHO_TEST_TMP")
    if not root:
        return request.getfixturevalue("tmp_path")
    path = pathlib.Path(root) / request.node.name
    shutil.rmtree(path, ignore_errors=True)
    path.mkdir(parents=True)
    return path


# Small, quick settings shared by the mapping tests (the synthetic sequence at 160x120).
QUICK = dict(
    iterations_per_keyframe=5,
    final_iterations=10,
    finish_seconds=0,
    mapper__num_threads=2,
    mapper__sh_degree=1,
    # Every frame that passes the motion/new-content test is a keyframe at
    # once (no sharpest-of-a-window wait), so tests can name their keyframes.
    keyframes__sharpness_window=1,
)


def run_cli(cli, *args, check=True, **kwargs):
    """Runs the dypho program; returns the CompletedProcess (stdout and stderr as text)."""
    env = dict(os.environ, OMP_WAIT_POLICY="passive")
    result = subprocess.run([cli, *map(str, args)], capture_output=True, text=True, env=env, **kwargs)
    if check and result.returncode != 0:
        raise AssertionError(f"dypho {' '.join(map(str, args))} failed ({result.returncode}):\n{result.stderr}")
    return result


@pytest.fixture(scope="session")
def synthetic(tmp_path_factory) -> dypho.Dataset:
    """The built-in synthetic dynamic sequence, 16 frames at 160x120 (written once per session)."""
    folder = tmp_path_factory.mktemp("synthetic") / "seq"
    return dypho.make_synthetic_sequence(folder, synth__frames=16, synth__width=160, synth__height=120)


@pytest.fixture(scope="session")
def static_synthetic(tmp_path_factory) -> dypho.Dataset:
    """The built-in synthetic sequence without walkers, 16 frames at 160x120."""
    folder = tmp_path_factory.mktemp("static") / "seq"
    return dypho.make_synthetic_sequence(folder, synth__frames=16, synth__width=160, synth__height=120,
                                         synth__num_walkers=0)


def random_map(n: int, k: int, seed: int = 0) -> dict:
    """A map dict with values in the ranges of a real map."""
    rng = np.random.default_rng(seed)
    sh = np.zeros((n, k, 3), np.float32)
    sh[:, 0] = rng.uniform(-1.5, 1.5, (n, 3))
    sh[:, 1:] = rng.uniform(-0.5, 0.5, (n, k - 1, 3))
    return {
        "means": rng.uniform(-1, 1, (n, 3)).astype(np.float32) + np.float32([0, 0, 3]),
        "log_scales": rng.uniform(-4.5, -2.5, (n, 3)).astype(np.float32),
        "quats": rng.normal(size=(n, 4)).astype(np.float32),
        "opacity_logits": rng.uniform(-2, 4, n).astype(np.float32),
        "sh": sh,
    }
