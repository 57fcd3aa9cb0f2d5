// The options tree and the whole system for Python: dypho._core.Options
// (engine/pipeline/pipeline_options.h: every key of `dypho run
// --print-config`), run() over RunPipeline with the outputs of `dypho run`,
// and the built-in synthetic sequence.
//
// Ctrl-C during run(): on Python's main thread a SIGINT handler of its own
// replaces Python's while the run lasts (Python cannot run its handler while
// the GIL is released). The first Ctrl-C stops after the current frame; the
// outputs of the frames processed are written as `dypho run` writes them,
// then run() raises KeyboardInterrupt. A second Ctrl-C exits the process at
// once (exit status 130; every file already written is complete).
#include <pybind11/stl.h>

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>

#include "engine/dataset/dataset.h"
#include "engine/pipeline/pipeline.h"
#include "engine/pipeline/pipeline_options.h"
#include "tools/python/src/arrays.h"
#include "tools/python/src/module.h"

namespace dypho::python {
namespace {

std::atomic<bool> g_stop{false};

extern "C" void OnInterrupt(int) {
  if (g_stop.exchange(true)) _exit(130);
  const char message[] = "\ndypho: interrupted; writing the outputs of the frames processed (Ctrl-C again to quit)\n";
  const ssize_t ignored = write(2, message, sizeof(message) - 1);
  (void)ignored;
}

// Installs OnInterrupt for SIGINT while alive (on the main thread only).
class InterruptScope {
 public:
  explicit InterruptScope(bool install) : installed_(install) {
    g_stop = false;
    if (!installed_) return;
    struct sigaction action {};
    action.sa_handler = OnInterrupt;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &previous_);
  }
  ~InterruptScope() {
    if (installed_) sigaction(SIGINT, &previous_, nullptr);
  }
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

 private:
  bool installed_;
  struct sigaction previous_ {};
};

py::dict ResultToDict(const PipelineResult& r) {
  py::dict d;
  d["dataset"] = r.dataset;
  d["frames"] = r.frames;
  d["tracked"] = r.tracked;
  d["lost"] = r.lost;
  d["interrupted"] = r.interrupted;
  d["trajectory"] = TrajectoryToPython(r.trajectory);
  d["ate_rmse"] = r.has_ate ? py::object(py::float_(r.ate_rmse)) : py::none();
  d["rpe_translation_rmse"] = r.has_rpe ? py::object(py::float_(r.rpe_translation_rmse)) : py::none();
  d["rpe_rotation_rmse"] = r.has_rpe ? py::object(py::float_(r.rpe_rotation_rmse)) : py::none();
  d["psnr"] = r.psnr;
  d["ssim"] = r.ssim;
  d["depth_l1"] = r.depth_l1;
  d["scored_frames"] = r.scored_frames;
  d["keyframes"] = r.keyframes;
  d["mapped_keyframes"] = r.mapped_keyframes;
  d["late_keyframes"] = r.late_keyframes;
  d["spilled_keyframes"] = r.spilled_keyframes;
  d["final_stop"] = r.final_stop;
  d["shortened_keyframes"] = r.shortened_keyframes;
  d["max_backlog"] = r.max_backlog;
  d["num_gaussians"] = r.num_gaussians;
  d["tracking_fps"] = r.tracking_fps;
  d["loop_seconds"] = r.loop_seconds;
  d["finish_seconds"] = r.finish_seconds;
  d["final_iterations"] = r.final_iterations;
  d["total_seconds"] = r.total_seconds;
  d["mean_mask_fraction"] = r.mean_mask_fraction;
  d["peak_rss_bytes"] = r.peak_rss_bytes;
  d["report_path"] = r.report_path;
  return d;
}

py::dict RunPy(const std::optional<std::string>& dataset_folder, const std::string& out_dir,
               const PipelineOptions& options, bool progress) {
  options.Validate();
  const bool main_thread = OnMainThread();
  PipelineResult result;
  {
    py::gil_scoped_release release;
    std::unique_ptr<Dataset> dataset;
    if (dataset_folder) {
      dataset = OpenDataset(*dataset_folder);
    } else {
      dataset = MakeBuiltInSequence(options, (std::filesystem::path(out_dir) / "sequence").string());
    }
    InterruptScope interrupts(main_thread);
    PipelineHooks hooks;
    hooks.stop = &g_stop;
    hooks.show_progress = progress;
    result = RunPipeline(options, *dataset, out_dir, hooks);
  }
  if (result.interrupted) {
    const std::string message = "dypho.run interrupted after " + std::to_string(result.frames) +
                                " frames; the outputs of those frames are in " + out_dir;
    PyErr_SetString(PyExc_KeyboardInterrupt, message.c_str());
    throw py::error_already_set();
  }
  return ResultToDict(result);
}

std::string GetOption(PipelineOptions& options, const std::string& key) {
  for (const OptionInfo& info : DescribeOptions(&options)) {
    if (info.key == key) return info.get();
  }
  throw ArgumentError("unknown option key '" + key + "'");
}

}  // namespace

