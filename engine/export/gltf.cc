#include "engine/export/gltf.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
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
      const float sign = export_internal::kShSignRotX180[j];
      for (int c = 0; c < 3; ++c) PutFloat(buffer, sh_offset[j] + 12 * i + 4 * c, sign * coeffs[3 * j + c]);
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

namespace {

// Element `i` of an accessor as `components` floats, checked against the
// view and buffer bounds once in the constructor.
class AccessorReader {
 public:
  AccessorReader(const tinygltf::Model& model, int index, int type, bool allow_normalized_ints,
                 const std::string& what)
      : what_(what) {
    DYPHO_CHECK_INPUT(index >= 0 && index < static_cast<int>(model.accessors.size()))
        << what << ": accessor " << index << " does not exist";
    const tinygltf::Accessor& a = model.accessors[index];
    DYPHO_CHECK_INPUT(a.type == type) << what << ": expected " << TypeName(type) << ", found " << TypeName(a.type);
    DYPHO_CHECK_INPUT(!a.sparse.isSparse) << what << ": sparse accessors are not supported";
    component_type_ = a.componentType;
    const bool is_float = component_type_ == TINYGLTF_COMPONENT_TYPE_FLOAT;
    const bool is_norm = allow_normalized_ints && a.normalized &&
                         (component_type_ == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                          component_type_ == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
    DYPHO_CHECK_INPUT(is_float || is_norm)
        << what << ": component type " << component_type_ << " is not supported (float"
        << (allow_normalized_ints ? ", or normalized unsigned byte/short" : "") << ")";
    DYPHO_CHECK_INPUT(a.bufferView >= 0 && a.bufferView < static_cast<int>(model.bufferViews.size()))
        << what << ": accessor has no buffer view";
    const tinygltf::BufferView& v = model.bufferViews[a.bufferView];
    DYPHO_CHECK_INPUT(v.buffer >= 0 && v.buffer < static_cast<int>(model.buffers.size()))
        << what << ": buffer view " << a.bufferView << " names no buffer";
    const std::vector<unsigned char>& data = model.buffers[v.buffer].data;
    components_ = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(type));
    component_size_ = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(component_type_));
    const size_t element = static_cast<size_t>(components_) * component_size_;
    stride_ = v.byteStride > 0 ? v.byteStride : element;
    count_ = a.count;
    DYPHO_CHECK_INPUT(stride_ >= element) << what << ": byteStride " << stride_ << " is below the element size "
                                          << element;
    // Every bound is checked by subtraction, never by adding two values read
    // from the file (an offset near 2^64 would wrap around and pass).
    DYPHO_CHECK_INPUT(v.byteOffset <= data.size() && v.byteLength <= data.size() - v.byteOffset)
        << what << ": buffer view " << a.bufferView << " (offset " << v.byteOffset << ", length " << v.byteLength
        << ") reaches past the end of its " << data.size() << "-byte buffer (file truncated or corrupt?)";
    const bool fits = count_ == 0 || (a.byteOffset <= v.byteLength && element <= v.byteLength - a.byteOffset &&
                                      count_ - 1 <= (v.byteLength - a.byteOffset - element) / stride_);
    DYPHO_CHECK_INPUT(fits) << what << ": " << count_ << " elements reach past the end of their buffer (offset "
                            << a.byteOffset << " in a " << v.byteLength
                            << "-byte buffer view; file truncated or corrupt?)";
    base_ = data.data() + v.byteOffset + a.byteOffset;
  }
  size_t count() const { return count_; }
  const std::string& what() const { return what_; }  // "file: attribute"
  // Component c of element i as float (normalized integers in [0, 1]).
  float Get(size_t i, int c) const {
    const unsigned char* p = base_ + i * stride_ + static_cast<size_t>(c) * component_size_;
    if (component_type_ == TINYGLTF_COMPONENT_TYPE_FLOAT) {
      float f;
      std::memcpy(&f, p, sizeof(f));
      return f;
    }
    if (component_type_ == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) return p[0] / 255.0f;
    uint16_t u;
    std::memcpy(&u, p, sizeof(u));
    return u / 65535.0f;
  }

 private:
  static std::string TypeName(int type) {
    switch (type) {
      case TINYGLTF_TYPE_SCALAR:
        return "SCALAR";
      case TINYGLTF_TYPE_VEC3:
        return "VEC3";
      case TINYGLTF_TYPE_VEC4:
        return "VEC4";
      default:
        return "type " + std::to_string(type);
    }
  }
  std::string what_;
  const unsigned char* base_ = nullptr;
  size_t count_ = 0, stride_ = 0;
  int components_ = 0, component_type_ = 0, component_size_ = 0;
};

