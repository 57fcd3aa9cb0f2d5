// Map files and offline rendering for Python: load_map / save_map in every
// format of engine/export/export.h, render_map with the CPU rasterizer.
#include <pybind11/stl.h>

#include <array>

#include "engine/export/export.h"
#include "engine/export/spz.h"
#include "engine/render/render.h"
#include "tools/python/src/arrays.h"
#include "tools/python/src/module.h"

namespace dypho::python {
namespace {

py::dict LoadMapPy(const std::string& path) {
  GaussianCloud cloud;
  {
    py::gil_scoped_release release;
    cloud = LoadMap(path);
  }
  return CloudToDict(cloud);
}

void SaveMapPy(const py::handle& map, const std::string& path, int spz_version) {
  const GaussianCloud cloud = CloudFromDict(map, "map");
  SpzOptions spz;
  spz.version = spz_version;
  std::string error;
  if (!spz.IsValid(&error)) throw ArgumentError("spz_version must be 2 or 3, got " + std::to_string(spz_version));
  py::gil_scoped_release release;
  if (MapFormatFromPath(path) == MapFormat::kSpz) {
    SaveSpz(cloud, path, spz);
  } else {
    SaveMap(cloud, path);
  }
}

py::dict RenderMapPy(const py::handle& map, const py::handle& camera_obj, const py::handle& pose_obj,
                     const std::string& mode, int sh_degree, const std::array<float, 3>& background, int threads) {
  const GaussianCloud cloud = CloudFromDict(map, "map");
  const Camera camera = CameraFromPython(camera_obj, "camera");
  const Rigid3d cam_from_world = PoseFromPython(pose_obj, "pose").Inverse();
  kernels::RasterSettings settings;
  if (mode == "sorted") {
    settings.mode = kernels::CompositeMode::kSorted;
  } else if (mode == "oit") {
    settings.mode = kernels::CompositeMode::kOrderIndependent;
  } else {
    throw ArgumentError("mode must be 'sorted' or 'oit', got '" + mode + "'");
  }
  settings.sh_degree = sh_degree;
  for (int c = 0; c < 3; ++c) settings.background[c] = background[c];
  settings.num_threads = threads;
  std::string error;
  if (!settings.IsValid(&error)) throw ArgumentError(error);
  camera.Validate("camera");
  RenderedView view;
  ImageF depth;
  {
    py::gil_scoped_release release;
    view = RenderView(cloud, camera, cam_from_world, settings);
    depth = NormalizedDepth(view);
  }
  py::dict d;
  d["color"] = ImageToNumpy(view.color);
  d["depth"] = ImageToNumpy(depth);
  d["alpha"] = ImageToNumpy(view.alpha);
  return d;
}

}  // namespace

void RegisterMaps(py::module_& m) {
  m.def("load_map", &LoadMapPy, py::arg("path"), "Reads a map file (any format); returns the map dict.");
  m.def("save_map", &SaveMapPy, py::arg("map"), py::arg("path"), py::arg("spz_version") = 3,
        "Writes a map dict in the format of the file extension (atomically).");
  m.def("render_map", &RenderMapPy, py::arg("map"), py::arg("camera"), py::arg("pose"), py::arg("mode") = "sorted",
        py::arg("sh_degree") = 3, py::arg("background") = std::array<float, 3>{0, 0, 0}, py::arg("threads") = 0,
        "Renders a map dict with the CPU rasterizer; returns color, depth and alpha arrays.");
}

}  // namespace dypho::python
