// dypho export: converts a saved Gaussian map (any format LoadMap reads) to
// another map format and/or a static dense coloured point cloud.
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "common/check.h"
#include "engine/dense/dense_from_dataset.h"
#include "engine/export/export.h"
#include "engine/export/point_cloud.h"
#include "engine/export/spz.h"
#include "tools/command.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

int RunExport(int argc, char** argv) {
  CLI::App app{
      "Convert a Gaussian map. The output format follows the extension of --out: .ply (3DGS PLY), "
      ".splat (antimatter15 web viewer), .spz (Niantic's compressed format, version 3), .glb or .gltf (glTF 2.0 "
      "with KHR_gaussian_splatting, y-up). "
      "--points writes a static dense coloured point cloud (PLY) from the Gaussian means, optionally "
      "voxel-downsampled and cleaned by statistical outlier removal; with --keyframes and --dataset it is built "
      "from the keyframes' depth instead (the dense map of a run, with normals), and no map is needed.",
      "dypho export"};
  std::string map_path, out_path, points_path, keyframes_path, dataset_path;
  PointCloudOptions points;
  DenseMapOptions dense;
  SpzOptions spz;
  app.add_option("map", map_path, "input map (.ply, .splat, .spz, .glb or .gltf); not needed with --keyframes");
  app.add_option("--out", out_path, "output map file (.ply, .splat, .spz, .glb or .gltf)")->check(NonEmptyPath());
  app.add_option("--spz-version", spz.version, ".spz format version written: 3, or 2 for viewers that read only 2")
      ->capture_default_str()
      ->check(CLI::IsMember({2, 3}));
  app.add_option("--points", points_path, "output point cloud (.ply)")->check(NonEmptyPath());
  app.add_option("--voxel", points.voxel_size, "point cloud voxel-grid cell edge [m] (0 = off)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--outlier-k", points.outlier_neighbors,
                 "point cloud outlier filter: neighbours per point (0 = off)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--outlier-std", points.outlier_std_ratio,
                 "point cloud outlier filter: remove points whose mean neighbour distance exceeds "
                 "mean + this many standard deviations")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--min-opacity", points.min_opacity, "point cloud: skip Gaussians less opaque than this")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 0.999999));
  app.add_option("--keyframes", keyframes_path,
                 "--points from keyframes: a run's keyframes.txt (TUM poses); needs --dataset")
      ->check(CLI::ExistingFile);
  app.add_option("--dataset", dataset_path, "--points from keyframes: the dataset folder the run read")
      ->check(CLI::ExistingDirectory);
  app.add_option("--dense-voxel", dense.map.voxel_size, "--points from keyframes: voxel edge [m]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-depth", dense.points.max_depth, "--points from keyframes: farther depth is dropped [m]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  auto* outlier_k = app.get_option("--outlier-k");
  auto* outlier_std = app.get_option("--outlier-std");
  CLI11_PARSE(app, argc, argv);

  if (!keyframes_path.empty() || !dataset_path.empty()) {
    DYPHO_CHECK_INPUT(!keyframes_path.empty() && !dataset_path.empty())
        << "--points from keyframes needs both --keyframes and --dataset";
    DYPHO_CHECK_INPUT(!points_path.empty()) << "--keyframes and --dataset build a point cloud: give --points";
    DYPHO_CHECK_INPUT(map_path.empty() && out_path.empty())
        << "--keyframes builds the point cloud from the dataset: give no map and no --out";
    // The Gaussian-mean defaults (filter off) do not apply: the dense map's do, unless given.
    if (outlier_k->count() > 0) dense.cloud.outlier_neighbors = points.outlier_neighbors;
    if (outlier_std->count() > 0) dense.cloud.outlier_std_ratio = points.outlier_std_ratio;
    DenseRebuildStats stats;
    const ColoredPoints cloud = DenseCloudFromKeyframes(dataset_path, keyframes_path, dense, &stats);
    SavePointCloudPly(cloud, points_path);
    std::printf("wrote %s: %d points from %d of %d keyframes (%d without depth skipped)\n", points_path.c_str(),
                cloud.size(), stats.used, stats.keyframes, stats.without_depth);
    return 0;
  }
  DYPHO_CHECK_INPUT(!map_path.empty()) << "give a map to convert (or --keyframes and --dataset for --points)";

  DYPHO_CHECK_INPUT(!out_path.empty() || !points_path.empty()) << "nothing to do: give --out and/or --points";
  if (!out_path.empty()) MapFormatFromPath(out_path);  // reject a bad extension before reading
  const GaussianCloud cloud = LoadMap(map_path);
  std::printf("%s: %d Gaussians, SH degree %d\n", map_path.c_str(), cloud.size(),
              cloud.sh_coeffs == 16 ? 3 : cloud.sh_coeffs == 9 ? 2 : cloud.sh_coeffs == 4 ? 1 : 0);
  // An empty map would give a 0-byte .splat or a 0-vertex .ply that looks
  // like a result: refuse, and write nothing.
  DYPHO_CHECK_INPUT(!cloud.empty()) << map_path << ": the map has no Gaussians; nothing written";
  if (!out_path.empty()) {
    if (MapFormatFromPath(out_path) == MapFormat::kSpz) {
      SaveSpz(cloud, out_path, spz);
    } else {
      SaveMap(cloud, out_path);
    }
    std::printf("wrote %s\n", out_path.c_str());
  }
  if (!points_path.empty()) {
    const ColoredPoints cloud_points = StaticPointCloud(cloud, points);
    SavePointCloudPly(cloud_points, points_path);
    std::printf("wrote %s: %d points\n", points_path.c_str(), cloud_points.size());
  }
  return 0;
}

}  // namespace

DYPHO_COMMAND("export", "convert a Gaussian map to .ply/.splat/.spz/.glb/.gltf and a dense point cloud", RunExport);

}  // namespace dypho::tools
