// LibTorch's intra-op thread pool. Debian's LibTorch starts with one intra-op
// thread unless told otherwise, so programs that run tensor ops on the CPU
// (losses, optimisers) call this once at start-up. The rasterizer kernels do
// not use this pool: they take kernels::RasterSettings::num_threads.
#pragma once

namespace dypho {

// Sets LibTorch's intra-op thread count (torch::set_num_threads);
// 0 = the number of hardware threads. Throws InvalidInput when negative.
void ConfigureTorchThreads(int num_threads);

}  // namespace dypho
