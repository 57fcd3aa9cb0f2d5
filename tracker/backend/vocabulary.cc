#include "tracker/backend/vocabulary.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <sstream>

#include "common/check.h"
#include "common/files.h"

namespace dypho {
namespace {

constexpr char kMagic[8] = {'D', 'Y', 'P', 'H', 'O', 'V', 'O', 'C'};
constexpr uint32_t kVersion = 1;
constexpr size_t kNodeBytes = 4 + 32 + 4 + 4;

// Bitwise majority of the members' descriptors (ties -> 0).
Descriptor Majority(const std::vector<Descriptor>& all, const std::vector<int>& members) {
  Descriptor out{};
  const size_t half = members.size() / 2;
  for (int word = 0; word < 4; ++word) {
    for (int bit = 0; bit < 64; ++bit) {
      size_t ones = 0;
      const uint64_t mask = uint64_t{1} << bit;
      for (int m : members) ones += (all[m][word] & mask) != 0;
      if (ones > half) out[word] |= mask;
    }
  }
  return out;
}

template <typename T>
void Put(std::string* out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out->append(bytes, sizeof(T));
}

template <typename T>
T Get(const std::string& in, size_t* at) {
  T value;
  std::memcpy(&value, in.data() + *at, sizeof(T));
  *at += sizeof(T);
  return value;
}

}  // namespace

double BowScore(const BowVector& a, const BowVector& b) {
  // |a - b|_1 = |a|_1 + |b|_1 + sum over common words (|a_w - b_w| - a_w - b_w).
  double l1 = 0.0;
  for (const auto& [w, v] : a) l1 += std::abs(v);
  for (const auto& [w, v] : b) l1 += std::abs(v);
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (ia->first < ib->first) {
      ++ia;
    } else if (ib->first < ia->first) {
      ++ib;
    } else {
      l1 += std::abs(ia->second - ib->second) - std::abs(ia->second) - std::abs(ib->second);
      ++ia;
      ++ib;
    }
  }
  return std::clamp(1.0 - 0.5 * l1, 0.0, 1.0);
}

bool VocabularyOptions::IsValid(std::string* error) const {
  std::ostringstream e;
  if (branching < 2) {
    e << "branching must be >= 2 (got " << branching << ")";
  } else if (levels < 1) {
    e << "levels must be >= 1 (got " << levels << ")";
  } else if (std::pow(static_cast<double>(branching), levels) > 1e7) {
    e << "branching^levels must be <= 1e7 words (got " << branching << "^" << levels << ")";
  } else if (iterations < 1) {
    e << "iterations must be >= 1 (got " << iterations << ")";
  } else {
    return true;
  }
  if (error != nullptr) *error = "VocabularyOptions." + e.str();
  return false;
}

