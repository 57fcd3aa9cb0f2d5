"""The Python example of README.md runs as written (extracted from the README)."""

import os
import pathlib
import re
import subprocess
import sys

import numpy as np

import dypho
from conftest import SOURCE_DIR


def readme_example() -> str:
    text = (SOURCE_DIR / "README.md").read_text()
    marker = text.index("<!-- python example: tools/python/tests/test_readme.py -->")
    block = re.search(r"```python\n(.*?)```", text[marker:], re.S)
    assert block, "no ```python block after the marker"
    return block.group(1)


def test_readme_example_runs_as_written(shared_data, workdir):
    code = readme_example()
    assert "../shared/data/tum_fr1_rpy_head250" in code
    # The example runs from the checkout root, beside ../shared.
    work = workdir / "checkout"
    work.mkdir()
    (workdir / "shared").symlink_to(shared_data.parent.resolve(), target_is_directory=True)
    env = dict(os.environ, OMP_WAIT_POLICY="passive")
    result = subprocess.run([sys.executable, "-c", code], cwd=work, capture_output=True, text=True, env=env,
                            timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    print(result.stdout)
    saved = dypho.load_map(work / "py_map" / "map.ply")
    assert saved["means"].shape[0] > 10000
    spz = dypho.load_map(work / "py_map" / "map.spz")
    assert spz["means"].shape == saved["means"].shape
    times, _ = dypho.read_trajectory(work / "py_map" / "keyframes.txt")
    assert len(times) >= 3
    view = np.load(work / "py_map" / "novel_view.npy")
    assert view.shape == (480, 640, 3) and view.mean() > 0.05
    assert "PSNR" in result.stdout
