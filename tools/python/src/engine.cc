// dypho._core.Engine: engine/api.h for Python. The GIL is released while the
// engine copies a frame, maps (synchronous mode), renders, refines and saves,
// so other Python threads run meanwhile (the engine itself is thread-safe).
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <cmath>
#include <memory>
#include <optional>

#include "engine/api.h"
#include "engine/map/sensor_model.h"
#include "engine/pipeline/pipeline.h"
#include "engine/pipeline/pipeline_options.h"
#include "tools/python/src/arrays.h"
#include "tools/python/src/module.h"

namespace dypho::python {
namespace {

// The engine's options from the options tree, as `dypho run` makes them
// (EngineOptionsFromTree); the sensor model's readout is the tree's
// rolling_shutter (0 when automatic: the engine knows no dataset). Waiting
// keyframes are never spilled (there is no output folder): past
// waiting_memory_mb, push_frame waits.
EngineOptions EngineOptionsFromPython(const PipelineOptions& tree, const Camera& camera, bool track_when_no_pose,
                                      double depth_scale, double final_seconds) {
  EngineOptions o =
      EngineOptionsFromTree(tree, camera, tree.rolling_shutter >= 0 ? tree.rolling_shutter : 0.0, std::string());
  o.track_when_no_pose = track_when_no_pose;
  o.depth_scale = depth_scale;
  o.final_seconds = final_seconds;
  return o;
}

kernels::CompositeMode ParseMode(const std::string& mode) {
  if (mode == "sorted") return kernels::CompositeMode::kSorted;
  if (mode == "oit") return kernels::CompositeMode::kOrderIndependent;
  throw ArgumentError("mode must be 'sorted' or 'oit', got '" + mode + "'");
}

py::dict StatusToDict(const EngineStatus& s) {
  py::dict d;
  d["frames"] = s.frames;
  d["keyframes"] = s.keyframes;
  d["mapped_keyframes"] = s.mapped_keyframes;
  d["queued_keyframes"] = s.queued_keyframes;
  d["late_keyframes"] = s.late_keyframes;
  d["spilled_keyframes"] = s.spilled_keyframes;
  d["push_waits"] = s.push_waits;
  d["final_steps"] = s.final_steps;
  d["final_stop"] = s.final_stop;
  d["shortened_keyframes"] = s.shortened_keyframes;
  d["num_gaussians"] = s.num_gaussians;
  d["iterations"] = s.iterations;
  d["last_loss"] = s.last_loss;
  return d;
}

class PyEngine {
 public:
  PyEngine(const py::handle& camera, const PipelineOptions& tree, bool track_when_no_pose, double depth_scale,
           double final_seconds) {
    const EngineOptions options =
        EngineOptionsFromPython(tree, CameraFromPython(camera, "camera"), track_when_no_pose, depth_scale, final_seconds);
    camera_ = options.camera;
    py::gil_scoped_release release;
    engine_ = Engine::Create(options);
  }

  py::dict PushFrame(const py::handle& rgb_obj, const py::handle& depth_obj, const py::handle& pose_obj,
                     const py::handle& mask_obj, std::optional<double> timestamp,
                     const py::handle& angular_velocity_obj, std::optional<double> depth_timestamp) {
    const py::ssize_t h = camera_.height, w = camera_.width;
    const std::string hw = "(" + std::to_string(h) + ", " + std::to_string(w);
    FrameBuffers frame;
    const py::array_t<uint8_t> rgb = CheckedArray<uint8_t>(rgb_obj, "rgb", {h, w, 3}, hw + ", 3) (the camera's size)");
    frame.rgb = rgb.data();
    py::array depth;
    if (!depth_obj.is_none()) {
      if (py::isinstance<py::array_t<uint16_t, 0>>(depth_obj)) {
        const py::array_t<uint16_t> d = CheckedArray<uint16_t>(depth_obj, "depth", {h, w}, hw + ")");
        frame.depth = d.data();
        depth = d;
      } else if (py::isinstance<py::array_t<float, 0>>(depth_obj)) {
        const py::array_t<float> d = CheckedArray<float>(depth_obj, "depth", {h, w}, hw + ")");
        frame.depth_m = d.data();
        depth = d;
      } else {
        const std::string got = py::isinstance<py::array>(depth_obj)
                                    ? Describe(py::reinterpret_borrow<py::array>(depth_obj))
                                    : py::str(py::type::of(depth_obj).attr("__name__")).cast<std::string>();
        throw ArgumentError("depth must be uint16 (units of depth_scale) or float32 (metres) of shape " + hw +
                            "), got " + got);
      }
    }
    py::array mask;
    if (!mask_obj.is_none()) {
      py::handle m = mask_obj;
      py::object as_u8;
      if (py::isinstance<py::array>(m) && py::reinterpret_borrow<py::array>(m).dtype().kind() == 'b') {
        as_u8 = py::reinterpret_borrow<py::array>(m).attr("view")("uint8");
        m = as_u8;
      }
      const py::array_t<uint8_t> a = CheckedArray<uint8_t>(m, "mask", {h, w}, hw + ") (uint8 or bool)");
      frame.dynamic_mask = a.data();
      mask = a;
    }
    if (!angular_velocity_obj.is_none()) {
      const py::array_t<double, py::array::forcecast> v = py::array_t<double, py::array::forcecast>::ensure(angular_velocity_obj);
      if (!v || v.ndim() != 1 || v.shape(0) != 3) throw ArgumentError("angular_velocity must have shape (3,)");
      frame.angular_velocity = Eigen::Vector3d(v.at(0), v.at(1), v.at(2));
    }
    frame.timestamp = timestamp ? *timestamp : (last_timestamp_ ? *last_timestamp_ + 1.0 / 30.0 : 0.0);
    frame.depth_timestamp = depth_timestamp;
    if (!std::isfinite(frame.timestamp)) throw ArgumentError("timestamp must be finite");
    std::optional<Rigid3d> cam_from_world;
    if (!pose_obj.is_none()) cam_from_world = PoseFromPython(pose_obj, "pose").Inverse();
    PushResult r;
    {
      py::gil_scoped_release release;
      r = engine_->PushFrame(frame, cam_from_world ? &*cam_from_world : nullptr);
    }
    last_timestamp_ = frame.timestamp;
    py::dict d;
    d["has_pose"] = r.has_pose;
    d["pose"] = r.has_pose ? py::object(PoseToNumpy(r.cam_from_world.Inverse())) : py::none();
    d["keyframe"] = r.keyframe;
    d["keyframe_id"] = r.keyframe_id;
    d["message"] = r.message;
    return d;
  }

