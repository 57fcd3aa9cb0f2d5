#include "tools/python/src/arrays.h"

#include <pybind11/stl.h>

#include <cmath>
#include <cstring>
#include <sstream>

namespace dypho::python {

std::string Describe(const py::array& a) {
  std::ostringstream s;
  s << py::str(a.dtype()).cast<std::string>() << " (";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) s << (d ? ", " : "") << a.shape(d);
  s << (a.ndim() == 1 ? ",)" : ")");
  return s.str();
}

namespace {

template <typename T>
std::string TypeName();
template <>
std::string TypeName<uint8_t>() { return "uint8"; }
template <>
std::string TypeName<uint16_t>() { return "uint16"; }
template <>
std::string TypeName<float>() { return "float32"; }
template <>
std::string TypeName<double>() { return "float64"; }

}  // namespace

template <typename T>
py::array_t<T> CheckedArray(const py::handle& obj, const std::string& name, const std::vector<py::ssize_t>& shape,
                            const std::string& shape_text) {
  if (!py::isinstance<py::array>(obj)) {
    throw ArgumentError(name + " must be a NumPy array (" + TypeName<T>() + ", shape " + shape_text + "), got " +
                        py::str(py::type::of(obj).attr("__name__")).cast<std::string>());
  }
  const py::array a = py::reinterpret_borrow<py::array>(obj);
  if (!py::isinstance<py::array_t<T, 0>>(a) || a.itemsize() != static_cast<py::ssize_t>(sizeof(T))) {
    throw ArgumentError(name + " must have dtype " + TypeName<T>() + ", got " + Describe(a));
  }
  bool shape_ok = a.ndim() == static_cast<py::ssize_t>(shape.size());
  for (size_t d = 0; shape_ok && d < shape.size(); ++d) shape_ok = shape[d] < 0 || a.shape(d) == shape[d];
  if (!shape_ok) throw ArgumentError(name + " must have shape " + shape_text + ", got " + Describe(a));
  if (!(a.flags() & py::array::c_style)) {
    throw ArgumentError(name + " must be C-contiguous (row-major, no strides); pass numpy.ascontiguousarray(" + name +
                        ")");
  }
  return py::reinterpret_borrow<py::array_t<T>>(a);
}

template py::array_t<uint8_t> CheckedArray<uint8_t>(const py::handle&, const std::string&,
                                                    const std::vector<py::ssize_t>&, const std::string&);
template py::array_t<uint16_t> CheckedArray<uint16_t>(const py::handle&, const std::string&,
                                                      const std::vector<py::ssize_t>&, const std::string&);
template py::array_t<float> CheckedArray<float>(const py::handle&, const std::string&,
                                                const std::vector<py::ssize_t>&, const std::string&);
template py::array_t<double> CheckedArray<double>(const py::handle&, const std::string&,
                                                  const std::vector<py::ssize_t>&, const std::string&);

namespace {

// A small float array argument (pose parts): any float dtype, any layout.
std::vector<double> SmallFloatArray(const py::handle& obj, const std::string& name, const std::vector<py::ssize_t>& shape,
                                    const std::string& shape_text) {
  py::array a;
  if (py::isinstance<py::array>(obj)) {
    a = py::reinterpret_borrow<py::array>(obj);
  } else {
    try {
      a = py::array::ensure(obj);
    } catch (const py::error_already_set&) {
    }
    if (!a) throw ArgumentError(name + " must be an array of shape " + shape_text);
  }
  const char kind = a.dtype().kind();
  if (kind != 'f') throw ArgumentError(name + " must be a float array (float32 or float64), got " + Describe(a));
  bool shape_ok = a.ndim() == static_cast<py::ssize_t>(shape.size());
  for (size_t d = 0; shape_ok && d < shape.size(); ++d) shape_ok = a.shape(d) == shape[d];
  if (!shape_ok) throw ArgumentError(name + " must have shape " + shape_text + ", got " + Describe(a));
  const py::array_t<double, py::array::c_style | py::array::forcecast> d =
      py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  std::vector<double> out(d.data(), d.data() + d.size());
  for (double v : out) {
    if (!std::isfinite(v)) throw ArgumentError(name + " holds a non-finite value");
  }
  return out;
}

}  // namespace

