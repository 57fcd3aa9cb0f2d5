#include "engine/export/gltf.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
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

// Declares the next `size` bytes of the single buffer as a view with one
// accessor; returns the accessor index. The buffer is sized beforehand.
int AddAccessor(tinygltf::Model* model, size_t* offset, size_t size, size_t count, int type, int component_type,
                bool normalized) {
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = *offset;
  view.byteLength = size;
  view.target = TINYGLTF_TARGET_ARRAY_BUFFER;
  model->bufferViews.push_back(view);
  *offset += size;

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

// Little-endian float `value` at byte `offset` of `buffer`.
inline void PutFloat(std::vector<unsigned char>* buffer, size_t offset, float value) {
  std::memcpy(buffer->data() + offset, &value, sizeof(float));
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

  // Layout: one tightly packed view per attribute, in this order.
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "dypho";
  model.buffers.resize(1);
  std::vector<unsigned char>* buffer = &model.buffers[0].data;
  buffer->resize(n * (12 + 4 + 16 + 12 + 4 + 12 * k));
  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_POINTS;
  const std::string prefix = std::string(kExtension) + ":";
  size_t offset = 0;
  const int position = AddAccessor(&model, &offset, 12 * n, n, TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, false);
  const int color =
      AddAccessor(&model, &offset, 4 * n, n, TINYGLTF_TYPE_VEC4, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, true);
  const int rotation = AddAccessor(&model, &offset, 16 * n, n, TINYGLTF_TYPE_VEC4, TINYGLTF_COMPONENT_TYPE_FLOAT, false);
  const int scale = AddAccessor(&model, &offset, 12 * n, n, TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, false);
  const int opacity_accessor =
      AddAccessor(&model, &offset, 4 * n, n, TINYGLTF_TYPE_SCALAR, TINYGLTF_COMPONENT_TYPE_FLOAT, false);
  primitive.attributes["POSITION"] = position;
  primitive.attributes["COLOR_0"] = color;
  primitive.attributes[prefix + "ROTATION"] = rotation;
  primitive.attributes[prefix + "SCALE"] = scale;
  primitive.attributes[prefix + "OPACITY"] = opacity_accessor;
  std::vector<size_t> sh_offset(k);
  for (int j = 0; j < k; ++j) {
    const int degree = static_cast<int>(std::sqrt(double(j)) + 1e-9);
    const int coef = j - degree * degree;
    const std::string name = prefix + "SH_DEGREE_" + std::to_string(degree) + "_COEF_" + std::to_string(coef);
    sh_offset[j] = offset;
    primitive.attributes[name] =
        AddAccessor(&model, &offset, 12 * n, n, TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, false);
  }
  DYPHO_CHECK(offset == buffer->size()) << "glTF buffer layout: " << offset << " != " << buffer->size();
  auto view_offset = [&](int accessor) { return model.bufferViews[model.accessors[accessor].bufferView].byteOffset; };
  const size_t position_offset = view_offset(position), color_offset = view_offset(color),
               rotation_offset = view_offset(rotation), scale_offset = view_offset(scale),
               opacity_offset = view_offset(opacity_accessor);

  // Per-Gaussian values in the glTF frame.
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t i = 0; i < n; ++i) {
    const float* m = &cloud.means[3 * i];
    const float p[3] = {m[0], -m[1], -m[2]};
    for (int a = 0; a < 3; ++a) {
      PutFloat(buffer, position_offset + 12 * i + 4 * a, p[a]);
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
      const float s = std::exp(cloud.log_scales[3 * i + a]);
      DYPHO_CHECK_INPUT(std::isfinite(s) && s > 0)
          << path << ": Gaussian " << i << " has log_scale " << cloud.log_scales[3 * i + a]
          << ", whose exponential is not a positive float32";
      PutFloat(buffer, scale_offset + 12 * i + 4 * a, s);
    }
    double q[4];  // w x y z, unit
    export_internal::NormalizedQuat(cloud, static_cast<int>(i), path, q);
    // (w=0, x=1) * q = (-x, w, -z, y) as (w, x, y, z); stored as x y z w.
    const float rotated[4] = {static_cast<float>(q[0]), static_cast<float>(-q[3]), static_cast<float>(q[2]),
                              static_cast<float>(-q[1])};
    std::memcpy(buffer->data() + rotation_offset + 16 * i, rotated, 16);
    const double opacity = export_internal::Sigmoid(cloud.opacity_logits[i]);
    PutFloat(buffer, opacity_offset + 4 * i, static_cast<float>(opacity));
    const float* coeffs = &cloud.sh[i * k * 3];
    for (int j = 0; j < k; ++j) {
      for (int c = 0; c < 3; ++c) PutFloat(buffer, sh_offset[j] + 12 * i + 4 * c, kShSignRotX180[j] * coeffs[3 * j + c]);
    }
    unsigned char* rgba = buffer->data() + color_offset + 4 * i;
    for (int c = 0; c < 3; ++c) {
      rgba[c] = static_cast<unsigned char>(std::lround(std::clamp(double(ShDcToRgb(coeffs[c])), 0.0, 1.0) * 255));
    }
    rgba[3] = static_cast<unsigned char>(std::lround(opacity * 255));
  }
  model.accessors[position].minValues = {lo[0], lo[1], lo[2]};
  model.accessors[position].maxValues = {hi[0], hi[1], hi[2]};

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

  WriteFileAtomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    DYPHO_CHECK_INPUT(out.good()) << "cannot open " << tmp << " for writing";
    tinygltf::TinyGLTF writer;
    DYPHO_CHECK_INPUT(writer.WriteGltfSceneToStream(&model, out, /*prettyPrint=*/!binary, binary))
        << path << ": tinygltf failed to serialise the map";
    out.close();
    DYPHO_CHECK_INPUT(out.good()) << "error writing " << tmp;
  });
}

}  // namespace dypho
