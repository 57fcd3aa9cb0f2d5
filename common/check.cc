#include "common/check.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace dypho {

std::string Printable(const std::string& text, size_t max_length) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (out.size() >= max_length) return out + "...";
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof(hex), "\\x%02x", c);
      out += hex;
    }
  }
  return out;
}

std::string FormatTimestamp(double seconds) {
  if (!std::isfinite(seconds) || std::abs(seconds) > 1e15) {
    std::ostringstream out;
    out << seconds;
    return out.str();
  }
  char text[64];
  std::snprintf(text, sizeof(text), "%.6f", seconds);
  return text;
}

}  // namespace dypho

namespace dypho::internal {

namespace {
const char* BaseName(const char* path) {
  const char* slash = std::strrchr(path, '/');
  return slash ? slash + 1 : path;
}
}  // namespace

CheckMessage::CheckMessage(const char* file, int line, const char* condition, bool fatal)
    : fatal_(fatal) {
  std::ostringstream prefix;
  prefix << "[" << BaseName(file) << ":" << line << "] check failed: " << condition;
  prefix_ = prefix.str();
}

CheckMessage::~CheckMessage() noexcept(false) {
  std::string message = prefix_;
  const std::string detail = stream_.str();
  if (!detail.empty()) message += ": " + detail;
  if (fatal_) {
    std::fprintf(stderr, "dypho: internal error %s\n", message.c_str());
    std::fflush(stderr);
    std::abort();
  }
  if (detail.empty()) throw InvalidInput(message);
  throw InvalidInput(detail, prefix_);
}

}  // namespace dypho::internal