// File access for tinygltf: only files under the glTF file's own folder may
// be read (a URI such as "/etc/passwd", "../../x" or "%2F.." is refused), and
// paths are used as written (the default expands "~" and shell words).
struct FolderGuard {
  std::filesystem::path folder;  // canonical
  std::string refused;           // the first existing path refused, for the message
  bool Allows(const std::string& path) {
    std::error_code ec;
    const std::filesystem::path p = std::filesystem::weakly_canonical(path, ec);
    if (!ec) {
      auto f = folder.begin(), q = p.begin();
      for (; f != folder.end() && q != p.end() && *f == *q; ++f, ++q) {
      }
      if (f == folder.end()) return true;
    }
    // (tinygltf also tries the working folder after the file's own: a file
    // missing from both is reported as missing, not as refused.)
    if (refused.empty() && std::filesystem::exists(path, ec)) refused = path;
    return false;
  }
};

bool GuardedFileExists(const std::string& path, void* user) {
  std::error_code ec;
  return static_cast<FolderGuard*>(user)->Allows(path) && std::filesystem::is_regular_file(path, ec);
}
std::string UnexpandedPath(const std::string& path, void*) { return path; }
bool GuardedReadWholeFile(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  if (!static_cast<FolderGuard*>(user)->Allows(path)) {
    if (err) *err += "refused: outside the glTF file's folder";
    return false;
  }
  return tinygltf::ReadWholeFile(out, err, path, nullptr);
}
bool RefuseWrite(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "writing is not allowed while reading";
  return false;
}
// Images are never decoded: the splat primitive uses none (a large unused
// texture would cost its full decoded size in memory).
bool SkipImage(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

}  // namespace

