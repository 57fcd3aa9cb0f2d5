// libFuzzer targets for every reader of outside data (issue 16). One source,
// one target per build: -DDYPHO_FUZZ_TARGET=N picks it (tests/fuzz/build.sh
// builds them all with ASan and UBSan). The readers take file paths, so each
// input is written to a file first. A target passes an input when the reader
// returns or throws InvalidInput; anything else (a crash, a sanitizer report,
// another exception, a hang) is a finding.
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "common/check.h"
#include "common/logging.h"

#define DYPHO_FUZZ_PLY 1
#define DYPHO_FUZZ_SPLAT 2
#define DYPHO_FUZZ_GLTF 3
#define DYPHO_FUZZ_GLB 4
#define DYPHO_FUZZ_SPZ 5
#define DYPHO_FUZZ_CAMERA 6
#define DYPHO_FUZZ_TRAJECTORY 7
#define DYPHO_FUZZ_OPTIONS 8
#define DYPHO_FUZZ_DATASET 9
#define DYPHO_FUZZ_PNG 10

#if DYPHO_FUZZ_TARGET <= DYPHO_FUZZ_SPZ
#include "engine/export/export.h"
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_CAMERA
#include "engine/dataset/camera_file.h"
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_TRAJECTORY
#include "engine/eval/trajectory.h"
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_OPTIONS
#include "engine/pipeline/pipeline_options.h"
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_DATASET
#include "engine/dataset/dataset.h"
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_PNG
#include "engine/io/png_decode.h"
#endif

namespace {

// A folder of this process for the input files (tmpfs when there is one).
const std::string& WorkDir() {
  static const std::string dir = [] {
    const std::string d = (access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp") + std::string("/dypho_fuzz_") +
                          std::to_string(getpid());
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

void WriteFile(const std::string& path, const uint8_t* data, size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  dypho::SetLogLevel(dypho::LogLevel::kError);  // warnings for every odd input would flood the run
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string& dir = WorkDir();
  try {
#if DYPHO_FUZZ_TARGET == DYPHO_FUZZ_PLY
    WriteFile(dir + "/map.ply", data, size);
    dypho::LoadMap(dir + "/map.ply");
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_SPLAT
    WriteFile(dir + "/map.splat", data, size);
    dypho::LoadMap(dir + "/map.splat");
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_GLTF
    WriteFile(dir + "/map.gltf", data, size);
    dypho::LoadMap(dir + "/map.gltf");
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_GLB
    WriteFile(dir + "/map.glb", data, size);
    dypho::LoadMap(dir + "/map.glb");
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_SPZ
    WriteFile(dir + "/map.spz", data, size);
    dypho::LoadMap(dir + "/map.spz");
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_CAMERA
    // First byte: YAML or JSON; the rest is the file.
    if (size == 0) return 0;
    const std::string path = dir + ((data[0] & 1) ? "/camera.json" : "/camera.yaml");
    WriteFile(path, data + 1, size - 1);
    dypho::ReadCameraFile(path);
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_TRAJECTORY
    WriteFile(dir + "/trajectory.txt", data, size);
    dypho::ReadTumTrajectory(dir + "/trajectory.txt");
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_OPTIONS
    dypho::PipelineOptions options;
    dypho::ApplyConfigText(&options, std::string(reinterpret_cast<const char*>(data), size), "fuzz.yaml");
    options.Validate();
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_DATASET
    // A generic dataset folder: camera.yaml, then the input split at the
    // first 0 byte into rgb.txt and depth.txt (the images need not exist: the
    // lists are what is read before any pixel).
    static bool camera_written = false;
    const std::string ds = dir + "/ds";
    if (!camera_written) {
      std::filesystem::create_directories(ds);
      const std::string camera = "fx: 100\nfy: 100\ncx: 31.5\ncy: 23.5\nwidth: 64\nheight: 48\n";
      WriteFile(ds + "/camera.yaml", reinterpret_cast<const uint8_t*>(camera.data()), camera.size());
      camera_written = true;
    }
    size_t split = 0;
    while (split < size && data[split] != 0) ++split;
    WriteFile(ds + "/rgb.txt", data, split);
    WriteFile(ds + "/depth.txt", data + std::min(size, split + 1), size - std::min(size, split + 1));
    dypho::OpenDataset(ds);
#elif DYPHO_FUZZ_TARGET == DYPHO_FUZZ_PNG
    // The PNG decoder of dataset frames, as each reader asks it (it never
    // throws: a file it cannot take goes to OpenCV).
    const std::vector<uint8_t> file(data, data + size);
    dypho::PngPixels pixels;
    for (dypho::PngWant want : {dypho::PngWant::kRgb8, dypho::PngWant::kGray8, dypho::PngWant::kGray16})
      dypho::DecodePngFast(file, want, &pixels);
#else
#error "DYPHO_FUZZ_TARGET must name a target"
#endif
  } catch (const dypho::InvalidInput&) {
    // the expected answer to bad input
  }
  return 0;
}