void RegisterRun(py::module_& m) {
  py::class_<PipelineOptions>(m, "Options",
                              "The options tree of `dypho run` (every key of `dypho run --print-config`). Build one "
                              "with dypho.options().")
      .def(py::init([](const std::string& preset) { return PresetOptions(preset); }), py::arg("preset") = "synthetic",
           "The defaults with a preset applied (synthetic, tum, bonn or shore).")
      .def(
          "set", [](PipelineOptions& o, const std::string& key, const std::string& value) { SetOption(&o, key, value); },
          py::arg("key"), py::arg("value"), "Sets one dotted key from text, as --set key=value.")
      .def(
          "apply_text",
          [](PipelineOptions& o, const std::string& text, const std::string& origin) {
            ApplyConfigText(&o, text, origin);
          },
          py::arg("text"), py::arg("origin"), "Applies YAML or JSON text, as a --config file.")
      .def(
          "apply_file", [](PipelineOptions& o, const std::string& path) { ApplyConfigFile(&o, path); },
          py::arg("path"), "Applies a YAML or JSON file, as --config.")
      .def(
          "disable", [](PipelineOptions& o, const std::string& stage) { DisableStage(&o, stage); }, py::arg("stage"),
          "Switches a stage off, as --disable.")
      .def("validate", &PipelineOptions::Validate, "Raises InvalidInput naming the first invalid key.")
      .def(
          "get", [](PipelineOptions& o, const std::string& key) { return GetOption(o, key); }, py::arg("key"),
          "The value of a dotted key as text.")
      .def(
          "keys",
          [](PipelineOptions& o) {
            std::vector<std::string> keys;
            for (const OptionInfo& info : DescribeOptions(&o)) keys.push_back(info.key);
            return keys;
          },
          "Every dotted key.")
      .def(
          "format", [](const PipelineOptions& o) { return FormatOptions(o); },
          "Every option as YAML with units and ranges (what --print-config prints).")
      .def("copy", [](const PipelineOptions& o) { return PipelineOptions(o); })
      .def_readonly("preset", &PipelineOptions::preset);
  m.def("run", &RunPy, py::arg("dataset"), py::arg("out"), py::arg("options"), py::arg("progress") = true,
        "The whole system (see dypho.run).");
  m.def(
      "preset_for_dataset",
      [](const std::string& folder) {
        py::gil_scoped_release release;
        return PresetForDataset(*OpenDataset(folder));
      },
      py::arg("folder"), "The preset `dypho run` picks for a dataset folder.");
  m.def(
      "make_synthetic_sequence",
      [](const std::string& folder, const PipelineOptions& options) {
        options.Validate();
        py::gil_scoped_release release;
        MakeBuiltInSequence(options, folder);
      },
      py::arg("folder"), py::arg("options"), "Writes the built-in synthetic sequence (options' synth.* keys).");
}

}  // namespace dypho::python
