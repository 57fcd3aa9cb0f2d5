#include "common/thread_name.h"

#include <cstring>

#if defined(__linux__)
#include <pthread.h>
#endif

namespace dypho {

void SetCurrentThreadName(const char* name) {
#if defined(__linux__)
  char buffer[16] = {};
  std::strncpy(buffer, name, sizeof(buffer) - 1);
  pthread_setname_np(pthread_self(), buffer);
#else
  (void)name;
#endif
}

}  // namespace dypho
