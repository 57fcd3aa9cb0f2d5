// Datasets, trajectories and trajectory metrics for Python: the dataset
// reader of engine/dataset/dataset.h (frames as NumPy arrays, decoded with
// the GIL released), TUM trajectory files, and ATE / RPE exactly as
// `dypho eval` computes them (engine/eval/ate.h).
#include <pybind11/stl.h>

#include <memory>

#include "engine/dataset/dataset.h"
#include "engine/eval/ate.h"
#include "engine/eval/trajectory.h"
#include "tools/python/src/arrays.h"
#include "tools/python/src/module.h"

namespace dypho::python {
namespace {

class PyDataset {
 public:
  PyDataset(const std::string& folder, const std::string& camera_preset, const std::string& camera_file,
            double depth_factor, double max_depth_dt, double frame_rate) {
    DatasetOptions options;
    options.camera_preset = camera_preset;
    options.camera_file = camera_file;
    options.depth_factor = depth_factor;
    options.max_depth_dt = max_depth_dt;
    options.frame_rate = frame_rate;
    std::string error;
    if (!options.IsValid(&error)) throw ArgumentError(error);
    py::gil_scoped_release release;
    dataset_ = OpenDataset(folder, options);
  }

  size_t size() const { return dataset_->size(); }
  const Dataset& dataset() const { return *dataset_; }

  py::dict Load(long index) const {
    const long n = static_cast<long>(dataset_->size());
    if (index < 0) index += n;
    if (index < 0 || index >= n) throw py::index_error("frame index out of range (" + std::to_string(n) + " frames)");
    Frame f;
    {
      py::gil_scoped_release release;
      f = dataset_->Load(static_cast<size_t>(index));
    }
    py::dict d;
    d["index"] = f.index;
    d["timestamp"] = f.timestamp;
    d["rgb"] = ImageToNumpy(f.rgb);
    d["depth"] = f.has_depth ? py::object(ImageToNumpy(f.depth)) : py::none();
    d["mask"] = f.dynamic_mask.empty() ? py::none() : py::object(ImageToNumpy(f.dynamic_mask));
    d["pose"] = f.world_from_cam_gt ? py::object(PoseToQuaternionTranslation(*f.world_from_cam_gt)) : py::none();
    d["rgb_path"] = f.rgb_path;
    d["depth_path"] = f.depth_path;
    d["depth_timestamp"] = f.has_depth ? py::object(py::float_(f.depth_timestamp)) : py::none();
    return d;
  }

