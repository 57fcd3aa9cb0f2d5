// dypho._core: the compiled half of the `dypho` Python package
// (tools/python/dypho/__init__.py is the other half and documents the API).
#include <pybind11/stl.h>

#include <sstream>

#include "common/camera.h"
#include "common/check.h"
#include "tools/python/src/arrays.h"
#include "tools/python/src/module.h"

namespace py = pybind11;

PYBIND11_MODULE(_core, m) {
  using dypho::Camera;
  m.doc() = "dypho's compiled core; use the `dypho` package, which wraps it.";

  // Bad input from the library (a missing file, a corrupt map, an option out
  // of range) is dypho.InvalidInput, a ValueError; bad arguments are plain
  // ValueErrors naming the argument.
  static py::exception<dypho::InvalidInput> invalid_input(m, "InvalidInput", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const dypho::InvalidInput& e) {
      invalid_input(e.message().c_str());
    } catch (const dypho::python::ArgumentError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });

  py::class_<Camera>(m, "Camera",
                     "Pinhole intrinsics with optional OpenCV radial-tangential distortion (k1, k2, p1, p2, k3). "
                     "Pixel centres lie at integer coordinates.")
      .def(py::init([](double fx, double fy, double cx, double cy, int width, int height,
                       const std::array<double, 5>& distortion) {
             Camera c;
             c.fx = fx;
             c.fy = fy;
             c.cx = cx;
             c.cy = cy;
             c.width = width;
             c.height = height;
             c.distortion = distortion;
             c.Validate("Camera");
             return c;
           }),
           py::arg("fx"), py::arg("fy"), py::arg("cx"), py::arg("cy"), py::arg("width"), py::arg("height"),
           py::arg("distortion") = std::array<double, 5>{0, 0, 0, 0, 0},
           "Camera(fx, fy, cx, cy, width, height, distortion=(0, 0, 0, 0, 0)): focal lengths and principal point "
           "[px], image size [px]; raises ValueError for invalid values.")
      .def_readonly("fx", &Camera::fx, "focal length along x [px]")
      .def_readonly("fy", &Camera::fy, "focal length along y [px]")
      .def_readonly("cx", &Camera::cx, "principal point x [px]")
      .def_readonly("cy", &Camera::cy, "principal point y [px]")
      .def_readonly("width", &Camera::width, "image width [px]")
      .def_readonly("height", &Camera::height, "image height [px]")
      .def_readonly("distortion", &Camera::distortion, "k1, k2, p1, p2, k3 (OpenCV order)")
      .def("scaled", &Camera::Scaled, py::arg("factor"), "The camera for images scaled by `factor` (0.5 halves them).")
      .def("__repr__", [](const Camera& c) {
        std::ostringstream s;
        s << "dypho.Camera(fx=" << c.fx << ", fy=" << c.fy << ", cx=" << c.cx << ", cy=" << c.cy
          << ", width=" << c.width << ", height=" << c.height;
        if (c.HasDistortion()) {
          s << ", distortion=(";
          for (int i = 0; i < 5; ++i) s << (i ? ", " : "") << c.distortion[i];
          s << ")";
        }
        s << ")";
        return s.str();
      });

  dypho::python::RegisterEngine(m);
  dypho::python::RegisterMaps(m);
  dypho::python::RegisterData(m);
  dypho::python::RegisterRun(m);
}
