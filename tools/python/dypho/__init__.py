"""dypho from Python: RGB-D SLAM that keeps moving people out of a 3D Gaussian map.

The module wraps dypho's C++ library (the embedding API of engine/api.h, the
whole system of ``dypho run``, map files, rendering, datasets and trajectory
metrics) with NumPy arrays in and out.

Conventions used everywhere:

* Images are C-contiguous NumPy arrays: RGB ``uint8`` (H, W, 3); depth
  ``uint16`` (units of ``depth_scale``, 5000 per metre as in TUM) or
  ``float32`` metres (H, W), 0 = no depth; dynamic masks ``uint8`` or
  ``bool`` (H, W), non-zero = moving (kept out of the map). A wrong dtype,
  shape or memory layout raises ``ValueError`` naming the argument.
* A pose is ``world_from_cam`` (camera to world; its translation is the
  camera centre), the convention of TUM ``groundtruth.txt``: a 4x4 float
  array, or a pair ``(quaternion (w, x, y, z), translation (x, y, z))``.
  Poses come back as 4x4 ``float64`` arrays; dataset frames give the pair,
  which goes back to C++ bit for bit. The camera frame is x right, y down,
  z forward (OpenCV).
* A map is a dict of ``float32`` arrays: ``means`` (N, 3) [m],
  ``log_scales`` (N, 3) [log m], ``quats`` (N, 4) w x y z, ``opacity_logits``
  (N,), ``sh`` (N, K, 3) with K = 1, 4, 9 or 16 SH coefficients per channel.
* Options are the keys of ``dypho run --print-config``: give them as a dict
  (nested or dotted keys, like a ``--config`` file), a ``config=`` file, or
  keyword arguments with ``__`` for the dots (``mapper__lr_means=1e-4``).
  Unknown keys and values out of range raise ``dypho.InvalidInput`` (a
  ``ValueError``) naming the key.
* Library errors (a missing file, a corrupt map, a bad option) raise
  ``dypho.InvalidInput``, a subclass of ``ValueError``.

The GIL is released while frames are copied and mapped, views rendered, maps
read and written and datasets decoded, so one Python thread can push frames
while another renders.
"""

import json
import os
from dataclasses import dataclass
from typing import Any, Dict, Iterator, Optional, Tuple

import numpy as np

from . import _core
from ._core import Camera, InvalidInput, Options

__all__ = [
    "Camera",
    "Dataset",
    "Engine",
    "Frame",
    "InvalidInput",
    "Options",
    "ate",
    "load_map",
    "make_synthetic_sequence",
    "open_dataset",
    "options",
    "pose_matrix",
    "read_trajectory",
    "render_map",
    "rpe",
    "run",
    "save_map",
    "write_trajectory",
]


