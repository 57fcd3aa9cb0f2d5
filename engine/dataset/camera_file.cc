#include "engine/dataset/camera_file.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "common/check.h"
#include "common/files.h"
#include "common/logging.h"

namespace dypho {
namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

Camera MakeCamera(double fx, double fy, double cx, double cy, std::array<double, 5> distortion) {
  Camera c;
  c.fx = fx;
  c.fy = fy;
  c.cx = cx;
  c.cy = cy;
  c.width = 640;
  c.height = 480;
  c.distortion = distortion;
  return c;
}

const std::set<std::string> kKnownKeys = {"fx",    "fy",     "cx",         "cy",
                                          "width", "height", "distortion", "depth_factor"};

// A flat key -> value view over YAML or JSON with error messages that name
// the file, the key and (for YAML) the line.
class KeyReader {
 public:
  virtual ~KeyReader() = default;
  virtual bool Has(const std::string& key) const = 0;
  virtual double Number(const std::string& key) const = 0;
  virtual std::vector<double> Numbers(const std::string& key) const = 0;
  virtual std::vector<std::string> Keys() const = 0;
};

class YamlReader : public KeyReader {
 public:
  YamlReader(const std::string& path, const std::string& text) : path_(path) {
    try {
      root_ = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      DYPHO_CHECK_INPUT(false) << path << ":" << e.mark.line + 1 << ": YAML syntax error: " << e.msg;
    }
    DYPHO_CHECK_INPUT(root_.IsMap())
        << path << ": camera file must be a map of keys (fx, fy, cx, cy, width, height, ...)";
  }
  bool Has(const std::string& key) const override { return static_cast<bool>(root_[key]); }
  double Number(const std::string& key) const override {
    const YAML::Node node = root_[key];
    DYPHO_CHECK_INPUT(node) << path_ << ": missing key '" << key << "'";
    bool ok = node.IsScalar();
    double value = 0.0;
    if (ok) {
      try {
        value = node.as<double>();
      } catch (const YAML::Exception&) {
        ok = false;
      }
    }
    DYPHO_CHECK_INPUT(ok) << path_ << ":" << node.Mark().line + 1 << ": key '" << key << "' must be a number";
    return value;
  }
  std::vector<double> Numbers(const std::string& key) const override {
    const YAML::Node node = root_[key];
    DYPHO_CHECK_INPUT(node && node.IsSequence()) << path_ << ":" << (node ? node.Mark().line + 1 : 0)
                                                 << ": key '" << key << "' must be a list of numbers";
    std::vector<double> out;
    bool ok = true;
    try {
      for (const auto& item : node) out.push_back(item.as<double>());
    } catch (const YAML::Exception&) {
      ok = false;
    }
    DYPHO_CHECK_INPUT(ok) << path_ << ":" << node.Mark().line + 1 << ": key '" << key
                          << "' must be a list of numbers";
    return out;
  }
  std::vector<std::string> Keys() const override {
    std::vector<std::string> keys;
    for (const auto& kv : root_) keys.push_back(kv.first.as<std::string>());
    return keys;
  }

 private:
  std::string path_;
  YAML::Node root_;
};

class JsonReader : public KeyReader {
 public:
  JsonReader(const std::string& path, const std::string& text) : path_(path) {
    try {
      root_ = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
      DYPHO_CHECK_INPUT(false) << path << ": JSON syntax error: " << e.what();
    }
    DYPHO_CHECK_INPUT(root_.is_object())
        << path << ": camera file must be a JSON object (fx, fy, cx, cy, width, height, ...)";
  }
  bool Has(const std::string& key) const override { return root_.contains(key); }
  double Number(const std::string& key) const override {
    DYPHO_CHECK_INPUT(root_.contains(key)) << path_ << ": missing key '" << key << "'";
    const auto& v = root_.at(key);
    DYPHO_CHECK_INPUT(v.is_number()) << path_ << ": key '" << key << "' must be a number";
    return v.get<double>();
  }
  std::vector<double> Numbers(const std::string& key) const override {
    const auto& v = root_.at(key);
    DYPHO_CHECK_INPUT(v.is_array()) << path_ << ": key '" << key << "' must be a list of numbers";
    std::vector<double> out;
    for (const auto& item : v) {
      DYPHO_CHECK_INPUT(item.is_number()) << path_ << ": key '" << key << "' must be a list of numbers";
      out.push_back(item.get<double>());
    }
    return out;
  }
  std::vector<std::string> Keys() const override {
    std::vector<std::string> keys;
    for (auto it = root_.begin(); it != root_.end(); ++it) keys.push_back(it.key());
    return keys;
  }

 private:
  std::string path_;
  nlohmann::json root_;
};

int Integer(const KeyReader& reader, const std::string& path, const std::string& key) {
  const double v = reader.Number(key);
  DYPHO_CHECK_INPUT(std::isfinite(v) && v == std::floor(v) && v > 0 && v < 1e6)
      << path << ": key '" << key << "' must be a positive whole number (got " << v << ")";
  return static_cast<int>(v);
}

}  // namespace

std::vector<std::string> CameraPresetNames() { return {"freiburg1", "freiburg2", "freiburg3", "bonn"}; }

