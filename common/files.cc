#include "common/files.h"

#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <malloc.h>
#include <unistd.h>

#include <cstdlib>
#include <mutex>

#include "common/check.h"

namespace dypho {
namespace fs = std::filesystem;

void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string&)>& write) {
  static std::atomic<int> counter{0};
  const fs::path target(path);
  if (target.has_parent_path()) MakeDirectories(target.parent_path().string());
  const std::string tmp = path + ".tmp." + std::to_string(::getpid()) + "." +
                          std::to_string(counter++);
  try {
    write(tmp);
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    const std::string why = ec.message();  // before remove() resets ec ("Success")
    fs::remove(tmp, ec);
    DYPHO_CHECK_INPUT(false) << "cannot write " << path << ": " << why;
  }
}

void WriteTextAtomically(const std::string& path, const std::string& contents) {
  WriteFileAtomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    DYPHO_CHECK_INPUT(out.good()) << "cannot open " << tmp << " for writing";
    out << contents;
    out.close();
    DYPHO_CHECK_INPUT(out.good()) << "error writing " << tmp;
  });
}

std::string ReadTextFile(const std::string& path) {
  std::error_code ec;
  DYPHO_CHECK_INPUT(!fs::is_directory(path, ec)) << path << " is a folder, not a file";
  std::ifstream in(path, std::ios::binary);
  DYPHO_CHECK_INPUT(in.good()) << "cannot open " << path;
  std::string text;
  char block[65536];
  while (in.good()) {
    in.read(block, sizeof(block));
    text.append(block, static_cast<size_t>(in.gcount()));
  }
  DYPHO_CHECK_INPUT(!in.bad()) << "cannot read " << path;
  return text;
}

void MakeDirectories(const std::string& dir) {
  if (dir.empty()) return;
  std::error_code ec;
  fs::create_directories(dir, ec);
  DYPHO_CHECK_INPUT(!ec && fs::is_directory(dir)) << "cannot create directory " << dir << ": " << ec.message();
}

void MakeOutputDirectory(const std::string& dir) {
  DYPHO_CHECK_INPUT(!dir.empty()) << "the output folder must not be empty";
  MakeDirectories(dir);
}

int ClearOwnedOutputs(const std::string& dir, const std::vector<std::string>& names) {
  int removed = 0;
  for (const std::string& name : names) {
    const fs::path p = fs::path(dir) / name;
    std::error_code ec;
    if (!fs::exists(fs::symlink_status(p, ec))) continue;
    fs::remove_all(p, ec);
    DYPHO_CHECK_INPUT(!ec) << "cannot remove the earlier output " << p.string() << ": " << ec.message();
    ++removed;
  }
  return removed;
}

bool IsInsideFolder(const std::string& path, const std::string& folder) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  const fs::path f = fs::weakly_canonical(fs::absolute(folder, ec), ec);
  auto pi = p.begin(), fi = f.begin();
  for (; fi != f.end() && pi != p.end(); ++fi, ++pi) {
    if (fi->empty() && std::next(fi) == f.end()) break;  // trailing "/" of the folder
    if (*fi != *pi) return false;
  }
  return fi == f.end() || (fi->empty() && std::next(fi) == f.end());
}

void CheckOutsideDataset(const std::string& out, const std::string& dataset, const std::string& flag, bool allowed) {
  DYPHO_CHECK_INPUT(allowed || !IsInsideFolder(out, dataset))
      << flag << " " << out << " lies inside the input dataset " << dataset
      << ": writing there could overwrite or add to its files; choose another place, or pass --write-into-dataset";
}

std::string JoinPath(const std::string& dir, const std::string& name) { return (fs::path(dir) / name).string(); }

bool KeepFreedMemory() {
  static std::once_flag once;
  static bool applied = false;
  std::call_once(once, [] {
    const char* env = std::getenv("DYPHO_KEEP_FREED_MEMORY");
    if (env != nullptr && std::string(env) == "0") return;
#if defined(__GLIBC__)
    applied = mallopt(M_MMAP_THRESHOLD, 1 << 30) == 1 && mallopt(M_TRIM_THRESHOLD, 1 << 30) == 1;
#endif
  });
  return applied;
}

int DefaultThreadCount() {
  const unsigned n = std::thread::hardware_concurrency();
  return n == 0 ? 1 : static_cast<int>(n);
}

}  // namespace dypho