def _option_text(key: str, value: Any) -> str:
    """The text form of an option value, as ``--set key=value`` takes it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    if isinstance(value, (str, os.PathLike)):
        return os.fspath(value)
    if isinstance(value, (list, tuple)):
        return ",".join(_option_text(key, v) for v in value)
    raise ValueError(f"option {key}: cannot use a value of type {type(value).__name__}")


def options(preset: Optional[str] = None, config=None, values: Optional[Dict[str, Any]] = None, disable=(),
            dataset=None, base: Optional[Options] = None, **kwargs) -> Options:
    """Builds the options tree the way ``dypho run`` does.

    Args:
        preset: ``synthetic``, ``tum``, ``bonn`` or ``shore``; default: the
            one the dataset folder implies (``dataset``), else ``synthetic``.
        config: a YAML or JSON file, read like ``--config`` (its ``preset``
            key is applied first; an explicit ``preset`` argument wins).
        values: a dict of options, nested (``{"mapper": {"lr_means": 1e-4}}``)
            or with dotted keys (``{"mapper.lr_means": 1e-4}``), applied like
            a config file after it.
        disable: stages to switch off, as ``--disable``: refine, adaptive,
            semantic, flow, epipolar or masking (a name or a list).
        dataset: a dataset folder, only to choose the default preset.
        base: start from a copy of these options instead of a preset.
        **kwargs: single options last, like ``--set``; ``__`` stands for the
            dot (``keyframes__max_frame_gap=4``).

    Returns:
        A validated ``dypho.Options``. Raises ``dypho.InvalidInput`` naming
        the key for an unknown key or a value out of range.
    """
    if base is not None:
        if preset is not None:
            raise ValueError("options: give base or preset, not both")
        o = base.copy()
        if config is not None:
            o.apply_file(os.fspath(config))
    else:
        name = preset
        if name is None:
            name = _core.preset_for_dataset(os.fspath(dataset)) if dataset is not None else "synthetic"
        o = Options(name)
        if config is not None:
            o.apply_file(os.fspath(config))
            if preset is not None and o.preset != preset:
                # The explicit preset wins over the file's; the file's other keys stay.
                o = Options(preset)
                o.apply_file(os.fspath(config))
                o.set("preset", preset)
    if values is not None:
        if not isinstance(values, dict):
            raise ValueError(f"values must be a dict of options, got {type(values).__name__}")
        o.apply_text(json.dumps(values), "options")
    for key, value in kwargs.items():
        dotted = key.replace("__", ".")
        o.set(dotted, _option_text(dotted, value))
    for stage in [disable] if isinstance(disable, str) else disable:
        o.disable(stage)
    o.validate()
    return o


def _resolve_options(opts, kwargs, dataset=None) -> Options:
    """An ``Options`` from an Options/dict/None plus keyword options."""
    config = kwargs.pop("config", None)
    preset = kwargs.pop("preset", None)
    disable = kwargs.pop("disable", ())
    if isinstance(opts, Options):
        return options(base=opts, preset=preset, config=config, disable=disable, **kwargs)
    if opts is not None and not isinstance(opts, dict):
        raise ValueError(f"options must be a dict or dypho.Options, got {type(opts).__name__}")
    return options(preset=preset, config=config, values=opts, disable=disable, dataset=dataset, **kwargs)


def pose_matrix(pose) -> np.ndarray:
    """A pose (4x4 array or (quaternion w x y z, translation) pair) as a 4x4 float64 array."""
    if isinstance(pose, (tuple, list)) and len(pose) == 2:
        w, x, y, z = (float(v) for v in np.asarray(pose[0], dtype=np.float64).reshape(4))
        n = (w * w + x * x + y * y + z * z) ** 0.5
        if n == 0:
            raise ValueError("pose: zero quaternion")
        w, x, y, z = w / n, x / n, y / n, z / n
        m = np.eye(4)
        m[:3, :3] = [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
        m[:3, 3] = np.asarray(pose[1], dtype=np.float64).reshape(3)
        return m
    m = np.asarray(pose, dtype=np.float64)
    if m.shape != (4, 4):
        raise ValueError(f"pose must be 4x4 or (quaternion, translation), got shape {m.shape}")
    return m.copy()


class Engine:
    """dypho as the mapping backend of a Python program (engine/api.h).

    Frames go in with ``push_frame`` (with the host's pose, or without one:
    then the built-in ORB tracker estimates it); the engine decides keyframes
    and maps them on its own thread (or inside ``push_frame`` when
    ``synchronous``), ``render`` renders any view of the current map, ``map``
    returns it, ``finish`` runs the final refinement and ``save`` writes
    ``map.ply`` and ``keyframes.txt``. Every method may be called from any
    thread.

    Args:
        camera: ``dypho.Camera`` of the frames (distortion allowed).
        options: a dict of options (nested or dotted keys, as a ``--config``
            file) or a ``dypho.Options``; keyword options (``__`` for dots)
            are applied on top. The engine uses the mapper, keyframe,
            iteration, queue and threading keys of the tree (``mapper.*``,
            ``keyframes.*``, ``iterations_per_keyframe``, ``final_iterations``,
            ``queue_capacity``, ``min_iterations_when_behind``, ``sequential``,
            ``map_sensor_model`` with ``rolling_shutter``), as ``dypho run``
            does.
        config: a YAML/JSON options file read first (like ``--config``).
        preset: the preset the options start from (default ``synthetic``).
        synchronous: map inside ``push_frame`` on the calling thread
            (deterministic: the same frames give the same map); the same as
            the option ``sequential``.
        track_when_no_pose: frames pushed without a pose go through the ORB
            tracker (otherwise such a push raises).
        depth_scale: depth units per metre of ``uint16`` depth frames.
        final_seconds: ``finish`` stops after this long [s]; 0 = no limit.
    """

    def __init__(self, camera: Camera, options=None, *, synchronous: Optional[bool] = None,
                 track_when_no_pose: bool = True, depth_scale: float = 5000.0, final_seconds: float = 0.0,
                 **kwargs):
        if synchronous is not None:
            kwargs["sequential"] = bool(synchronous)
        self._options = _resolve_options(options, kwargs)
        self._engine = _core.Engine(camera, self._options, bool(track_when_no_pose), float(depth_scale),
                                    float(final_seconds))

    @property
    def camera(self) -> Camera:
        """The camera the frames must match."""
        return self._engine.camera

    @property
    def options(self) -> Options:
        """The options tree the engine was made from (a copy)."""
        return self._options.copy()

    def push_frame(self, rgb: np.ndarray, depth: Optional[np.ndarray] = None, pose=None,
                   mask: Optional[np.ndarray] = None, timestamp: Optional[float] = None,
                   angular_velocity=None, depth_timestamp: Optional[float] = None) -> Dict[str, Any]:
        """Adds one frame.

        Args:
            rgb: ``uint8`` (H, W, 3) RGB image of the camera's size.
            depth: ``uint16`` (units of ``depth_scale``) or ``float32``
                metres (H, W); without depth a frame is tracked but never
                becomes a keyframe.
            pose: ``world_from_cam`` (4x4 or (quaternion w x y z,
                translation)); None = the ORB tracker estimates it.
            mask: ``uint8`` or ``bool`` (H, W), non-zero = dynamic (kept out
                of the map and of tracking).
            timestamp: seconds; default: 1/30 s after the previous frame
                (0 for the first).
            angular_velocity: (3,) camera rotation rate [rad/s] for the
                rolling-shutter / motion-blur model; default from the poses.
            depth_timestamp: when the depth was captured [s], if not at
                ``timestamp`` (within 0.1 s); the engine moves the depth to
                the colour image's pose (``Frame.depth_timestamp``).

        Returns:
            dict with ``has_pose`` (False: the tracker lost the frame),
            ``pose`` (the 4x4 world_from_cam used, or None), ``keyframe``,
            ``keyframe_id`` (-1 unless a keyframe) and ``message`` (why there
            is no pose).
        """
        return self._engine.push_frame(rgb, depth, pose, mask, timestamp, angular_velocity, depth_timestamp)

    def render(self, camera: Camera, pose, mode: str = "sorted") -> Dict[str, np.ndarray]:
        """Renders the current map at ``pose`` (world_from_cam) with ``camera``'s intrinsics.

        ``mode`` is ``sorted`` (depth-sorted alpha compositing) or ``oit``
        (order-independent). Returns ``color`` (H, W, 3) float32 linear
        [0, 1] (not clamped), ``depth`` (H, W) float32 camera z [m] of what
        each pixel shows (0 where alpha < 0.5) and ``alpha`` (H, W).
        """
        return self._engine.render(camera, pose, mode)

    def map(self) -> Dict[str, np.ndarray]:
        """A copy of the current map as a dict of arrays (see the module docstring)."""
        return self._engine.map()

    def update_keyframe_pose(self, keyframe_id: int, pose) -> None:
        """Moves keyframe ``keyframe_id`` (and the Gaussians it inserted) to a corrected world_from_cam pose."""
        self._engine.update_keyframe_pose(int(keyframe_id), pose)

    def keyframe_pose(self, keyframe_id: int) -> np.ndarray:
        """The current 4x4 world_from_cam pose of keyframe ``keyframe_id``."""
        return self._engine.keyframe_pose(int(keyframe_id))

    def mapped_keyframes(self) -> Tuple[np.ndarray, np.ndarray]:
        """The keyframes in the map: (timestamps (N,), world_from_cam poses (N, 4, 4)) in mapping order.

        The poses as the map holds them (host updates and, with
        ``mapper.refine_poses``, the photometric refinement included): what
        ``save`` writes to keyframes.txt.
        """
        return self._engine.mapped_keyframes()

    def status(self, queue_only: bool = False) -> Dict[str, Any]:
        """Counters: frames, keyframes, mapped/queued/late/spilled/shortened keyframes, push_waits, num_gaussians, iterations, last_loss, final_steps, final_stop.

        ``queue_only`` returns at once without waiting for the current
        optimisation step (the map counters are then 0).
        """
        return self._engine.status(bool(queue_only))

    def wait_until_idle(self) -> None:
        """Blocks until every queued keyframe is mapped."""
        self._engine.wait_until_idle()

    def finish(self, progress=None) -> int:
        """Maps the queued keyframes, then refines all keyframes together.

        Runs the option ``final_iterations`` steps (fewer when
        ``final_seconds`` runs out); ``progress(done, planned)`` is called
        every few steps. Ctrl-C (on the main thread) stops it between steps
        with KeyboardInterrupt; the map stays usable. Returns the steps run.
        """
        return self._engine.finish(progress)

    def save(self, directory) -> None:
        """Writes ``directory``/map.ply, ``directory``/keyframes.txt (TUM format) and ``directory``/dense.ply (the static dense point cloud) atomically."""
        self._engine.save(os.fspath(directory))

    def save_dense_cloud(self, path) -> None:
        """Writes the static dense point cloud of the mapped keyframes (binary PLY: x y z nx ny nz red green blue), atomically."""
        self._engine.save_dense_cloud(os.fspath(path))

    def close(self) -> None:
        """Stops the mapping thread and frees the engine (keyframes still waiting are discarded: call finish() first to map them)."""
        self._engine = None

    def __enter__(self):
        """``with dypho.Engine(...) as engine:`` closes the engine at the end of the block."""
        return self

    def __exit__(self, *exc):
        """Closes the engine (see ``close``); exceptions propagate."""
        self.close()
        return False


def run(dataset=None, out=None, *, progress: bool = True, options=None, **kwargs) -> Dict[str, Any]:
    """Runs the whole system, exactly as ``dypho run DATASET --out OUT`` does.

    Args:
        dataset: a dataset folder (TUM, Bonn, generic with a camera file, or
            a synthetic sequence); None generates the built-in synthetic
            dynamic sequence into ``out``/sequence.
        out: the output folder (created): trajectory.txt, keyframes.txt,
            map.ply, map.splat, map.glb, map.spz, renders/, overlays/,
            report.md, metrics.json, options.yaml, as ``dypho run``.
        progress: progress lines on stderr.
        options: a dict of options or a ``dypho.Options``.
        **kwargs: ``config=``, ``preset=``, ``disable=`` and single options
            (``poses="gt"``, ``sequential=True``, ``max_frames=60``,
            ``mapper__lr_means=1e-4``), as the flags of ``dypho run``.

    Returns:
        dict of the run's results (frames, tracked, ate_rmse, psnr, ssim,
        keyframes, num_gaussians, timings, trajectory as (timestamps, poses),
        report_path, ...).

    Ctrl-C stops after the current frame, writes the outputs of the frames
    processed and raises KeyboardInterrupt; a second Ctrl-C quits at once.
    """
    if out is None:
        raise ValueError("run: out (the output folder) is required")
    folder = os.fspath(dataset) if dataset is not None else None
    opts = _resolve_options(options, kwargs, dataset=folder)
    return _core.run(folder, os.fspath(out), opts, bool(progress))


def load_map(path) -> Dict[str, np.ndarray]:
    """Reads a map file: .ply (3DGS), .splat, .spz, .glb or .gltf. Returns the map dict."""
    return _core.load_map(os.fspath(path))


def save_map(map: Dict[str, np.ndarray], path, spz_version: int = 3) -> None:
    """Writes a map dict in the format of ``path``'s extension (.ply, .splat, .spz, .glb, .gltf), atomically.

    ``spz_version`` (2 or 3) is the .spz format version written.
    """
    _core.save_map(map, os.fspath(path), int(spz_version))


def render_map(map: Dict[str, np.ndarray], camera: Camera, pose, mode: str = "sorted", sh_degree: int = 3,
               background=(0.0, 0.0, 0.0), threads: int = 0) -> Dict[str, np.ndarray]:
    """Renders a map dict with the CPU rasterizer at ``pose`` (world_from_cam).

    Returns ``color`` (H, W, 3) float32 linear [0, 1] (not clamped),
    ``depth`` (H, W) camera z [m] of what each pixel shows (0 where
    alpha <= 0.5) and ``alpha`` (H, W). ``sh_degree`` is clipped to what the
    map holds; ``threads`` = 0 uses every core.
    """
    return _core.render_map(map, camera, pose, mode, int(sh_degree), tuple(float(b) for b in background),
                            int(threads))


@dataclass
class Frame:
    """One dataset frame.

    Attributes:
        index: position in the sequence.
        timestamp: RGB timestamp [s].
        rgb: ``uint8`` (H, W, 3).
        depth: ``float32`` (H, W) metres (0 = none), or None without depth.
        mask: ``uint8`` (H, W) dynamic mask (255 = dynamic) from the
            folder's masks/, or None.
        pose: the ground-truth world_from_cam as (quaternion w x y z,
            translation), or None where the ground truth does not cover the
            frame. ``pose_matrix(frame.pose)`` gives the 4x4.
        rgb_path, depth_path: the image files.
        depth_timestamp: when the depth was captured [s] (the dataset's
            depth time: for TUM fr1 20 ms before ``timestamp``), or None
            without depth; pass it to ``Engine.push_frame``.
    """

    index: int
    timestamp: float
    rgb: np.ndarray
    depth: Optional[np.ndarray]
    mask: Optional[np.ndarray]
    pose: Optional[Tuple[np.ndarray, np.ndarray]]
    rgb_path: str
    depth_path: str
    depth_timestamp: Optional[float] = None


class Dataset:
    """An RGB-D sequence on disk (TUM RGB-D, Bonn, or a generic folder with a camera file).

    ``len(dataset)`` frames; ``dataset[i]`` decodes frame i (a ``Frame``;
    negative indices count from the end); iterating yields every frame in
    order. See engine/dataset/dataset.h for the folder layouts.
    """

    def __init__(self, core):
        self._core = core

    @property
    def camera(self) -> Camera:
        """The camera of the frames (with distortion, if any)."""
        return self._core.camera

    @property
    def depth_factor(self) -> float:
        """Depth PNG units per metre."""
        return self._core.depth_factor

    @property
    def name(self) -> str:
        """The folder name."""
        return self._core.name

    @property
    def folder(self) -> str:
        """The folder as given."""
        return self._core.folder

    @property
    def format(self) -> str:
        """``tum``, ``bonn`` or ``generic``."""
        return self._core.format

    @property
    def ground_truth(self):
        """The ground-truth trajectory as (timestamps (N,), world_from_cam poses (N, 4, 4)), or None."""
        return self._core.ground_truth

    def __len__(self) -> int:
        """The number of frames."""
        return len(self._core)

    def __getitem__(self, index: int) -> Frame:
        """Frame ``index`` (negative counts from the end), decoded now; IndexError outside the sequence."""
        return Frame(**self._core.load(int(index)))

    def __iter__(self) -> Iterator[Frame]:
        """Every frame in order, decoded one at a time."""
        for i in range(len(self)):
            yield self[i]

    def __repr__(self) -> str:
        """The folder, frame count, format and camera."""
        return f"dypho.Dataset({self.folder!r}, {len(self)} frames, {self.format}, {self.camera!r})"


def open_dataset(folder, camera_preset: str = "", camera_file: str = "", depth_factor: float = 0.0,
                 max_depth_dt: float = 0.02, frame_rate: float = 30.0) -> Dataset:
    """Opens a dataset folder (lists are read and image files checked; pixels are read per frame).

    Args:
        folder: TUM RGB-D, Bonn RGB-D Dynamic, or a folder in the same
            layout with camera.yaml/camera.json.
        camera_preset: freiburg1|fr1|freiburg2|fr2|freiburg3|fr3|bonn; ""
            = from the camera file or the folder name.
        camera_file: a YAML/JSON camera file that overrides everything.
        depth_factor: depth units per metre; 0 = the camera file's, else 5000.
        max_depth_dt: largest RGB-depth time difference when pairing by time [s].
        frame_rate: [Hz] for image folders whose names are not timestamps.
    """
    return Dataset(_core.Dataset(os.fspath(folder), camera_preset, os.fspath(camera_file), float(depth_factor),
                                 float(max_depth_dt), float(frame_rate)))


def make_synthetic_sequence(folder, options=None, **kwargs) -> Dataset:
    """Writes the built-in synthetic dynamic sequence (TUM layout, exact poses, depth and masks) and opens it.

    Its size and content follow the ``synth.*`` options, e.g.
    ``make_synthetic_sequence("seq", synth__frames=30, synth__width=160,
    synth__height=120)``; it is what ``dypho run`` without a dataset maps.
    """
    opts = _resolve_options(options, kwargs)
    _core.make_synthetic_sequence(os.fspath(folder), opts)
    return open_dataset(folder)


def ate(gt, est, max_dt: float = 0.02, offset: float = 0.0, scale: bool = False) -> Dict[str, Any]:
    """Absolute trajectory error, as ``dypho eval`` (and TUM's evaluate_ate.py) computes it.

    ``gt`` and ``est`` are each a TUM trajectory file, a pair (timestamps
    (N,), poses (N, 4, 4) world_from_cam), or an (N, 8) array of TUM rows
    ``t tx ty tz qx qy qz qw``. Poses are matched by timestamp within
    ``max_dt`` [s] (after adding ``offset`` to the estimate's), aligned by
    SE(3) (Sim(3) with ``scale``). Returns rmse, mean, median, std, min, max
    [m], count, scale, gt_from_est (4x4), errors, timestamps,
    unmatched_estimates.
    """
    return _core.ate(_trajectory_arg(gt), _trajectory_arg(est), float(max_dt), float(offset), bool(scale))


def rpe(gt, est, delta: float = 1.0, offset: float = 0.0, scale: float = 1.0) -> Dict[str, Any]:
    """Relative pose error over ``delta`` seconds, as ``dypho eval`` (TUM's evaluate_rpe.py) computes it.

    Trajectories as for ``ate``. ``scale`` multiplies the estimate's relative
    translations (``dypho eval --scale`` uses the ATE's Sim(3) scale).
    Returns ``translation`` [m] and ``rotation`` [deg] statistics (count,
    rmse, mean, median, std, min, max) and the per-pair errors.
    """
    return _core.rpe(_trajectory_arg(gt), _trajectory_arg(est), float(delta), float(offset), float(scale))


def _trajectory_arg(t):
    """A path-like trajectory argument as a string; other forms unchanged."""
    return os.fspath(t) if isinstance(t, os.PathLike) else t


def read_trajectory(path) -> Tuple[np.ndarray, np.ndarray]:
    """A TUM trajectory file as (timestamps (N,), world_from_cam poses (N, 4, 4))."""
    return _core.read_trajectory(os.fspath(path))


def write_trajectory(path, timestamps, poses) -> None:
    """Writes timestamps (N,) and poses (N 4x4 arrays or (quaternion, translation) pairs) as a TUM file."""
    _core.write_trajectory(os.fspath(path), timestamps, poses)
