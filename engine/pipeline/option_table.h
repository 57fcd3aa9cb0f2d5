// Internal to engine/pipeline/: the helpers that bind option keys to
// fields (parsing, range checks, formatting), shared by the option list
// (pipeline_option_list.cc) and the option functions (pipeline_options.cc).
#pragma once

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "common/check.h"
#include "engine/pipeline/pipeline_options.h"

namespace dypho {
namespace option_table {


inline std::string Trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

inline std::string FormatDouble(double v) {
  std::ostringstream out;
  out.precision(10);
  out << v;
  return out.str();
}

// The shortest decimal that reads back to the same T, so a float field
// set to 0.005 prints as 0.005 and not as 0.004999999888.
template <typename T>
inline std::string FormatField(T v) {
  if (std::is_integral<T>::value || !std::isfinite(static_cast<double>(v))) return FormatDouble(static_cast<double>(v));
  for (int digits = 1; digits <= 17; ++digits) {
    std::ostringstream out;
    out.precision(digits);
    out << static_cast<double>(v);
    if (static_cast<T>(std::strtod(out.str().c_str(), nullptr)) == v) return out.str();
  }
  return FormatDouble(static_cast<double>(v));
}

inline double ParseNumber(const std::string& key, const std::string& text) {
  const std::string t = Trim(text);
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(t.c_str(), &end);
  DYPHO_CHECK_INPUT(!t.empty() && *end == '\0' && std::isfinite(v))
      << key << ": '" << Printable(text) << "' is not a finite number";
  // 1e-400 reads as 0 (with ERANGE), which for some keys means "no limit".
  DYPHO_CHECK_INPUT(errno != ERANGE || v != 0)
      << key << ": '" << Printable(text) << "' is too small for a double (it would read as 0)";
  return v;
}

inline bool ParseBool(const std::string& key, const std::string& text) {
  std::string t = Trim(text);
  std::transform(t.begin(), t.end(), t.begin(), ::tolower);
  if (t == "true" || t == "yes" || t == "on" || t == "1") return true;
  if (t == "false" || t == "no" || t == "off" || t == "0") return false;
  DYPHO_CHECK_INPUT(false) << key << ": '" << text << "' is not a boolean (true/false)";
  return false;
}

inline constexpr double kNone = std::numeric_limits<double>::quiet_NaN();

// Builds the table; each Add binds a key to a field.
class Table {
 public:
  std::vector<OptionInfo> rows;

  template <typename T>
  void Num(const std::string& key, T* field, double lo, double hi, const std::string& units, const std::string& doc) {
    OptionInfo o;
    o.key = key;
    o.type = std::is_integral<T>::value ? "int" : "float";
    o.units = units;
    o.doc = doc;
    o.has_range = true;
    o.min = std::isnan(lo) ? -std::numeric_limits<double>::infinity() : lo;
    o.max = std::isnan(hi) ? std::numeric_limits<double>::infinity() : hi;
    const double mn = o.min, mx = o.max;
    o.get = [field] { return FormatField(*field); };
    o.set = [field, key, mn, mx](const std::string& text) {
      const double v = ParseNumber(key, text);
      if (std::is_integral<T>::value)
        DYPHO_CHECK_INPUT(v == std::floor(v)) << key << ": '" << text << "' is not an integer";
      DYPHO_CHECK_INPUT(v >= mn && v <= mx) << key << ": " << text << " is out of range [" << FormatDouble(mn)
                                            << ", " << FormatDouble(mx) << "]";
      *field = static_cast<T>(v);
    };
    rows.push_back(std::move(o));
  }
  void Bool(const std::string& key, bool* field, const std::string& doc) {
    OptionInfo o;
    o.key = key;
    o.type = "bool";
    o.doc = doc;
    o.get = [field] { return std::string(*field ? "true" : "false"); };
    o.set = [field, key](const std::string& text) { *field = ParseBool(key, text); };
    rows.push_back(std::move(o));
  }
  void Str(const std::string& key, std::string* field, const std::vector<std::string>& allowed,
           const std::string& doc) {
    OptionInfo o;
    o.key = key;
    o.type = "string";
    o.doc = doc;
    o.get = [field] { return *field; };
    o.set = [field, key, allowed](const std::string& text) {
      const std::string t = Trim(text);
      if (!allowed.empty()) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : "|") + a;
        DYPHO_CHECK_INPUT(std::find(allowed.begin(), allowed.end(), t) != allowed.end())
            << key << ": '" << text << "' is not one of " << list;
      }
      *field = t;
    };
    rows.push_back(std::move(o));
  }
  void List(const std::string& key, std::vector<std::string>* field, const std::string& doc) {
    OptionInfo o;
    o.key = key;
    o.type = "list";
    o.doc = doc;
    o.get = [field] {
      std::string s;
      for (const auto& v : *field) s += (s.empty() ? "" : ",") + v;
      return s;
    };
    o.set = [field](const std::string& text) {
      field->clear();
      std::stringstream in(text);
      std::string item;
      while (std::getline(in, item, ',')) {
        item = Trim(item);
        if (!item.empty()) field->push_back(item);
      }
    };
    rows.push_back(std::move(o));
  }
};

}  // namespace option_table
}  // namespace dypho
