#include "engine/torch/threads.h"

#include <ATen/Parallel.h>  // at::set_num_threads, which torch::set_num_threads names

#include "common/check.h"
#include "common/files.h"

namespace dypho {

void ConfigureTorchThreads(int num_threads) {
  DYPHO_CHECK_INPUT(num_threads >= 0 && num_threads <= kMaxThreads)
      << "ConfigureTorchThreads: num_threads must be in [0, " << kMaxThreads << "] (got " << num_threads << ")";
  at::set_num_threads(num_threads > 0 ? num_threads : DefaultThreadCount());
}

}  // namespace dypho