  void UpdateKeyframePose(int id, const py::handle& pose) {
    const Rigid3d cam_from_world = PoseFromPython(pose, "pose").Inverse();
    py::gil_scoped_release release;
    engine_->UpdateKeyframePose(id, cam_from_world);
  }

  py::array_t<double> KeyframePose(int id) const {
    Rigid3d cam_from_world;
    {
      py::gil_scoped_release release;
      cam_from_world = engine_->KeyframePose(id);
    }
    return PoseToNumpy(cam_from_world.Inverse());
  }

  py::tuple MappedKeyframes() const {
    Trajectory keyframes;
    {
      py::gil_scoped_release release;
      keyframes = engine_->MappedKeyframes();
    }
    return TrajectoryToPython(keyframes);
  }

  py::dict Render(const py::handle& camera_obj, const py::handle& pose_obj, const std::string& mode) const {
    const Camera camera = CameraFromPython(camera_obj, "camera");
    const Rigid3d cam_from_world = PoseFromPython(pose_obj, "pose").Inverse();
    const kernels::CompositeMode composite = ParseMode(mode);
    EngineRender r;
    {
      py::gil_scoped_release release;
      r = engine_->Render(camera, cam_from_world, composite);
    }
    py::dict d;
    d["color"] = VectorToNumpy(r.color, {r.height, r.width, 3});
    d["depth"] = VectorToNumpy(r.depth, {r.height, r.width});
    d["alpha"] = VectorToNumpy(r.alpha, {r.height, r.width});
    return d;
  }

  py::dict Map() const {
    GaussianCloud cloud;
    {
      py::gil_scoped_release release;
      cloud = engine_->Map();
    }
    return CloudToDict(cloud);
  }

  py::dict Status(bool queue_only) const {
    EngineStatus s;
    {
      py::gil_scoped_release release;
      s = queue_only ? engine_->QueueStatus() : engine_->Status();
    }
    return StatusToDict(s);
  }

  void WaitUntilIdle() {
    py::gil_scoped_release release;
    engine_->WaitUntilIdle();
  }

  // Runs the final refinement; `progress(done, planned)` is called every few
  // steps. On the main thread a pending Ctrl-C (or any signal handler that
  // raises) stops it between steps and raises.
  int Finish(const std::optional<py::function>& progress) {
    const bool main_thread = OnMainThread();
    auto callback = [&](int done, int planned) {
      py::gil_scoped_acquire acquire;
      if (main_thread && PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (progress) (*progress)(done, planned);
    };
    py::gil_scoped_release release;
    return engine_->Finish(callback);
  }

  void Save(const std::string& dir) const {
    py::gil_scoped_release release;
    engine_->Save(dir);
  }

  void SaveDenseCloud(const std::string& path) const {
    py::gil_scoped_release release;
    engine_->SaveDenseCloud(path);
  }

  const Camera& camera() const { return camera_; }

 private:
  std::unique_ptr<Engine> engine_;
  Camera camera_;
  std::optional<double> last_timestamp_;
};

}  // namespace

void RegisterEngine(py::module_& m) {
  py::class_<PyEngine>(m, "Engine",
                       "The embedding API (engine/api.h). Use dypho.Engine, which builds the options; see its "
                       "docstrings.")
      .def(py::init<const py::handle&, const PipelineOptions&, bool, double, double>(), py::arg("camera"),
           py::arg("options"), py::arg("track_when_no_pose"), py::arg("depth_scale"), py::arg("final_seconds"))
      .def("push_frame", &PyEngine::PushFrame, py::arg("rgb"), py::arg("depth"), py::arg("pose"), py::arg("mask"),
           py::arg("timestamp"), py::arg("angular_velocity"), py::arg("depth_timestamp"))
      .def("update_keyframe_pose", &PyEngine::UpdateKeyframePose, py::arg("keyframe_id"), py::arg("pose"))
      .def("keyframe_pose", &PyEngine::KeyframePose, py::arg("keyframe_id"))
      .def("mapped_keyframes", &PyEngine::MappedKeyframes)
      .def("render", &PyEngine::Render, py::arg("camera"), py::arg("pose"), py::arg("mode"))
      .def("map", &PyEngine::Map)
      .def("status", &PyEngine::Status, py::arg("queue_only"))
      .def("wait_until_idle", &PyEngine::WaitUntilIdle)
      .def("finish", &PyEngine::Finish, py::arg("progress"))
      .def("save", &PyEngine::Save, py::arg("directory"))
      .def("save_dense_cloud", &PyEngine::SaveDenseCloud, py::arg("path"))
      .def_property_readonly("camera", &PyEngine::camera);
}

}  // namespace dypho::python
