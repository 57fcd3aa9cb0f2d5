// Names the calling thread (Linux: shown by `top -H`, `ps -L`, perf and gdb),
// so a user can see which of dypho's threads takes the CPU.
#pragma once

namespace dypho {

// `name` is cut to the 15 characters Linux keeps. Does nothing where thread
// names are not supported; never throws.
void SetCurrentThreadName(const char* name);

}  // namespace dypho
