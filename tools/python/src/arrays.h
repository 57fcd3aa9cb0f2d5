// NumPy <-> dypho conversions for the Python module, with the checks that
// turn a wrong dtype, shape or memory layout into a ValueError naming the
// argument (ArgumentError below).
//
// Conventions of the whole module:
//   - images are row-major (H, W[, C]) C-contiguous arrays: RGB uint8
//     (H, W, 3); depth uint16 (units of depth_scale) or float32 metres (H, W);
//     masks uint8 or bool (H, W), non-zero = dynamic;
//   - a pose is world_from_cam (camera to world: its translation is the
//     camera centre, as in TUM trajectory files), given as a 4x4 float array
//     or a pair (quaternion (w, x, y, z), translation (3,)); returned as a
//     4x4 float64 array;
//   - a map is a dict of float32 arrays: means (N, 3), log_scales (N, 3),
//     quats (N, 4) w x y z, opacity_logits (N,), sh (N, K, 3) with K = 1, 4,
//     9 or 16.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"
#include "engine/eval/trajectory.h"
#include "engine/gaussians.h"

namespace dypho::python {

namespace py = pybind11;

// Raised for a bad argument; registered as ValueError.
class ArgumentError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// "float64 (480, 640, 3)": an array's dtype and shape for messages.
std::string Describe(const py::array& a);

// `obj` as an array of dtype T with `shape` (-1 = any size), C-contiguous.
// Throws ArgumentError "<name> must be ..." otherwise. No copy.
template <typename T>
py::array_t<T> CheckedArray(const py::handle& obj, const std::string& name, const std::vector<py::ssize_t>& shape,
                            const std::string& shape_text);

// Converts a pose argument (see above) to world_from_cam. Near-unit
// quaternions are copied exactly (so a pose read from a dataset frame goes
// back bit for bit); others are normalised.
Rigid3d PoseFromPython(const py::handle& obj, const std::string& name);
py::array_t<double> PoseToNumpy(const Rigid3d& world_from_cam);
// (timestamps (N,), world_from_cam poses (N, 4, 4)).
py::tuple TrajectoryToPython(const Trajectory& trajectory);
// (quaternion w x y z, translation) as two float64 arrays.
py::tuple PoseToQuaternionTranslation(const Rigid3d& world_from_cam);

// A camera argument: a dypho.Camera.
Camera CameraFromPython(const py::handle& obj, const std::string& name);

py::dict CloudToDict(const GaussianCloud& cloud);
GaussianCloud CloudFromDict(const py::handle& obj, const std::string& name);

py::array ImageToNumpy(const ImageU8& image);  // (H, W, C) or (H, W) for one channel
py::array ImageToNumpy(const ImageF& image);
py::array_t<float> VectorToNumpy(const std::vector<float>& values, const std::vector<py::ssize_t>& shape);

// Whether the calling thread is Python's main thread (where signals are handled).
bool OnMainThread();

}  // namespace dypho::python