Rigid3d PoseFromPython(const py::handle& obj, const std::string& name) {
  Rigid3d pose;
  if (py::isinstance<py::tuple>(obj) || py::isinstance<py::list>(obj)) {
    const py::sequence seq = py::reinterpret_borrow<py::sequence>(obj);
    if (seq.size() != 2) {
      throw ArgumentError(name + " must be a 4x4 array or a pair (quaternion w x y z, translation x y z)");
    }
    const std::vector<double> q = SmallFloatArray(seq[0], name + "[0] (quaternion w x y z)", {4}, "(4,)");
    const std::vector<double> t = SmallFloatArray(seq[1], name + "[1] (translation)", {3}, "(3,)");
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (norm < 1e-12) throw ArgumentError(name + "[0] (quaternion) is zero");
    pose.rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
    if (std::fabs(norm - 1.0) > 1e-12) pose.rotation.normalize();
    pose.translation = Eigen::Vector3d(t[0], t[1], t[2]);
    return pose;
  }
  const std::vector<double> m = SmallFloatArray(obj, name, {4, 4}, "(4, 4)");
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = m[4 * i + j];
  if (std::fabs(m[12]) > 1e-9 || std::fabs(m[13]) > 1e-9 || std::fabs(m[14]) > 1e-9 || std::fabs(m[15] - 1) > 1e-9)
    throw ArgumentError(name + ": the last row of a 4x4 pose must be (0, 0, 0, 1)");
  const double orthogonality = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > 1e-5 || r.determinant() < 0)
    throw ArgumentError(name + ": the upper-left 3x3 block is not a rotation (R^T R differs from I by " +
                        std::to_string(orthogonality) + ")");
  pose.rotation = Eigen::Quaterniond(r).normalized();
  pose.translation = Eigen::Vector3d(m[3], m[7], m[11]);
  return pose;
}

py::tuple TrajectoryToPython(const Trajectory& t) {
  py::array_t<double> times(t.size());
  py::array_t<double> poses({static_cast<py::ssize_t>(t.size()), py::ssize_t(4), py::ssize_t(4)});
  for (size_t i = 0; i < t.size(); ++i) {
    times.mutable_at(i) = t.timestamps[i];
    const Eigen::Matrix4d m = t.world_from_cam[i].ToMatrix4();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) poses.mutable_at(i, r, c) = m(r, c);
  }
  return py::make_tuple(times, poses);
}

py::array_t<double> PoseToNumpy(const Rigid3d& world_from_cam) {
  py::array_t<double> out({4, 4});
  const Eigen::Matrix4d m = world_from_cam.ToMatrix4();
  double* d = out.mutable_data();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) d[4 * i + j] = m(i, j);
  return out;
}

py::tuple PoseToQuaternionTranslation(const Rigid3d& world_from_cam) {
  py::array_t<double> q(4), t(3);
  const Eigen::Quaterniond& r = world_from_cam.rotation;
  const double qv[4] = {r.w(), r.x(), r.y(), r.z()};
  std::memcpy(q.mutable_data(), qv, sizeof(qv));
  std::memcpy(t.mutable_data(), world_from_cam.translation.data(), 3 * sizeof(double));
  return py::make_tuple(q, t);
}

Camera CameraFromPython(const py::handle& obj, const std::string& name) {
  try {
    return obj.cast<Camera>();
  } catch (const py::cast_error&) {
    throw ArgumentError(name + " must be a dypho.Camera, got " +
                        py::str(py::type::of(obj).attr("__name__")).cast<std::string>());
  }
}

py::array_t<float> VectorToNumpy(const std::vector<float>& values, const std::vector<py::ssize_t>& shape) {
  py::array_t<float> out(shape);
  if (!values.empty()) std::memcpy(out.mutable_data(), values.data(), values.size() * sizeof(float));
  return out;
}