std::string CanonicalPresetName(const std::string& name) {
  const std::string n = Lower(name);
  if (n == "freiburg1" || n == "fr1" || n == "tum1") return "freiburg1";
  if (n == "freiburg2" || n == "fr2" || n == "tum2") return "freiburg2";
  if (n == "freiburg3" || n == "fr3" || n == "tum3") return "freiburg3";
  if (n == "bonn") return "bonn";
  return "";
}

std::optional<Camera> CameraPreset(const std::string& name) {
  // Values: the ROS default calibration used by the TUM benchmark tools
  // (https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats) and the
  // Bonn RGB-D Dynamic dataset's calibration (Palazzolo et al., IROS 2019).
  const std::string canonical = CanonicalPresetName(name);
  if (canonical == "freiburg1") {
    return MakeCamera(517.3, 516.5, 318.6, 255.3, {0.2624, -0.9531, -0.0054, 0.0026, 1.1633});
  }
  if (canonical == "freiburg2") return MakeCamera(520.9, 521.0, 325.1, 249.7, {0, 0, 0, 0, 0});
  if (canonical == "freiburg3") return MakeCamera(535.4, 539.2, 320.1, 247.6, {0, 0, 0, 0, 0});
  if (canonical == "bonn") {
    return MakeCamera(542.822841, 542.576870, 315.593520, 237.756098,
                      {0.039903, -0.099343, -0.000730, -0.000144, 0.0});
  }
  return std::nullopt;
}

std::optional<double> PresetDepthTimeOffset(const std::string& name) {
  if (CanonicalPresetName(name) == "freiburg1") return -0.020;
  return std::nullopt;
}

std::string PresetFromFolderName(const std::string& folder) {
  namespace fs = std::filesystem;
  fs::path p = fs::absolute(fs::path(folder)).lexically_normal();
  if (!p.has_filename() && p.has_parent_path()) p = p.parent_path();  // trailing slash
  const std::string name = Lower(p.filename().string());
  std::set<std::string> found;
  if (name.find("freiburg1") != std::string::npos || name.find("fr1") != std::string::npos)
    found.insert("freiburg1");
  if (name.find("freiburg2") != std::string::npos || name.find("fr2") != std::string::npos)
    found.insert("freiburg2");
  if (name.find("freiburg3") != std::string::npos || name.find("fr3") != std::string::npos)
    found.insert("freiburg3");
  if (name.find("bonn") != std::string::npos) found.insert("bonn");
  if (found.empty()) return "";
  if (found.size() > 1) {
    std::string list;
    for (const auto& f : found) list += (list.empty() ? "" : ", ") + f;
    DYPHO_CHECK_INPUT(false) << "dataset folder name '" << p.filename().string()
                             << "' matches several camera presets (" << list
                             << "); choose one with the camera preset option or add camera.yaml";
  }
  return *found.begin();
}

CameraFile ReadCameraFile(const std::string& path) {
  const std::string text = ReadTextFile(path);
  const std::string ext = Lower(std::filesystem::path(path).extension().string());
  std::unique_ptr<KeyReader> reader;
  if (ext == ".json") {
    reader = std::make_unique<JsonReader>(path, text);
  } else {
    DYPHO_CHECK_INPUT(ext == ".yaml" || ext == ".yml")
        << "camera file " << path << " must end in .yaml, .yml or .json";
    reader = std::make_unique<YamlReader>(path, text);
  }

  CameraFile out;
  Camera& c = out.camera;
  c.fx = reader->Number("fx");
  c.fy = reader->Number("fy");
  c.cx = reader->Number("cx");
  c.cy = reader->Number("cy");
  c.width = Integer(*reader, path, "width");
  c.height = Integer(*reader, path, "height");
  if (reader->Has("distortion")) {
    const std::vector<double> d = reader->Numbers("distortion");
    DYPHO_CHECK_INPUT(d.size() == 4 || d.size() == 5)
        << path << ": key 'distortion' must have 4 or 5 values k1 k2 p1 p2 [k3] (got " << d.size() << ")";
    for (size_t i = 0; i < d.size(); ++i) c.distortion[i] = d[i];
  }
  if (reader->Has("depth_factor")) {
    const double f = reader->Number("depth_factor");
    DYPHO_CHECK_INPUT(std::isfinite(f) && f > 0)
        << path << ": key 'depth_factor' must be > 0 (got " << f << ")";
    out.depth_factor = f;
  }
  for (const std::string& key : reader->Keys()) {
    if (!kKnownKeys.count(key)) {
      DYPHO_LOG(Warning) << path << ": ignoring unknown key '" << key << "'";
    }
  }
  c.ValidateCalibration(path);
  return out;
}

std::string FormatCameraYaml(const Camera& camera, double depth_factor) {
  std::ostringstream s;
  s.precision(17);
  s << "# dypho camera file: pinhole intrinsics [px], image size [px],\n"
    << "# distortion k1 k2 p1 p2 k3 (OpenCV order), depth PNG units per metre.\n";
  s << "fx: " << camera.fx << "\nfy: " << camera.fy << "\ncx: " << camera.cx << "\ncy: " << camera.cy
    << "\nwidth: " << camera.width << "\nheight: " << camera.height << "\ndistortion: [";
  for (int i = 0; i < 5; ++i) s << (i ? ", " : "") << camera.distortion[i];
  s << "]\ndepth_factor: " << depth_factor << "\n";
  return s.str();
}

}  // namespace dypho