void Vocabulary::Build(int node, const std::vector<Descriptor>& all, const std::vector<int>& members, int level,
                       const VocabularyOptions& options, unsigned* seed) {
  const int k = options.branching;
  if (level == options.levels || static_cast<int>(members.size()) <= k) {
    // A leaf: a word (also when too few descriptors are left to split).
    nodes_[node].word = num_words_++;
    word_node_.push_back(node);
    return;
  }
  std::mt19937 rng((*seed)++);
  // k-means++ seeding with the Hamming distance.
  std::vector<Descriptor> centres;
  centres.push_back(all[members[std::uniform_int_distribution<size_t>(0, members.size() - 1)(rng)]]);
  std::vector<double> d2(members.size(), std::numeric_limits<double>::max());
  while (static_cast<int>(centres.size()) < k) {
    double total = 0.0;
    for (size_t i = 0; i < members.size(); ++i) {
      const double d = HammingDistance(all[members[i]], centres.back());
      d2[i] = std::min(d2[i], d * d);
      total += d2[i];
    }
    if (total <= 0.0) break;  // all members equal the centres chosen
    double r = std::uniform_real_distribution<double>(0.0, total)(rng);
    size_t pick = 0;
    for (; pick + 1 < members.size(); ++pick) {
      r -= d2[pick];
      if (r <= 0.0 && d2[pick] > 0.0) break;
    }
    centres.push_back(all[members[pick]]);
  }
  // k-majority iterations.
  std::vector<int> assignment(members.size(), -1);
  std::vector<std::vector<int>> groups;
  for (int it = 0; it < options.iterations; ++it) {
    bool changed = false;
    for (size_t i = 0; i < members.size(); ++i) {
      int best = 0, best_d = 257;
      for (size_t c = 0; c < centres.size(); ++c) {
        const int d = HammingDistance(all[members[i]], centres[c]);
        if (d < best_d) {
          best_d = d;
          best = static_cast<int>(c);
        }
      }
      changed = changed || assignment[i] != best;
      assignment[i] = best;
    }
    groups.assign(centres.size(), {});
    for (size_t i = 0; i < members.size(); ++i) groups[assignment[i]].push_back(members[i]);
    if (!changed) break;
    for (size_t c = 0; c < centres.size(); ++c)
      if (!groups[c].empty()) centres[c] = Majority(all, groups[c]);
  }
  for (size_t c = 0; c < centres.size(); ++c) {
    if (groups[c].empty()) continue;
    const int child = static_cast<int>(nodes_.size());
    Node n;
    n.parent = node;
    n.descriptor = centres[c];
    nodes_.push_back(n);
    nodes_[node].children.push_back(child);
    Build(child, all, groups[c], level + 1, options, seed);
  }
}

Vocabulary Vocabulary::Train(const std::vector<std::vector<Descriptor>>& images, const VocabularyOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
  std::vector<Descriptor> all;
  for (const auto& image : images) all.insert(all.end(), image.begin(), image.end());
  DYPHO_CHECK_INPUT(!all.empty()) << "vocabulary training: no descriptors in " << images.size() << " images";
  Vocabulary v;
  v.branching_ = options.branching;
  v.levels_ = options.levels;
  v.nodes_.emplace_back();
  std::vector<int> members(all.size());
  for (size_t i = 0; i < all.size(); ++i) members[i] = static_cast<int>(i);
  unsigned seed = options.seed;
  v.Build(0, all, members, 0, options, &seed);
  // idf over the training images.
  std::vector<int> images_with(v.num_words_, 0);
  int n_images = 0;
  for (const auto& image : images) {
    if (image.empty()) continue;
    ++n_images;
    std::vector<int> words;
    for (const Descriptor& d : image) words.push_back(v.Word(d));
    std::sort(words.begin(), words.end());
    words.erase(std::unique(words.begin(), words.end()), words.end());
    for (int w : words) ++images_with[w];
  }
  for (int w = 0; w < v.num_words_; ++w)
    v.nodes_[v.word_node_[w]].idf =
        static_cast<float>(std::log(static_cast<double>(n_images) / std::max(1, images_with[w])));
  return v;
}

int Vocabulary::Word(const Descriptor& d) const {
  DYPHO_CHECK(!nodes_.empty()) << "Vocabulary::Word on an empty vocabulary";
  int node = 0;
  while (nodes_[node].word < 0) {
    int best = nodes_[node].children.front(), best_d = 257;
    for (int c : nodes_[node].children) {
      const int dist = HammingDistance(d, nodes_[c].descriptor);
      if (dist < best_d) {
        best_d = dist;
        best = c;
      }
    }
    node = best;
  }
  return nodes_[node].word;
}

BowVector Vocabulary::Transform(const std::vector<Descriptor>& descriptors) const {
  BowVector v;
  if (descriptors.empty() || empty()) return v;
  for (const Descriptor& d : descriptors) v[Word(d)] += 1.0;
  double sum = 0.0;
  for (auto& [w, value] : v) {
    value = value / descriptors.size() * nodes_[word_node_[w]].idf;
    sum += value;
  }
  // Words in every training image have idf 0: drop them.
  for (auto it = v.begin(); it != v.end();) it = it->second > 0.0 ? std::next(it) : v.erase(it);
  if (sum > 0.0)
    for (auto& [w, value] : v) value /= sum;
  return v;
}