GaussianCloud LoadGltf(const std::string& path) {
  const bool binary = EndsWith(path, ".glb");
  DYPHO_CHECK_INPUT(binary || EndsWith(path, ".gltf")) << path << ": a glTF file name must end in .glb or .gltf";
  std::error_code ec;
  DYPHO_CHECK_INPUT(std::filesystem::is_regular_file(path, ec)) << path << ": no such file";
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  FolderGuard guard;
  guard.folder = std::filesystem::weakly_canonical(std::filesystem::absolute(path, ec).parent_path(), ec);
  loader.SetFsCallbacks({GuardedFileExists, UnexpandedPath, GuardedReadWholeFile, RefuseWrite, &guard});
  loader.SetImageLoader(SkipImage, nullptr);
  std::string err, warn;
  const bool ok = binary ? loader.LoadBinaryFromFile(&model, &err, &warn, path)
                         : loader.LoadASCIIFromFile(&model, &err, &warn, path);
  DYPHO_CHECK_INPUT(ok || guard.refused.empty())
      << path << ": a URI points outside the file's folder (" << guard.refused
      << "); only relative paths under it are read";
  DYPHO_CHECK_INPUT(ok) << path << ": not a readable glTF file: " << (err.empty() ? "tinygltf failed" : err);

  const std::string prefix = std::string(kExtension) + ":";
  const tinygltf::Primitive* splats = nullptr;
  for (const tinygltf::Mesh& mesh : model.meshes) {
    for (const tinygltf::Primitive& p : mesh.primitives) {
      if (!splats && p.attributes.count(prefix + "ROTATION")) splats = &p;
    }
  }
  DYPHO_CHECK_INPUT(splats) << path << ": no primitive has the " << kExtension
                            << " attributes (a plain point cloud or mesh is not a Gaussian map)";
  auto reader = [&](const std::string& name, int type, bool normalized_ints = false) {
    const auto it = splats->attributes.find(name);
    DYPHO_CHECK_INPUT(it != splats->attributes.end()) << path << ": the splat primitive has no " << name;
    return AccessorReader(model, it->second, type, normalized_ints, path + ": " + name);
  };
  const AccessorReader position = reader("POSITION", TINYGLTF_TYPE_VEC3);
  const AccessorReader rotation = reader(prefix + "ROTATION", TINYGLTF_TYPE_VEC4);
  const AccessorReader scale = reader(prefix + "SCALE", TINYGLTF_TYPE_VEC3);
  const AccessorReader opacity = reader(prefix + "OPACITY", TINYGLTF_TYPE_SCALAR);
  std::vector<AccessorReader> sh;
  for (int degree = 0; degree <= 3; ++degree) {
    int present = 0;
    for (int coef = 0; coef <= 2 * degree; ++coef) {
      present += splats->attributes.count(prefix + "SH_DEGREE_" + std::to_string(degree) + "_COEF_" +
                                          std::to_string(coef));
    }
    if (present == 0) break;
    DYPHO_CHECK_INPUT(present == 2 * degree + 1)
        << path << ": SH degree " << degree << " has " << present << " of its " << 2 * degree + 1 << " coefficients";
    for (int coef = 0; coef <= 2 * degree; ++coef) {
      sh.push_back(reader(prefix + "SH_DEGREE_" + std::to_string(degree) + "_COEF_" + std::to_string(coef),
                          TINYGLTF_TYPE_VEC3));
    }
  }
  std::optional<AccessorReader> colour;  // the fallback without SH
  if (sh.empty()) colour.emplace(reader("COLOR_0", TINYGLTF_TYPE_VEC4, /*normalized_ints=*/true));

  const size_t n = position.count();
  DYPHO_CHECK_INPUT(n > 0) << path << ": the map has no Gaussians";
  std::vector<const AccessorReader*> attributes = {&rotation, &scale, &opacity};
  for (const AccessorReader& r : sh) attributes.push_back(&r);
  if (colour) attributes.push_back(&*colour);
  for (const AccessorReader* r : attributes) {
    DYPHO_CHECK_INPUT(r->count() == n) << r->what() << ": attributes disagree on the number of Gaussians ("
                                       << r->count() << " vs " << n << " positions)";
  }

  GaussianCloud cloud;
  cloud.sh_coeffs = sh.empty() ? 1 : static_cast<int>(sh.size());
  cloud.means.resize(3 * n);
  cloud.log_scales.resize(3 * n);
  cloud.quats.resize(4 * n);
  cloud.opacity_logits.resize(n);
  cloud.sh.resize(3 * n * cloud.sh_coeffs);
  constexpr float kMaxLogit = 16.6f;  // logit(1 - 2^-24)
  for (size_t i = 0; i < n; ++i) {
    // The exporter's change of frame is a rotation by 180 degrees about x:
    // applying it again undoes it.
    const float p[3] = {position.Get(i, 0), -position.Get(i, 1), -position.Get(i, 2)};
    const float qx = rotation.Get(i, 0), qy = rotation.Get(i, 1), qz = rotation.Get(i, 2), qw = rotation.Get(i, 3);
    // Stored (w', x', y', z') = (-x, w, -z, y): w = x', x = -w', y = z', z = -y'.
    const float q[4] = {qx, -qw, qz, -qy};
    for (int a = 0; a < 3; ++a) {
      cloud.means[3 * i + a] = p[a];
      const float s = scale.Get(i, a);
      DYPHO_CHECK_INPUT(s > 0 && std::isfinite(s))
          << path << ": Gaussian " << i << " has scale " << s << " (must be positive and finite)";
      cloud.log_scales[3 * i + a] = std::log(s);
    }
    const float q_norm2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    DYPHO_CHECK_INPUT(std::isfinite(q_norm2)) << path << ": Gaussian " << i << " has a non-finite rotation quaternion ("
                                              << qx << ", " << qy << ", " << qz << ", " << qw << ")";
    DYPHO_CHECK_INPUT(q_norm2 > 0)
        << path << ": Gaussian " << i << " has a zero rotation quaternion";
    for (int a = 0; a < 4; ++a) cloud.quats[4 * i + a] = q[a];
    const float o = opacity.Get(i, 0);
    DYPHO_CHECK_INPUT(o >= 0 && o <= 1) << path << ": Gaussian " << i << " has opacity " << o << " (must be in [0, 1])";
    const double logit = std::log(double(o)) - std::log1p(-double(o));
    cloud.opacity_logits[i] = static_cast<float>(std::clamp(logit, double(-kMaxLogit), double(kMaxLogit)));
    float* coeffs = &cloud.sh[3 * i * cloud.sh_coeffs];
    for (size_t j = 0; j < sh.size(); ++j) {
      for (int c = 0; c < 3; ++c) coeffs[3 * j + c] = export_internal::kShSignRotX180[j] * sh[j].Get(i, c);
    }
    if (colour) {
      for (int c = 0; c < 3; ++c) coeffs[c] = RgbToShDc(colour->Get(i, c));
    }
  }
  export_internal::CheckCloudForExport(cloud, path);  // NaN or infinity anywhere: a clear error
  return cloud;
}

}  // namespace dypho
