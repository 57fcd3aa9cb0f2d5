// Bag of binary words: k-majority vocabulary tree, tf-idf vectors, the L1
// score, the inverted index, and the vocabulary file (bad files are clear
// errors naming the file).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <string>

#include "common/check.h"
#include "tracker/backend/bow_database.h"
#include "tracker/backend/vocabulary.h"

namespace dypho {
namespace {

Descriptor RandomDescriptor(std::mt19937_64* rng) { return {(*rng)(), (*rng)(), (*rng)(), (*rng)()}; }

// `d` with `bits` distinct random bits flipped.
Descriptor Flip(Descriptor d, int bits, std::mt19937_64* rng) {
  std::set<int> chosen;
  while (static_cast<int>(chosen.size()) < bits) chosen.insert(static_cast<int>((*rng)() % 256));
  for (int b : chosen) d[b / 64] ^= uint64_t{1} << (b % 64);
  return d;
}

// `clusters` random centres (about 128 bits apart), each image holding
// `per_image` noisy copies (<= 8 bits flipped) of the centres it sees.
struct ClusterData {
  std::vector<Descriptor> centres;
  std::vector<std::vector<Descriptor>> images;
  std::vector<std::vector<int>> labels;
};

ClusterData MakeClusters(int clusters, int num_images, int per_image, unsigned seed) {
  std::mt19937_64 rng(seed);
  ClusterData data;
  for (int c = 0; c < clusters; ++c) data.centres.push_back(RandomDescriptor(&rng));
  for (int i = 0; i < num_images; ++i) {
    std::vector<Descriptor> image;
    std::vector<int> labels;
    for (int j = 0; j < per_image; ++j) {
      // Image i sees the clusters i, i+1, i+2 (mod clusters).
      const int c = (i + j % 3) % clusters;
      image.push_back(Flip(data.centres[c], static_cast<int>(rng() % 9), &rng));
      labels.push_back(c);
    }
    data.images.push_back(image);
    data.labels.push_back(labels);
  }
  return data;
}

TEST(Vocabulary, KMajorityFindsTheClusters) {
  const ClusterData data = MakeClusters(8, 16, 30, 1);
  VocabularyOptions options;
  options.branching = 8;
  options.levels = 1;
  const Vocabulary v = Vocabulary::Train(data.images, options);
  ASSERT_EQ(v.num_words(), 8);
  // One word per cluster: every member of a cluster, and its centre, on it.
  std::vector<int> word_of(8, -1);
  std::set<int> words;
  for (size_t i = 0; i < data.images.size(); ++i) {
    for (size_t j = 0; j < data.images[i].size(); ++j) {
      const int c = data.labels[i][j];
      const int w = v.Word(data.images[i][j]);
      if (word_of[c] < 0) word_of[c] = w;
      EXPECT_EQ(w, word_of[c]) << "cluster " << c;
    }
  }
  for (int c = 0; c < 8; ++c) {
    EXPECT_EQ(v.Word(data.centres[c]), word_of[c]);
    words.insert(word_of[c]);
  }
  EXPECT_EQ(words.size(), 8u);
}

TEST(Vocabulary, TfIdfVectorsAndScores) {
  const ClusterData data = MakeClusters(8, 16, 30, 2);
  VocabularyOptions options;
  options.branching = 8;
  options.levels = 1;
  const Vocabulary v = Vocabulary::Train(data.images, options);
  ASSERT_EQ(v.num_words(), 8);  // one per cluster (previous test)
  const BowVector a = v.Transform(data.images[0]);
  double l1 = 0.0;
  for (const auto& [w, value] : a) l1 += value;
  EXPECT_NEAR(l1, 1.0, 1e-12);
  EXPECT_EQ(a.size(), 3u);  // image 0 sees 3 clusters; each appears in 6 of 16 images (idf log(16/6))
  for (const auto& [w, value] : a) EXPECT_NEAR(value, 1.0 / 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(BowScore(a, a), 1.0);
  // Image 1 shares clusters 1 and 2 with image 0; image 4 shares none.
  const BowVector b = v.Transform(data.images[1]), c = v.Transform(data.images[4]);
  EXPECT_NEAR(BowScore(a, b), 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(BowScore(a, c), 0.0, 1e-12);
  // The inverted index gives the same scores, best first.
  BowDatabase db;
  for (size_t i = 0; i < data.images.size(); ++i) db.Add(static_cast<int>(i), v.Transform(data.images[i]));
  const std::vector<BowMatch> m = db.Query(a, 3);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].entry, 0);
  EXPECT_NEAR(m[0].score, 1.0, 1e-12);
  // Image 8 sees the same clusters as image 0 (mod 8); then 1, 7, 9, 15 share two.
  EXPECT_EQ(m[1].entry, 8);
  EXPECT_NEAR(m[1].score, 1.0, 1e-12);
  EXPECT_EQ(m[2].entry, 1);
  EXPECT_NEAR(m[2].score, 2.0 / 3.0, 1e-12);
  const std::vector<BowMatch> without0 = db.Query(a, 0, {0});
  for (const BowMatch& x : without0) {
    EXPECT_NE(x.entry, 0);
    EXPECT_NEAR(x.score, BowScore(a, *db.Vector(x.entry)), 1e-12);
  }
  db.Erase(1);
  for (const BowMatch& x : db.Query(a, 0)) EXPECT_NE(x.entry, 1);
}

class VocabularyFile : public ::testing::Test {
 protected:
  std::string Path(const std::string& name) {
    const std::string dir = std::string(DYPHO_BINARY_DIR) + "/test_tmp/vocabulary";
    std::filesystem::create_directories(dir);
    return dir + "/" + name;
  }
  // The message of the InvalidInput thrown by Vocabulary::Load(path).
  std::string LoadError(const std::string& path) {
    try {
      Vocabulary::Load(path);
    } catch (const InvalidInput& e) {
      return e.what();
    }
    return "";
  }
};

TEST_F(VocabularyFile, SaveLoadRoundTrip) {
  const ClusterData data = MakeClusters(8, 16, 30, 3);
  VocabularyOptions options;
  options.branching = 3;
  options.levels = 3;
  const Vocabulary v = Vocabulary::Train(data.images, options);
  const std::string path = Path("voc.bin");
  v.Save(path);
  const Vocabulary back = Vocabulary::Load(path);
  EXPECT_EQ(back.num_words(), v.num_words());
  EXPECT_EQ(back.branching(), 3);
  EXPECT_EQ(back.levels(), 3);
  for (const auto& image : data.images) {
    const BowVector a = v.Transform(image), b = back.Transform(image);
    ASSERT_EQ(a.size(), b.size());
    for (auto ia = a.begin(), ib = b.begin(); ia != a.end(); ++ia, ++ib) {
      EXPECT_EQ(ia->first, ib->first);
      EXPECT_DOUBLE_EQ(ia->second, ib->second);
    }
  }
}

TEST_F(VocabularyFile, EmptyCorruptOrTruncatedIsAnErrorNamingTheFile) {
  const std::string empty = Path("empty.bin");
  std::ofstream(empty).close();
  EXPECT_NE(LoadError(empty).find("vocabulary file " + empty + " is empty"), std::string::npos) << LoadError(empty);

  const std::string text = Path("text.bin");
  std::ofstream(text) << "this is not a vocabulary, just some text long enough";
  EXPECT_NE(LoadError(text).find(text), std::string::npos);
  EXPECT_NE(LoadError(text).find("not a dypho vocabulary"), std::string::npos) << LoadError(text);

  // A valid file cut short, and one with a broken parent link.
  const ClusterData data = MakeClusters(8, 16, 30, 4);
  VocabularyOptions options;
  options.branching = 3;
  options.levels = 2;
  const std::string good = Path("good.bin");
  Vocabulary::Train(data.images, options).Save(good);
  std::string bytes;
  {
    std::ifstream in(good, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::string cut = Path("cut.bin");
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - 7);
  EXPECT_NE(LoadError(cut).find("vocabulary file " + cut + " is truncated"), std::string::npos) << LoadError(cut);
  std::string broken = bytes;
  const size_t second_node = 8 + 16 + 44;  // header, then node 0 (44 bytes); node 1's parent
  broken[second_node] = 5;                 // parent 5 > own index 1
  const std::string bad = Path("bad.bin");
  std::ofstream(bad, std::ios::binary) << broken;
  EXPECT_NE(LoadError(bad).find("vocabulary file " + bad + ": node 1 has parent 5"), std::string::npos)
      << LoadError(bad);

  EXPECT_NE(LoadError(Path("missing.bin")).find("missing.bin"), std::string::npos);
}

TEST(Vocabulary, TrainingWithoutDescriptorsIsAnError) {
  EXPECT_THROW(Vocabulary::Train({{}, {}}, VocabularyOptions()), InvalidInput);
  VocabularyOptions bad;
  bad.branching = 1;
  EXPECT_THROW(Vocabulary::Train({{Descriptor{}}}, bad), InvalidInput);
}

}  // namespace
}  // namespace dypho