 private:
  std::unique_ptr<Dataset> dataset_;
};

// A trajectory argument: a path, (timestamps (N,), poses (N, 4, 4)), or an
// (N, 8) array of TUM rows "t tx ty tz qx qy qz qw".
Trajectory TrajectoryFromPython(const py::handle& obj, const std::string& name) {
  if (py::isinstance<py::str>(obj) || py::hasattr(obj, "__fspath__")) {
    const std::string path = py::str(py::module_::import("os").attr("fspath")(obj)).cast<std::string>();
    py::gil_scoped_release release;
    return ReadTumTrajectory(path);
  }
  Trajectory t;
  if (py::isinstance<py::tuple>(obj) && py::len(obj) == 2) {
    const py::tuple pair = py::reinterpret_borrow<py::tuple>(obj);
    const py::array_t<double, py::array::c_style | py::array::forcecast> times =
        py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(pair[0]);
    if (!times || times.ndim() != 1) throw ArgumentError(name + "[0] (timestamps) must have shape (N,)");
    const py::ssize_t n = times.shape(0);
    const py::sequence poses = py::reinterpret_borrow<py::sequence>(pair[1]);
    if (py::len(poses) != static_cast<size_t>(n))
      throw ArgumentError(name + ": " + std::to_string(n) + " timestamps but " + std::to_string(py::len(poses)) +
                          " poses");
    for (py::ssize_t i = 0; i < n; ++i)
      t.Add(times.at(i), PoseFromPython(poses[i], name + "[1][" + std::to_string(i) + "]"));
  } else {
    const py::array_t<double, py::array::c_style | py::array::forcecast> rows =
        py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
    if (!rows || rows.ndim() != 2 || rows.shape(1) != 8)
      throw ArgumentError(name + " must be a path, (timestamps, poses) or an (N, 8) array 't tx ty tz qx qy qz qw'");
    for (py::ssize_t i = 0; i < rows.shape(0); ++i) {
      const double* r = rows.data(i, 0);
      const Eigen::Quaterniond q(r[7], r[4], r[5], r[6]);
      if (q.norm() < 1e-12) throw ArgumentError(name + " row " + std::to_string(i) + " has a zero quaternion");
      t.Add(r[0], Rigid3d(q, Eigen::Vector3d(r[1], r[2], r[3])));
    }
  }
  for (size_t i = 1; i < t.size(); ++i) {
    if (!(t.timestamps[i] > t.timestamps[i - 1]))
      throw ArgumentError(name + ": timestamps must increase (index " + std::to_string(i) + ")");
  }
  return t;
}

py::dict StatsToDict(const ErrorStats& s) {
  py::dict d;
  d["count"] = s.count;
  d["rmse"] = s.rmse;
  d["mean"] = s.mean;
  d["median"] = s.median;
  d["std"] = s.std;
  d["min"] = s.min;
  d["max"] = s.max;
  return d;
}

py::dict AtePy(const py::handle& gt_obj, const py::handle& est_obj, double max_dt, double offset, bool scale) {
  const Trajectory gt = TrajectoryFromPython(gt_obj, "gt"), est = TrajectoryFromPython(est_obj, "est");
  AteOptions options;
  options.max_time_difference = max_dt;
  options.time_offset = offset;
  options.estimate_scale = scale;
  std::string error;
  if (!options.IsValid(&error)) throw ArgumentError(error);
  AteResult r;
  {
    py::gil_scoped_release release;
    r = ComputeAte(gt, est, options);
  }
  py::dict d = StatsToDict(r.translation);
  d["scale"] = r.scale;
  // gt_from_est maps estimated positions onto the ground truth: as a 4x4
  // (rotation and translation; the scale is separate).
  py::array_t<double> alignment({4, 4});
  const Eigen::Matrix4d m = r.gt_from_est.ToMatrix4();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) alignment.mutable_at(i, j) = m(i, j);
  d["gt_from_est"] = alignment;
  d["errors"] = py::array_t<double>(r.errors.size(), r.errors.data());
  d["timestamps"] = py::array_t<double>(r.timestamps.size(), r.timestamps.data());
  d["unmatched_estimates"] = r.unmatched_estimates;
  return d;
}

py::dict RpePy(const py::handle& gt_obj, const py::handle& est_obj, double delta, double offset, double scale) {
  const Trajectory gt = TrajectoryFromPython(gt_obj, "gt"), est = TrajectoryFromPython(est_obj, "est");
  RpeOptions options;
  options.delta = delta;
  options.time_offset = offset;
  options.scale = scale;
  std::string error;
  if (!options.IsValid(&error)) throw ArgumentError(error);
  RpeResult r;
  {
    py::gil_scoped_release release;
    r = ComputeRpe(gt, est, options);
  }
  py::dict d;
  d["translation"] = StatsToDict(r.translation);
  d["rotation"] = StatsToDict(r.rotation);
  std::vector<double> t(r.pairs.size()), rot(r.pairs.size());
  for (size_t i = 0; i < r.pairs.size(); ++i) {
    t[i] = r.pairs[i].translation_error;
    rot[i] = r.pairs[i].rotation_error;
  }
  d["translation_errors"] = py::array_t<double>(t.size(), t.data());
  d["rotation_errors"] = py::array_t<double>(rot.size(), rot.data());
  return d;
}

py::tuple ReadTrajectoryPy(const std::string& path) {
  Trajectory t;
  {
    py::gil_scoped_release release;
    t = ReadTumTrajectory(path);
  }
  return TrajectoryToPython(t);
}

void WriteTrajectoryPy(const std::string& path, const py::handle& timestamps, const py::handle& poses) {
  const Trajectory t = TrajectoryFromPython(py::make_tuple(timestamps, poses), "trajectory");
  py::gil_scoped_release release;
  WriteTumTrajectory(path, t);
}

}  // namespace

void RegisterData(py::module_& m) {
  py::class_<PyDataset>(m, "Dataset", "A dataset folder (use dypho.open_dataset).")
      .def(py::init<const std::string&, const std::string&, const std::string&, double, double, double>(),
           py::arg("folder"), py::arg("camera_preset"), py::arg("camera_file"), py::arg("depth_factor"),
           py::arg("max_depth_dt"), py::arg("frame_rate"))
      .def("__len__", &PyDataset::size)
      .def("load", &PyDataset::Load, py::arg("index"), "Frame `index` as a dict of arrays (decoded without the GIL).")
      .def_property_readonly("camera", [](const PyDataset& d) { return d.dataset().camera(); })
      .def_property_readonly("depth_factor", [](const PyDataset& d) { return d.dataset().depth_factor(); })
      .def_property_readonly("name", [](const PyDataset& d) { return d.dataset().name(); })
      .def_property_readonly("folder", [](const PyDataset& d) { return d.dataset().folder(); })
      .def_property_readonly("format", [](const PyDataset& d) { return d.dataset().format(); })
      .def_property_readonly("ground_truth", [](const PyDataset& d) {
        return d.dataset().has_ground_truth() ? py::object(TrajectoryToPython(d.dataset().ground_truth()))
                                              : py::object(py::none());
      });
  m.def("ate", &AtePy, py::arg("gt"), py::arg("est"), py::arg("max_dt") = 0.02, py::arg("offset") = 0.0,
        py::arg("scale") = false, "Absolute trajectory error (see dypho.ate).");
  m.def("rpe", &RpePy, py::arg("gt"), py::arg("est"), py::arg("delta") = 1.0, py::arg("offset") = 0.0,
        py::arg("scale") = 1.0, "Relative pose error (see dypho.rpe).");
  m.def("read_trajectory", &ReadTrajectoryPy, py::arg("path"), "A TUM trajectory file as (timestamps, poses).");
  m.def("write_trajectory", &WriteTrajectoryPy, py::arg("path"), py::arg("timestamps"), py::arg("poses"),
        "Writes (timestamps, poses) as a TUM trajectory file (atomically).");
}

}  // namespace dypho::python
