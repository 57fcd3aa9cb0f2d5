// The parts of the dypho._core extension, each registered by its own file.
#pragma once

#include <pybind11/pybind11.h>

namespace dypho::python {

void RegisterEngine(pybind11::module_& m);   // engine.cc: Engine
void RegisterMaps(pybind11::module_& m);     // maps.cc: load_map, save_map, render_map
void RegisterData(pybind11::module_& m);     // data.cc: Dataset, trajectories, ate, rpe
void RegisterRun(pybind11::module_& m);      // run.cc: Options, run, synthetic sequences

}  // namespace dypho::python
