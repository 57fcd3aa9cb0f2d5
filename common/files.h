// File helpers: atomic writes (temporary file, then rename) so no reader ever
// sees a half-written output.
#pragma once

#include <functional>
#include <string>

namespace dypho {

// Calls `write(tmp_path)` to produce the file under a temporary name beside
// `path`, then renames it onto `path`. If `write` throws, the temporary file
// is removed and the exception propagates; `path` is untouched.
void WriteFileAtomically(const std::string& path, const std::function<void(const std::string&)>& write);
// Writes `contents` to `path` atomically.
void WriteTextAtomically(const std::string& path, const std::string& contents);
// Reads a whole file; throws InvalidInput naming the file when it cannot.
std::string ReadTextFile(const std::string& path);
// Creates `dir` and its parents; throws naming it on failure.
void MakeDirectories(const std::string& dir);

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

}  // namespace dypho