py::dict CloudToDict(const GaussianCloud& cloud) {
  const py::ssize_t n = cloud.size();
  py::dict d;
  d["means"] = VectorToNumpy(cloud.means, {n, 3});
  d["log_scales"] = VectorToNumpy(cloud.log_scales, {n, 3});
  d["quats"] = VectorToNumpy(cloud.quats, {n, 4});
  d["opacity_logits"] = VectorToNumpy(cloud.opacity_logits, {n});
  d["sh"] = VectorToNumpy(cloud.sh, {n, cloud.sh_coeffs, 3});
  return d;
}

GaussianCloud CloudFromDict(const py::handle& obj, const std::string& name) {
  if (!py::isinstance<py::dict>(obj)) {
    throw ArgumentError(name + " must be a dict of arrays (means, log_scales, quats, opacity_logits, sh), got " +
                        py::str(py::type::of(obj).attr("__name__")).cast<std::string>());
  }
  const py::dict d = py::reinterpret_borrow<py::dict>(obj);
  auto get = [&](const char* key) {
    if (!d.contains(key)) throw ArgumentError(name + " has no '" + key + "' array");
    return d[key];
  };
  const py::handle opacity = get("opacity_logits");
  if (!py::isinstance<py::array>(opacity)) throw ArgumentError(name + "['opacity_logits'] must be a NumPy array");
  const py::ssize_t n = py::reinterpret_borrow<py::array>(opacity).ndim() == 1
                            ? py::reinterpret_borrow<py::array>(opacity).shape(0)
                            : -1;
  if (n < 0) throw ArgumentError(name + "['opacity_logits'] must have shape (N,)");
  const std::string count = std::to_string(n);
  const py::handle sh_obj = get("sh");
  py::ssize_t k = 1;
  if (py::isinstance<py::array>(sh_obj) && py::reinterpret_borrow<py::array>(sh_obj).ndim() == 3)
    k = py::reinterpret_borrow<py::array>(sh_obj).shape(1);
  if (k != 1 && k != 4 && k != 9 && k != 16)
    throw ArgumentError(name + "['sh'] must have shape (N, K, 3) with K = 1, 4, 9 or 16, got K = " + std::to_string(k));
  GaussianCloud cloud;
  cloud.sh_coeffs = static_cast<int>(k);
  auto copy = [&](const char* key, std::vector<py::ssize_t> shape, const std::string& text, std::vector<float>* out) {
    const py::array_t<float> a = CheckedArray<float>(get(key), name + "['" + key + "']", shape, text);
    out->assign(a.data(), a.data() + a.size());
  };
  copy("means", {n, 3}, "(" + count + ", 3)", &cloud.means);
  copy("log_scales", {n, 3}, "(" + count + ", 3)", &cloud.log_scales);
  copy("quats", {n, 4}, "(" + count + ", 4)", &cloud.quats);
  copy("opacity_logits", {n}, "(" + count + ",)", &cloud.opacity_logits);
  copy("sh", {n, k, 3}, "(" + count + ", " + std::to_string(k) + ", 3)", &cloud.sh);
  return cloud;
}

py::array ImageToNumpy(const ImageU8& image) {
  std::vector<py::ssize_t> shape = {image.height(), image.width()};
  if (image.channels() > 1) shape.push_back(image.channels());
  py::array_t<uint8_t> out(shape);
  if (image.size() > 0) std::memcpy(out.mutable_data(), image.data(), image.size());
  return out;
}

py::array ImageToNumpy(const ImageF& image) {
  std::vector<py::ssize_t> shape = {image.height(), image.width()};
  if (image.channels() > 1) shape.push_back(image.channels());
  py::array_t<float> out(shape);
  if (image.size() > 0) std::memcpy(out.mutable_data(), image.data(), image.size() * sizeof(float));
  return out;
}

bool OnMainThread() {
  const py::object threading = py::module_::import("threading");
  return threading.attr("current_thread")().is(threading.attr("main_thread")());
}

}  // namespace dypho::python
