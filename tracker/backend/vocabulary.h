// A bag of binary words for ORB descriptors (place recognition), as
// Galvez-Lopez and Tardos describe for DBoW2 ("Bags of Binary Words for
// Fast Place Recognition in Image Sequences", IEEE T-RO 2012); our own code.
//
// Vocabulary tree: the training descriptors are clustered into `branching`
// groups by k-majority (k-medians for binary strings: k-means++ seeding with
// the Hamming distance, each centre the bitwise majority of its members),
// recursively up to `levels` levels; the leaves are the words. A descriptor
// goes down the tree to the nearest child at each level.
//
// Weights: tf-idf. idf(w) = log(N / n_w) over the N training images, n_w of
// which contain w (words no training image has get log(N)); an image's
// vector holds, per word, tf * idf with tf = (descriptors on w) / (all its
// descriptors), normalised to unit L1 norm. Similarity (DBoW2's L1 score):
// s(v1, v2) = 1 - 0.5 * |v1 - v2|_1 in [0, 1], 1 for equal vectors.
//
// File (`dypho vocab train`): "DYPHOVOC", uint32 version (1), branching,
// levels, number of nodes; per node int32 parent (-1 for the root), 32
// descriptor bytes, float32 idf, int32 word (-1 for inner nodes); little
// endian. Load throws InvalidInput naming the file for an empty, truncated
// or inconsistent file.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "tracker/orb_matcher.h"

namespace dypho {

// word -> weight, unit L1 norm (empty for an image without descriptors).
using BowVector = std::map<int, double>;

// DBoW2's L1 score in [0, 1].
double BowScore(const BowVector& a, const BowVector& b);

struct VocabularyOptions {
  int branching = 10;      // k: children per node, >= 2
  int levels = 4;          // depth of the tree (words <= branching^levels), >= 1
  int iterations = 10;     // k-majority iterations per node at most, >= 1
  unsigned seed = 1;       // k-means++ seeding

  bool IsValid(std::string* error) const;
};

class Vocabulary {
 public:
  Vocabulary() = default;
  // Trains on the descriptors of `images` (one vector per image). Throws
  // InvalidInput for invalid options or no descriptor at all.
  static Vocabulary Train(const std::vector<std::vector<Descriptor>>& images, const VocabularyOptions& options);
  // Throws InvalidInput naming `path` when it cannot be read or is not a
  // valid vocabulary.
  static Vocabulary Load(const std::string& path);
  // Writes atomically (a temporary file, then rename); throws InvalidInput
  // naming the path when it cannot be written.
  void Save(const std::string& path) const;

  bool empty() const { return num_words_ == 0; }
  int num_words() const { return num_words_; }
  int branching() const { return branching_; }
  int levels() const { return levels_; }
  // The word of one descriptor.
  int Word(const Descriptor& d) const;
  // The tf-idf vector of an image's descriptors.
  BowVector Transform(const std::vector<Descriptor>& descriptors) const;

 private:
  struct Node {
    int parent = -1;
    Descriptor descriptor{};
    std::vector<int> children;
    int word = -1;
    float idf = 0.0f;
  };
  void Build(int node, const std::vector<Descriptor>& descriptors, const std::vector<int>& members, int level,
             const VocabularyOptions& options, unsigned* seed);

  std::vector<Node> nodes_;
  std::vector<int> word_node_;  // word -> node
  int num_words_ = 0;
  int branching_ = 0;
  int levels_ = 0;
};

}  // namespace dypho
