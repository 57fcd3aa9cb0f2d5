// File helpers: atomic writes (temporary file, then rename) so no reader ever
// sees a half-written output.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace dypho {

// Calls `write(tmp_path)` to produce the file under a temporary name beside
// `path`, then renames it onto `path`. If `write` throws, the temporary file
// is removed and the exception propagates; `path` is untouched.
void WriteFileAtomically(const std::string& path, const std::function<void(const std::string&)>& write);
// Writes `contents` to `path` atomically.
void WriteTextAtomically(const std::string& path, const std::string& contents);
// Reads a whole file; throws InvalidInput naming the file when it cannot.
std::string ReadTextFile(const std::string& path);
// Creates `dir` and its parents; throws naming it on failure. An empty `dir`
// (the parent of a bare file name) does nothing.
void MakeDirectories(const std::string& dir);
// The same for a command's output folder, where an empty path is an error
// (`--out ""` once wrote map.ply and report.md into the filesystem root).
void MakeOutputDirectory(const std::string& dir);
// Removes the entries `names` (files or folders) of `dir` that exist: the
// outputs a command owns, cleared before it writes so that no file of an
// earlier run in a reused folder is left looking current. Returns how many
// were removed.
int ClearOwnedOutputs(const std::string& dir, const std::vector<std::string>& names);
// Whether `path` is `folder` or lies under it (both made absolute and
// canonical as far as they exist, so "a/../b" and symbolic links count).
bool IsInsideFolder(const std::string& path, const std::string& folder);
// Throws InvalidInput unless `allowed` or `out` (the value of `flag`) lies
// outside the input dataset folder `dataset`: no command writes into its
// input unless asked to (`dypho masks DS --out DS` made DS/masks/, which
// later runs loaded as the dataset's own masks).
void CheckOutsideDataset(const std::string& out, const std::string& dataset, const std::string& flag, bool allowed);
// `dir` / `name` as a string (std::filesystem: no doubled or missing "/").
std::string JoinPath(const std::string& dir, const std::string& name);

// Asks glibc's malloc to keep freed memory for reuse instead of returning
// large blocks to the operating system (mmap threshold 1 GiB, trim threshold
// 2 GiB). Rendering and optimisation allocate tens of megabytes of scratch
// memory per call; on virtual machines a first touch of a fresh page costs
// tens of microseconds, which otherwise dominates a render (measured here:
// 45 MB of fresh memory takes 300 ms to touch, reused memory 7 ms).
// Called once by the CPU rasterizer factory; the environment variable
// DYPHO_KEEP_FREED_MEMORY=0 turns it off. Returns whether it was applied.
bool KeepFreedMemory();

// Number of hardware threads (at least 1): the default for thread-count options.
int DefaultThreadCount();

// The most threads any option or --threads flag accepts (0 still means "all
// hardware threads"). More would only oversubscribe the cores; 100000 crashed
// OpenMP's thread start-up and 2e9 made libgomp allocate 448 GB.
constexpr int kMaxThreads = 256;

}  // namespace dypho