void Vocabulary::Save(const std::string& path) const {
  std::string out(kMagic, sizeof(kMagic));
  Put<uint32_t>(&out, kVersion);
  Put<uint32_t>(&out, static_cast<uint32_t>(branching_));
  Put<uint32_t>(&out, static_cast<uint32_t>(levels_));
  Put<uint32_t>(&out, static_cast<uint32_t>(nodes_.size()));
  for (const Node& n : nodes_) {
    Put<int32_t>(&out, n.parent);
    for (uint64_t w : n.descriptor) Put<uint64_t>(&out, w);
    Put<float>(&out, n.idf);
    Put<int32_t>(&out, n.word);
  }
  WriteTextAtomically(path, out);
}

Vocabulary Vocabulary::Load(const std::string& path) {
  const std::string in = ReadTextFile(path);
  const std::string what = "vocabulary file " + path;
  DYPHO_CHECK_INPUT(!in.empty()) << what << " is empty";
  DYPHO_CHECK_INPUT(in.size() >= sizeof(kMagic) + 16 && std::memcmp(in.data(), kMagic, sizeof(kMagic)) == 0)
      << what << " is not a dypho vocabulary (no DYPHOVOC header; train one with `dypho vocab train`)";
  size_t at = sizeof(kMagic);
  const uint32_t version = Get<uint32_t>(in, &at);
  DYPHO_CHECK_INPUT(version == kVersion) << what << ": version " << version << " (this build reads " << kVersion << ")";
  Vocabulary v;
  v.branching_ = static_cast<int>(Get<uint32_t>(in, &at));
  v.levels_ = static_cast<int>(Get<uint32_t>(in, &at));
  const uint32_t n = Get<uint32_t>(in, &at);
  DYPHO_CHECK_INPUT(v.branching_ >= 2 && v.levels_ >= 1 && n >= 1)
      << what << ": invalid header (branching " << v.branching_ << ", levels " << v.levels_ << ", nodes " << n << ")";
  DYPHO_CHECK_INPUT(in.size() == at + static_cast<size_t>(n) * kNodeBytes)
      << what << " is truncated or has trailing bytes (" << in.size() << " bytes, " << n << " nodes need "
      << at + static_cast<size_t>(n) * kNodeBytes << ")";
  v.nodes_.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    Node& node = v.nodes_[i];
    node.parent = Get<int32_t>(in, &at);
    for (uint64_t& w : node.descriptor) w = Get<uint64_t>(in, &at);
    node.idf = Get<float>(in, &at);
    node.word = Get<int32_t>(in, &at);
    DYPHO_CHECK_INPUT(i == 0 ? node.parent == -1 : (node.parent >= 0 && node.parent < static_cast<int>(i)))
        << what << ": node " << i << " has parent " << node.parent;
    DYPHO_CHECK_INPUT(std::isfinite(node.idf) && node.idf >= 0.0f) << what << ": node " << i << " has idf " << node.idf;
    if (i > 0) {
      DYPHO_CHECK_INPUT(v.nodes_[node.parent].word < 0) << what << ": node " << i << " is a child of word node " << node.parent;
      v.nodes_[node.parent].children.push_back(static_cast<int>(i));
    }
    if (node.word >= 0) {
      DYPHO_CHECK_INPUT(node.word == v.num_words_) << what << ": node " << i << " has word " << node.word
                                                  << ", expected " << v.num_words_;
      v.word_node_.push_back(static_cast<int>(i));
      ++v.num_words_;
    }
  }
  for (uint32_t i = 0; i < n; ++i)
    DYPHO_CHECK_INPUT((v.nodes_[i].word >= 0) != !v.nodes_[i].children.empty())
        << what << ": node " << i << " is neither a word nor has children";
  return v;
}

}  // namespace dypho
