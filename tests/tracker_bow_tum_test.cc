// Place recognition with the bag of words on the real TUM fr1/rpy frames:
// a vocabulary trained on some frames ranks the nearest keyframe of the
// sequence first for other frames; the tracker relocalises a kidnapped
// frame with bag-of-words candidates only (thumbnails off); a corrupt
// vocabulary file given to the tracker is an error naming it.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/dataset/dataset.h"
#include "engine/eval/trajectory.h"
#include "tests/test_data.h"
#include "tracker/backend/bow_database.h"
#include "tracker/backend/vocabulary.h"
#include "tracker/cv_view.h"
#include "tracker/orb_extractor.h"
#include "tracker/orb_tracker.h"

namespace dypho {
namespace {

using ::dypho::testing::SharedData;

constexpr char kRpy[] = "tum_fr1_rpy_head250";

TrackerFrame ToTrackerFrame(const Frame& f) {
  TrackerFrame t;
  t.timestamp = f.timestamp;
  t.image = CvView(f.rgb);
  if (f.has_depth) t.depth = CvView(f.depth);
  return t;
}

// The ground-truth orientation of frame i (interpolated at its time).
Eigen::Quaterniond GtRotation(const Dataset& dataset, size_t i) {
  const auto& gt = dataset.info(i).world_from_cam_gt;
  EXPECT_TRUE(gt.has_value()) << "frame " << i << " has no ground truth";
  return gt ? gt->rotation : Eigen::Quaterniond::Identity();
}

double ViewAngleDeg(const Dataset& dataset, size_t a, size_t b) {
  return RotationAngle(GtRotation(dataset, a), GtRotation(dataset, b)) * 180.0 / M_PI;
}

TEST(TrackerBowTum, VocabularyRanksAFrameOfTheSameViewFirst) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const auto dataset = OpenDataset(SharedData(kRpy));
  OrbExtractor extractor(OrbExtractorOptions(), dataset->camera());
  auto descriptors = [&](size_t i) {
    cv::Mat gray;
    cv::cvtColor(CvView(dataset->Load(i).rgb), gray, cv::COLOR_RGB2GRAY);
    return DescriptorsFromMat(extractor.Extract(gray).descriptors);
  };
  // Train on frames 0, 25, ..., 225; index frames 0, 10, ..., 240.
  std::vector<std::vector<Descriptor>> training;
  for (size_t i = 0; i < 250; i += 25) training.push_back(descriptors(i));
  VocabularyOptions options;
  options.branching = 10;
  options.levels = 3;
  const Vocabulary vocabulary = Vocabulary::Train(training, options);
  BowDatabase db;
  for (size_t i = 0; i < 250; i += 10) db.Add(static_cast<int>(i), vocabulary.Transform(descriptors(i)));
  // Query frames between the indexed ones (fr1/rpy turns back and forth,
  // so the same view recurs far apart in time): the best match looks the
  // same way (ground truth within kMaxAngle), and is much closer in view
  // than the indexed frames are on average.
  constexpr double kMaxAngle = 10.0;  // [deg]
  int hits = 0, queries = 0;
  double mean_best = 0.0, mean_all = 0.0, query_ms = 0.0;
  for (size_t q = 5; q < 250; q += 20) {
    const std::vector<Descriptor> d = descriptors(q);
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<BowMatch> m = db.Query(vocabulary.Transform(d), 1);
    query_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_FALSE(m.empty());
    ++queries;
    const double angle = ViewAngleDeg(*dataset, q, m[0].entry);
    hits += angle <= kMaxAngle;
    EXPECT_LT(angle, 20.0) << "frame " << q << " best " << m[0].entry;
    mean_best += angle;
    for (size_t i = 0; i < 250; i += 10) mean_all += ViewAngleDeg(*dataset, q, i) / 25.0;
    std::printf("frame %zu: best %d (score %.3f), view %.1f deg apart\n", q, m[0].entry, m[0].score, angle);
  }
  mean_best /= queries;
  mean_all /= queries;
  std::printf("%d of %d within %.0f deg; mean view angle to the best %.1f deg, to all %.1f deg; %.2f ms per query "
              "(transform + inverted index, %d words, 25 entries)\n", hits, queries, kMaxAngle, mean_best, mean_all,
              query_ms / queries, vocabulary.num_words());
  // Measured: 11 of 13 within 10 deg (the others 11.1 and 15.5: ORB is
  // rotation invariant, the angle includes roll), mean 5.9 against 35.7 deg.
  EXPECT_GE(hits, 10) << hits << " of " << queries;
  EXPECT_LT(mean_best, 0.25 * mean_all);
}

TEST(TrackerBowTum, KidnappedFrameRelocalisedByBagOfWords) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const auto dataset = OpenDataset(SharedData(kRpy));
  OrbTrackerOptions options;
  options.rolling_shutter_readout = 0.025;
  options.relocalisation_thumbnails = false;  // bag of words (and the reference keyframe) only
  OrbTracker tracker(dataset->camera(), options);
  for (size_t i = 0; i < 120; ++i) ASSERT_TRUE(IsTracked(tracker.Track(ToTrackerFrame(dataset->Load(i))).status)) << i;
  // The kidnapped frame: the earlier frame whose view is farthest from
  // frame 119's (ground truth).
  size_t far = 0;
  for (size_t i = 0; i < 100; ++i)
    if (ViewAngleDeg(*dataset, i, 119) > ViewAngleDeg(*dataset, far, 119)) far = i;
  std::printf("kidnapped to frame %zu, %.1f deg from frame 119\n", far, ViewAngleDeg(*dataset, far, 119));
  EXPECT_TRUE(tracker.has_vocabulary());  // trained at start-up from the first keyframes
  EXPECT_EQ(tracker.num_bow_entries(), tracker.num_live_keyframes());
  // The motion model and the reference keyframe fail there; the bag of
  // words finds the place.
  Frame kidnapped = dataset->Load(far);
  kidnapped.timestamp = dataset->Load(119).timestamp + 0.033;
  const TrackResult r = tracker.Track(ToTrackerFrame(kidnapped));
  std::printf("kidnapped frame: %s, %d inliers, source %s\n", TrackStatusName(r.status), r.num_inliers,
              CoarseSourceName(r.coarse_source));
  EXPECT_EQ(r.status, TrackStatus::kRelocalized) << r.message;
  // Without either cue it stays lost (the test can fail).
  OrbTrackerOptions blind = options;
  blind.relocalisation_bow = false;
  OrbTracker blind_tracker(dataset->camera(), blind);
  for (size_t i = 0; i < 120; ++i) blind_tracker.Track(ToTrackerFrame(dataset->Load(i)));
  EXPECT_NE(blind_tracker.Track(ToTrackerFrame(kidnapped)).status, TrackStatus::kRelocalized);
}

TEST(TrackerBowTum, CorruptVocabularyFileIsAnErrorNamingIt) {
  const std::string dir = std::string(DYPHO_BINARY_DIR) + "/test_tmp/tracker_bow";
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/corrupt_vocab.bin";
  std::ofstream(path) << "DYPHOVOC garbage";
  Camera camera;
  camera.fx = camera.fy = 500;
  camera.cx = 319.5;
  camera.cy = 239.5;
  camera.width = 640;
  camera.height = 480;
  OrbTrackerOptions options;
  options.vocabulary_path = path;
  try {
    OrbTracker tracker(camera, options);
    FAIL() << "no error for " << path;
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("vocabulary file " + path), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dypho
