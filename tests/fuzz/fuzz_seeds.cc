// Writes the seed corpora of tests/fuzz/build.sh: small valid maps in every
// format dypho reads (saved by dypho's own writers), one file per format.
#include <cstdio>
#include <string>

#include "engine/export/export.h"
#include "engine/export/spz.h"
#include "engine/gaussians.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_seeds OUT_DIR (writes OUT_DIR/{ply,splat,gltf,glb,spz}/seed_N.*)\n");
    return 2;
  }
  const std::string out = argv[1];
  for (int sh_coeffs : {1, 4}) {
    dypho::GaussianCloud cloud;
    cloud.sh_coeffs = sh_coeffs;
    for (int i = 0; i < 3; ++i) {
      const float mean[3] = {0.1f * i, -0.2f, 2.0f + i}, log_scale[3] = {-3, -2.5f, -2}, quat[4] = {1, 0.1f * i, 0, 0};
      float sh[48] = {};
      for (int c = 0; c < 3 * sh_coeffs; ++c) sh[c] = 0.1f * (c % 7) - 0.3f;
      cloud.Add(mean, log_scale, quat, 0.5f * i, sh);
    }
    const std::string n = std::to_string(sh_coeffs);
    for (const char* ext : {"ply", "splat", "gltf", "glb", "spz"}) {
      dypho::SaveMap(cloud, out + "/" + ext + "/seed_" + n + "." + ext);
    }
  }
  return 0;
}
