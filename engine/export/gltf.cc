#include "engine/export/gltf.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include <tiny_gltf.h>  // declarations only; the implementation is in libtinygltf

#include "common/check.h"
#include "common/files.h"
#include "engine/export/cloud_checks.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "glTF buffers are little-endian");

namespace dypho {
namespace {

constexpr char kExtension[] = "KHR_gaussian_splatting";

// Sign of each SH basis function (3DGS ordering) under (x, y, z) -> (x, -y, -z).
constexpr float kShSignRotX180[16] = {1, -1, -1, 1, -1, 1, 1, -1, 1, -1, 1, -1, -1, 1, -1, 1};

bool EndsWith(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  std::string tail = s.substr(s.size() - suffix.size());
  std::transform(tail.begin(), tail.end(), tail.begin(), [](unsigned char c) { return std::tolower(c); });
  return tail == suffix;
}

// Appends `bytes` to the single buffer as a new view and accessor.
int AddAccessor(tinygltf::Model* model, const void* bytes, size_t size, size_t count, int type, int component_type,
                bool normalized) {
  tinygltf::Buffer& buffer = model->buffers[0];
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.data.size();
  view.byteLength = size;
  view.target = TINYGLTF_TARGET_ARRAY_BUFFER;
  const unsigned char* p = static_cast<const unsigned char*>(bytes);
  buffer.data.insert(buffer.data.end(), p, p + size);
  model->bufferViews.push_back(view);

  tinygltf::Accessor accessor;
  accessor.bufferView = static_cast<int>(model->bufferViews.size()) - 1;
  accessor.byteOffset = 0;
  accessor.count = count;
  accessor.type = type;
  accessor.componentType = component_type;
  accessor.normalized = normalized;
  model->accessors.push_back(accessor);
  return static_cast<int>(model->accessors.size()) - 1;
}

}  // namespace

void SaveGltf(const GaussianCloud& cloud, const std::string& path) {
  const bool binary = EndsWith(path, ".glb");
  DYPHO_CHECK_INPUT(binary || EndsWith(path, ".gltf"))
      << path << ": a glTF file name must end in .glb (binary) or .gltf (JSON with an embedded buffer)";
  export_internal::CheckCloudForExport(cloud, path);
  DYPHO_CHECK_INPUT(!cloud.empty()) << path << ": the map has no Gaussians; glTF cannot hold an empty point primitive";
  const size_t n = cloud.size();
  const int k = cloud.sh_coeffs;

  // Per-Gaussian values in the glTF frame.
  std::vector<float> positions(3 * n), rotations(4 * n), scales(3 * n), opacities(n);
  std::vector<uint8_t> colors(4 * n);
  std::vector<std::vector<float>> sh(k, std::vector<float>(3 * n));
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t i = 0; i < n; ++i) {
    const float* m = &cloud.means[3 * i];
    const float p[3] = {m[0], -m[1], -m[2]};
    for (int a = 0; a < 3; ++a) {
      positions[3 * i + a] = p[a];
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
      scales[3 * i + a] = std::exp(cloud.log_scales[3 * i + a]);
      DYPHO_CHECK_INPUT(std::isfinite(scales[3 * i + a]) && scales[3 * i + a] > 0)
          << path << ": Gaussian " << i << " has log_scale " << cloud.log_scales[3 * i + a]
          << ", whose exponential is not a positive float32";
    }
    double q[4];  // w x y z, unit
    export_internal::NormalizedQuat(cloud, static_cast<int>(i), path, q);
    // (w=0, x=1) * q = (-x, w, -z, y) as (w, x, y, z); stored as x y z w.
    rotations[4 * i + 0] = static_cast<float>(q[0]);
    rotations[4 * i + 1] = static_cast<float>(-q[3]);
    rotations[4 * i + 2] = static_cast<float>(q[2]);
    rotations[4 * i + 3] = static_cast<float>(-q[1]);
    const double opacity = export_internal::Sigmoid(cloud.opacity_logits[i]);
    opacities[i] = static_cast<float>(opacity);
    const float* coeffs = &cloud.sh[i * k * 3];
    for (int j = 0; j < k; ++j) {
      for (int c = 0; c < 3; ++c) sh[j][3 * i + c] = kShSignRotX180[j] * coeffs[3 * j + c];
    }
    for (int c = 0; c < 3; ++c) {
      colors[4 * i + c] = static_cast<uint8_t>(std::lround(std::clamp(double(ShDcToRgb(coeffs[c])), 0.0, 1.0) * 255));
    }
    colors[4 * i + 3] = static_cast<uint8_t>(std::lround(opacity * 255));
  }

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "dypho";
  model.buffers.resize(1);
  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_POINTS;
  const int position = AddAccessor(&model, positions.data(), positions.size() * sizeof(float), n,
                                   TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, false);
  model.accessors[position].minValues = {lo[0], lo[1], lo[2]};
  model.accessors[position].maxValues = {hi[0], hi[1], hi[2]};
  primitive.attributes["POSITION"] = position;
  primitive.attributes["COLOR_0"] =
      AddAccessor(&model, colors.data(), colors.size(), n, TINYGLTF_TYPE_VEC4, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, true);
  const std::string prefix = std::string(kExtension) + ":";
  primitive.attributes[prefix + "ROTATION"] = AddAccessor(&model, rotations.data(), rotations.size() * sizeof(float),
                                                          n, TINYGLTF_TYPE_VEC4, TINYGLTF_COMPONENT_TYPE_FLOAT, false);
  primitive.attributes[prefix + "SCALE"] = AddAccessor(&model, scales.data(), scales.size() * sizeof(float), n,
                                                       TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, false);
  primitive.attributes[prefix + "OPACITY"] = AddAccessor(&model, opacities.data(), opacities.size() * sizeof(float),
                                                         n, TINYGLTF_TYPE_SCALAR, TINYGLTF_COMPONENT_TYPE_FLOAT, false);
  for (int j = 0; j < k; ++j) {
    const int degree = static_cast<int>(std::sqrt(double(j)) + 1e-9);
    const int coef = j - degree * degree;
    const std::string name = prefix + "SH_DEGREE_" + std::to_string(degree) + "_COEF_" + std::to_string(coef);
    primitive.attributes[name] = AddAccessor(&model, sh[j].data(), sh[j].size() * sizeof(float), n,
                                             TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, false);
  }
  tinygltf::Value::Object extension;
  extension["kernel"] = tinygltf::Value(std::string("ellipse"));
  extension["colorSpace"] = tinygltf::Value(std::string("srgb_rec709_display"));
  extension["projection"] = tinygltf::Value(std::string("perspective"));
  extension["sortingMethod"] = tinygltf::Value(std::string("cameraDistance"));
  primitive.extensions[kExtension] = tinygltf::Value(std::move(extension));

  tinygltf::Mesh mesh;
  mesh.name = "dypho_map";
  mesh.primitives.push_back(std::move(primitive));
  model.meshes.push_back(std::move(mesh));
  tinygltf::Node node;
  node.name = "dypho_map";
  node.mesh = 0;
  model.nodes.push_back(std::move(node));
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(std::move(scene));
  model.defaultScene = 0;
  model.extensionsUsed.push_back(kExtension);

  std::ostringstream stream;
  tinygltf::TinyGLTF writer;
  DYPHO_CHECK_INPUT(writer.WriteGltfSceneToStream(&model, stream, /*prettyPrint=*/!binary, binary))
      << path << ": tinygltf failed to serialise the map";
  WriteTextAtomically(path, stream.str());
}

}  // namespace dypho
