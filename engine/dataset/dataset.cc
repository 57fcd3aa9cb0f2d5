#include "engine/dataset/dataset.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <sstream>
#include <utility>

#include "common/check.h"
#include "common/logging.h"
#include "engine/dataset/camera_file.h"
#include "engine/eval/associate.h"
#include "engine/io/image_io.h"
#include "engine/stereo/stereo_dataset.h"

namespace dypho {
namespace fs = std::filesystem;
namespace {

// One image listed in a list file (or found in an image folder).
struct ListEntry {
  double timestamp = 0.0;
  std::string path;    // relative to the dataset folder, as listed
  std::string source;  // "…/rgb.txt:12" or the folder it was found in
};

// One line of associations.txt.
struct AssociationEntry {
  ListEntry first;
  ListEntry second;
};

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string Join(const std::string& folder, const std::string& relative) {
  return (fs::path(folder) / relative).lexically_normal().string();
}

// Normalised relative path used to match RGB entries across list files.
std::string Key(const std::string& relative) { return fs::path(relative).lexically_normal().string(); }

bool ParseDouble(const std::string& token, double* value) {
  if (token.empty()) return false;
  const char* begin = token.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (end != begin + token.size() || errno == ERANGE || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

// DatasetOptions::depth_time as an offset [s], nullopt unless a number in
// [-0.1, 0.1].
std::optional<double> ParseDepthTimeOffset(const std::string& text) {
  double v = 0.0;
  if (!ParseDouble(text, &v) || std::abs(v) > 0.1) return std::nullopt;
  return v;
}

std::string FormatOffset(double seconds) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%+.3f", seconds);
  return buf;
}

// Splits the data lines of a list file into whitespace-separated tokens;
// calls `row(tokens, line_number, line)` for each non-comment line.
template <typename RowFn>
void ForEachRow(const std::string& path, RowFn row) {
  std::ifstream in(path);
  DYPHO_CHECK_INPUT(in.good()) << "cannot open " << path;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream s(line);
    std::vector<std::string> tokens;
    std::string token;
    while (s >> token) tokens.push_back(token);
    row(tokens, line_no, line);
  }
}

std::string Source(const std::string& path, int line) { return path + ":" + std::to_string(line); }

// "timestamp path" lines with strictly increasing timestamps.
std::vector<ListEntry> ReadImageList(const std::string& path) {
  std::vector<ListEntry> entries;
  ForEachRow(path, [&](const std::vector<std::string>& tokens, int line_no, const std::string& line) {
    ListEntry e;
    DYPHO_CHECK_INPUT(tokens.size() == 2 && ParseDouble(tokens[0], &e.timestamp))
        << Source(path, line_no) << ": expected 'timestamp path', got '" << Printable(line) << "'";
    DYPHO_CHECK_INPUT(entries.empty() || e.timestamp > entries.back().timestamp)
        << Source(path, line_no) << ": timestamp " << tokens[0] << " is not after the previous one ("
        << FormatTimestamp(entries.back().timestamp) << "); timestamps must increase";
    e.path = tokens[1];
    e.source = Source(path, line_no);
    entries.push_back(std::move(e));
  });
  return entries;
}

// "t1 path1 t2 path2" lines with strictly increasing first timestamps.
std::vector<AssociationEntry> ReadAssociations(const std::string& path) {
  std::vector<AssociationEntry> entries;
  ForEachRow(path, [&](const std::vector<std::string>& tokens, int line_no, const std::string& line) {
    AssociationEntry e;
    DYPHO_CHECK_INPUT(tokens.size() == 4 && ParseDouble(tokens[0], &e.first.timestamp) &&
                      ParseDouble(tokens[2], &e.second.timestamp))
        << Source(path, line_no) << ": expected 't_rgb rgb_path t_depth depth_path', got '" << Printable(line) << "'";
    DYPHO_CHECK_INPUT(entries.empty() || e.first.timestamp > entries.back().first.timestamp)
        << Source(path, line_no) << ": timestamp " << tokens[0] << " is not after the previous one ("
        << FormatTimestamp(entries.back().first.timestamp) << "); timestamps must increase";
    e.first.path = tokens[1];
    e.second.path = tokens[3];
    e.first.source = e.second.source = Source(path, line_no);
    entries.push_back(std::move(e));
  });
  return entries;
}

// A file name that is a timestamp in seconds with a decimal point, as TUM's
// "1305031229.528748.png"; frame numbers such as "000123.png" are not.
bool ParseTimestampName(const std::string& path, double* timestamp) {
  const std::string stem = fs::path(path).stem().string();
  return stem.find('.') != std::string::npos && ParseDouble(stem, timestamp);
}

bool IsImageFile(const fs::path& p) {
  const std::string ext = Lower(p.extension().string());
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".tif" ||
         ext == ".tiff" || ext == ".ppm" || ext == ".pgm";
}

// The images of a folder, sorted by the timestamps their names encode; when
// a name is not a number, sorted by name and stamped index / frame_rate.
// `*named_by_time` tells which case applied.
std::vector<ListEntry> ListImageFolder(const std::string& folder, const std::string& sub, double frame_rate,
                                       bool* named_by_time) {
  std::vector<ListEntry> entries;
  for (const auto& item : fs::directory_iterator(fs::path(folder) / sub)) {
    if (!item.is_regular_file() || !IsImageFile(item.path())) continue;
    ListEntry e;
    e.path = (fs::path(sub) / item.path().filename()).string();
    e.source = (fs::path(folder) / sub).string() + "/";
    entries.push_back(std::move(e));
  }
  *named_by_time = !entries.empty();
  for (ListEntry& e : entries) {
    if (!ParseTimestampName(e.path, &e.timestamp)) *named_by_time = false;
  }
  if (*named_by_time) {
    std::sort(entries.begin(), entries.end(),
              [](const ListEntry& a, const ListEntry& b) { return a.timestamp < b.timestamp; });
    for (size_t i = 1; i < entries.size(); ++i) {
      DYPHO_CHECK_INPUT(entries[i].timestamp > entries[i - 1].timestamp)
          << "images " << entries[i - 1].path << " and " << entries[i].path << " in " << folder
          << " have the same timestamp";
    }
  } else {
    std::sort(entries.begin(), entries.end(),
              [](const ListEntry& a, const ListEntry& b) { return a.path < b.path; });
    for (size_t i = 0; i < entries.size(); ++i) entries[i].timestamp = i / frame_rate;
  }
  return entries;
}

bool IsDirectory(const std::string& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

bool IsFile(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

// Runs `f`; an InvalidInput it throws gets the list entry appended.
template <typename F>
auto WithSource(const std::string& source, F f) -> decltype(f()) {
  try {
    return f();
  } catch (const InvalidInput& e) {
    throw InvalidInput(e.message() + " (listed at " + source + ")", e.location());
  }
}

// Chooses the camera (see dataset.h for the order) and says where it came from.
Camera ChooseCamera(const std::string& folder, const DatasetOptions& options, std::string* source,
                    std::string* preset, std::optional<double>* file_depth_factor) {
  auto from_file = [&](const std::string& path) {
    CameraFile file = ReadCameraFile(path);
    *source = "camera file " + path;
    *file_depth_factor = file.depth_factor;
    return file.camera;
  };
  auto from_preset = [&](const std::string& name, const std::string& why) {
    const std::optional<Camera> camera = CameraPreset(name);
    std::string names;
    for (const auto& n : CameraPresetNames()) names += (names.empty() ? "" : ", ") + n;
    DYPHO_CHECK_INPUT(camera.has_value())
        << "unknown camera preset '" << name << "' (known: " << names << ", or fr1/fr2/fr3)";
    *preset = CanonicalPresetName(name);
    *source = "preset " + *preset + " (" + why + ")";
    return *camera;
  };

  if (!options.camera_file.empty()) return from_file(options.camera_file);
  if (!options.camera_preset.empty()) return from_preset(options.camera_preset, "given");
  for (const char* name : {"camera.yaml", "camera.yml", "camera.json"}) {
    const std::string path = Join(folder, name);
    if (IsFile(path)) return from_file(path);
  }
  const std::string by_name = PresetFromFolderName(folder);
  DYPHO_CHECK_INPUT(!by_name.empty())
      << "cannot tell the camera of dataset " << folder
      << ": its name contains none of freiburg1/fr1, freiburg2/fr2, freiburg3/fr3, bonn and it has no "
         "camera.yaml or camera.json; give a camera preset or a camera file";
  return from_preset(by_name, "folder name");
}

}  // namespace

bool DatasetOptions::IsValid(std::string* error) const {
  if (stereo_method != "elas" && stereo_method != "sgbm") {
    if (error) *error = "stereo_method must be elas or sgbm (got '" + stereo_method + "')";
    return false;
  }
  if (depth_time != "auto" && depth_time != "listed" && !ParseDepthTimeOffset(depth_time)) {
    if (error)
      *error = "depth_time must be auto, listed or an offset in seconds from the colour timestamp within "
               "[-0.1, 0.1] (got '" + depth_time + "')";
    return false;
  }
  std::ostringstream msg;
  if (!camera_preset.empty() && CanonicalPresetName(camera_preset).empty()) {
    msg << "camera_preset '" << camera_preset << "' is unknown (freiburg1, freiburg2, freiburg3, bonn)";
  } else if (!(std::isfinite(depth_factor) && depth_factor >= 0)) {
    msg << "depth_factor must be >= 0 (got " << depth_factor << ")";
  } else if (!(std::isfinite(max_depth_dt) && max_depth_dt > 0)) {
    msg << "max_depth_dt must be > 0 s (got " << max_depth_dt << ")";
  } else if (!(max_gt_gap > 0)) {
    msg << "max_gt_gap must be > 0 s (got " << max_gt_gap << ")";
  } else if (!(std::isfinite(frame_rate) && frame_rate > 0)) {
    msg << "frame_rate must be > 0 Hz (got " << frame_rate << ")";
  }
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

std::optional<Rigid3d> InterpolatePose(const Trajectory& trajectory, double t, double max_gap) {
  const std::vector<double>& ts = trajectory.timestamps;
  if (ts.empty() || !(t >= ts.front() && t <= ts.back())) return std::nullopt;
  const size_t k = std::upper_bound(ts.begin(), ts.end(), t) - ts.begin();  // first > t
  if (k == ts.size()) return trajectory.world_from_cam.back();              // t == last
  if (ts[k - 1] == t) return trajectory.world_from_cam[k - 1];
  const double t0 = ts[k - 1], t1 = ts[k];
  if (t1 - t0 > max_gap) return std::nullopt;
  return Interpolate(trajectory.world_from_cam[k - 1], trajectory.world_from_cam[k], (t - t0) / (t1 - t0));
}

Dataset::Dataset(Contents contents) : contents_(std::move(contents)) {
  for (size_t i = 0; i < contents_.frames.size(); ++i) {
    contents_.frames[i].index = i;
    if (!contents_.frames[i].world_from_cam_gt) frames_without_gt_.push_back(i);
  }
}

const FrameInfo& Dataset::info(size_t i) const {
  DYPHO_CHECK_INPUT(i < size()) << "frame " << i << " is out of range: dataset " << name() << " has "
                                << size() << " frames";
  return contents_.frames[i];
}

size_t Dataset::frames_with_depth() const {
  return std::count_if(contents_.frames.begin(), contents_.frames.end(),
                       [](const FrameInfo& f) { return f.has_depth; });
}

size_t Dataset::frames_with_mask() const {
  return std::count_if(contents_.frames.begin(), contents_.frames.end(),
                       [](const FrameInfo& f) { return !f.mask_path.empty(); });
}

Dataset Dataset::WithStereoPreview(int downscale) const {
  DYPHO_CHECK_INPUT(contents_.stereo != nullptr) << "stereo preview depth: " << contents_.folder << " is not a stereo dataset";
  DYPHO_CHECK_INPUT(downscale >= 1 && downscale <= 8)
      << "stereo preview downscale must be 1..8 (got " << downscale << ")";
  Dataset copy = *this;
  auto rig = std::make_shared<stereo::StereoRig>(*contents_.stereo);
  rig->preview_downscale = downscale;
  copy.contents_.stereo = std::move(rig);
  return copy;
}

Frame Dataset::Load(size_t i) const {
  const FrameInfo& fi = info(i);
  if (contents_.stereo) {
    Frame pair = stereo::LoadStereoFrame(*contents_.stereo, fi);
    pair.depth_timestamp = pair.timestamp;  // the depth comes from the pair
    return pair;
  }
  Frame frame;
  frame.index = fi.index;
  frame.timestamp = fi.timestamp;
  frame.rgb_path = fi.rgb_path;
  frame.depth_path = fi.depth_path;
  frame.depth_timestamp = fi.depth_timestamp;
  frame.has_depth = fi.has_depth;
  frame.world_from_cam_gt = fi.world_from_cam_gt;

  // The depth PNG decodes on a second thread while the RGB one decodes here
  // (PNG decoding is most of Load's time).
  auto read_depth = [&fi] {
    return WithSource(fi.depth_source, [&fi] { return ReadDepth16(fi.depth_path); });
  };
  std::future<Image<uint16_t>> depth_future;
  if (fi.has_depth && contents_.parallel_decode) depth_future = std::async(std::launch::async, read_depth);

  frame.rgb = WithSource(fi.rgb_source, [&] { return ReadRgb8(fi.rgb_path); });
  const Camera& cam = contents_.camera;
  DYPHO_CHECK_INPUT(frame.rgb.width() == cam.width && frame.rgb.height() == cam.height)
      << "RGB image " << fi.rgb_path << " is " << frame.rgb.width() << "x" << frame.rgb.height()
      << " but the camera (" << contents_.camera_source << ") is " << cam.width << "x" << cam.height
      << " (listed at " << fi.rgb_source << ")";

  if (fi.has_depth) {
    const Image<uint16_t> raw = depth_future.valid() ? depth_future.get() : read_depth();
    DYPHO_CHECK_INPUT(raw.width() == frame.rgb.width() && raw.height() == frame.rgb.height())
        << "depth image " << fi.depth_path << " is " << raw.width() << "x" << raw.height()
        << " but its RGB image " << fi.rgb_path << " is " << frame.rgb.width() << "x" << frame.rgb.height()
        << " (listed at " << fi.depth_source << ")";
    frame.depth = DepthFromU16(raw, contents_.depth_factor);
  }

  if (!fi.mask_path.empty()) {
    frame.dynamic_mask = ReadGray8(fi.mask_path);
    DYPHO_CHECK_INPUT(frame.dynamic_mask.width() == frame.rgb.width() &&
                      frame.dynamic_mask.height() == frame.rgb.height())
        << "mask " << fi.mask_path << " is " << frame.dynamic_mask.width() << "x"
        << frame.dynamic_mask.height() << " but its RGB image " << fi.rgb_path << " is " << frame.rgb.width()
        << "x" << frame.rgb.height();
    for (uint8_t& v : frame.dynamic_mask.pixels()) v = v ? 255 : 0;
  }
  return frame;
}

std::unique_ptr<Dataset> OpenDataset(const std::string& folder, const DatasetOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "DatasetOptions: " << error;
  DYPHO_CHECK_INPUT(fs::exists(folder)) << "dataset folder does not exist: " << folder;
  DYPHO_CHECK_INPUT(IsDirectory(folder)) << "dataset path is not a folder: " << folder;

  if (auto stereo_contents = stereo::OpenStereoContents(folder, options))
    return std::make_unique<Dataset>(std::move(*stereo_contents));

  Dataset::Contents c;
  c.folder = folder;
  {
    fs::path p = fs::absolute(fs::path(folder)).lexically_normal();
    if (!p.has_filename() && p.has_parent_path()) p = p.parent_path();
    c.name = p.filename().string();
  }

  const std::string rgb_list = Join(folder, "rgb.txt");
  const std::string depth_list = Join(folder, "depth.txt");
  const std::string association_list = Join(folder, "associations.txt");
  const bool have_associations = IsFile(association_list);

  // 1. The RGB frames.
  std::vector<ListEntry> rgb;
  std::vector<AssociationEntry> associations;
  if (have_associations) associations = ReadAssociations(association_list);
  if (IsFile(rgb_list)) {
    rgb = ReadImageList(rgb_list);
  } else if (IsDirectory(Join(folder, "rgb"))) {
    bool named_by_time = false;
    rgb = ListImageFolder(folder, "rgb", options.frame_rate, &named_by_time);
    if (!named_by_time && !rgb.empty()) {
      DYPHO_LOG(Warning) << "dataset " << folder << ": image names in rgb/ are not timestamps; using "
                         << options.frame_rate << " Hz";
    }
  } else if (have_associations) {
    for (const AssociationEntry& a : associations) rgb.push_back(a.first);
  } else {
    DYPHO_CHECK_INPUT(false) << folder
                             << " is not an RGB-D dataset folder: it has no rgb.txt, no rgb/ folder and no "
                                "associations.txt";
  }
  DYPHO_CHECK_INPUT(!rgb.empty()) << "dataset " << folder << " lists no RGB images";

  c.frames.resize(rgb.size());
  std::map<std::string, size_t> frame_by_path;
  for (size_t i = 0; i < rgb.size(); ++i) {
    FrameInfo& f = c.frames[i];
    f.timestamp = rgb[i].timestamp;
    f.rgb_path = Join(folder, rgb[i].path);
    f.rgb_source = rgb[i].source;
    frame_by_path[Key(rgb[i].path)] = i;
  }

  // 2. Depth for each frame.
  auto set_depth = [&](size_t i, const ListEntry& depth) {
    FrameInfo& f = c.frames[i];
    f.has_depth = true;
    f.depth_path = Join(folder, depth.path);
    f.depth_timestamp = depth.timestamp;
    f.depth_listed_timestamp = depth.timestamp;
    f.depth_source = depth.source;
  };
  auto associate_by_time = [&](const std::vector<ListEntry>& depth) {
    std::vector<double> rgb_times, depth_times;
    for (const auto& e : rgb) rgb_times.push_back(e.timestamp);
    for (const auto& e : depth) depth_times.push_back(e.timestamp);
    for (const TimestampMatch& m : AssociateTimestamps(rgb_times, depth_times, options.max_depth_dt)) {
      set_depth(m.first, depth[m.second]);
    }
  };
  if (have_associations) {
    for (const AssociationEntry& a : associations) {
      // Either column pair may be the RGB one (associate.py writes them in
      // the order it was given the lists).
      auto it = frame_by_path.find(Key(a.first.path));
      const ListEntry* depth = &a.second;
      if (it == frame_by_path.end()) {
        it = frame_by_path.find(Key(a.second.path));
        depth = &a.first;
      }
      DYPHO_CHECK_INPUT(it != frame_by_path.end())
          << a.first.source << ": neither " << a.first.path << " nor " << a.second.path
          << " is one of the dataset's RGB images (" << (IsFile(rgb_list) ? rgb_list : Join(folder, "rgb/"))
          << ")";
      DYPHO_CHECK_INPUT(!c.frames[it->second].has_depth)
          << a.first.source << ": RGB image " << it->first << " is associated a second time (first at "
          << c.frames[it->second].depth_source << ")";
      set_depth(it->second, *depth);
    }
  } else if (IsFile(depth_list)) {
    associate_by_time(ReadImageList(depth_list));
  } else if (IsDirectory(Join(folder, "depth"))) {
    bool named_by_time = false;
    const std::vector<ListEntry> depth = ListImageFolder(folder, "depth", options.frame_rate, &named_by_time);
    bool rgb_named_by_time = true;
    double unused = 0.0;
    for (const auto& e : rgb) rgb_named_by_time &= ParseTimestampName(e.path, &unused);
    if (named_by_time && rgb_named_by_time) {
      associate_by_time(depth);
    } else {  // pair by file name (000001.png with 000001.png)
      std::map<std::string, const ListEntry*> by_stem;
      for (const auto& e : depth) by_stem[fs::path(e.path).stem().string()] = &e;
      for (size_t i = 0; i < rgb.size(); ++i) {
        auto it = by_stem.find(fs::path(rgb[i].path).stem().string());
        if (it != by_stem.end()) {
          ListEntry d = *it->second;
          d.timestamp = rgb[i].timestamp;
          set_depth(i, d);
        }
      }
    }
  }

  // 3. Dynamic masks named like the RGB images.
  const std::string mask_dir = Join(folder, "masks");
  if (IsDirectory(mask_dir)) {
    for (FrameInfo& f : c.frames) {
      const fs::path rgb_name = fs::path(f.rgb_path).filename();
      for (const fs::path& candidate :
           {fs::path(mask_dir) / rgb_name, fs::path(mask_dir) / rgb_name.stem().concat(".png")}) {
        if (IsFile(candidate.string())) {
          f.mask_path = candidate.string();
          break;
        }
      }
    }
  }

  // 4. Every listed image must exist.
  if (options.check_files) {
    for (const FrameInfo& f : c.frames) {
      DYPHO_CHECK_INPUT(IsFile(f.rgb_path))
          << f.rgb_source << ": listed RGB image does not exist: " << f.rgb_path;
      DYPHO_CHECK_INPUT(!f.has_depth || IsFile(f.depth_path))
          << f.depth_source << ": listed depth image does not exist: " << f.depth_path;
    }
  }

  // 5. Camera and depth scale.
  std::string preset;
  std::optional<double> file_depth_factor;
  c.camera = ChooseCamera(folder, options, &c.camera_source, &preset, &file_depth_factor);
  c.format = preset == "bonn" ? "bonn" : (preset.empty() ? "generic" : "tum");
  c.parallel_decode = options.parallel_decode;
  c.depth_factor =
      options.depth_factor > 0 ? options.depth_factor : file_depth_factor.value_or(kTumDepthFactor);
  // When the depth images were captured.
  std::optional<double> depth_offset;
  if (options.depth_time == "auto") {
    depth_offset = PresetDepthTimeOffset(preset);
    if (depth_offset)
      c.depth_time_source = "colour time " + FormatOffset(*depth_offset) + " s (preset " + preset + ")";
  } else if (options.depth_time != "listed") {
    depth_offset = ParseDepthTimeOffset(options.depth_time);
    c.depth_time_source = "colour time " + FormatOffset(*depth_offset) + " s (given)";
  }
  if (depth_offset)
    for (FrameInfo& f : c.frames)
      if (f.has_depth) f.depth_timestamp = f.timestamp + *depth_offset;

  // 6. Ground truth at the frame timestamps.
  const std::string gt_path = Join(folder, "groundtruth.txt");
  if (IsFile(gt_path)) {
    c.ground_truth = ReadTumTrajectory(gt_path);
    c.ground_truth_path = gt_path;
    for (FrameInfo& f : c.frames)
      f.world_from_cam_gt = InterpolatePose(c.ground_truth, f.timestamp, options.max_gt_gap);
  }

  auto dataset = std::make_unique<Dataset>(std::move(c));
  const size_t with_depth = dataset->frames_with_depth();
  if (with_depth < dataset->size()) {
    DYPHO_LOG(Info) << "dataset " << dataset->name() << ": " << dataset->size() - with_depth << " of "
                    << dataset->size() << " frames have no depth image";
  }
  if (dataset->has_ground_truth() && !dataset->frames_without_gt().empty()) {
    DYPHO_LOG(Warning) << "dataset " << dataset->name() << ": " << dataset->frames_without_gt().size()
                       << " of " << dataset->size()
                       << " frames lie outside the ground-truth time range (or in a gap) and have no "
                          "ground-truth pose (first: frame "
                       << dataset->frames_without_gt().front() << ")";
  }
  return dataset;
}

}  // namespace dypho
