// The ORB work made ahead of the masks (OrbExtractor::Prepare,
// OrbTracker::PrepareJob, the pipeline's SideWorker): the features and poses
// are exactly those made without it, whatever threshold it was prepared at
// (a level prepared above what the masks call for is detected again).
#include <gtest/gtest.h>

#include <pthread.h>

#include <cstdio>
#include <future>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/dataset/dataset.h"
#include "common/side_worker.h"
#include "tests/test_data.h"
#include "tracker/cv_view.h"
#include "tracker/orb_extractor.h"
#include "tracker/orb_tracker.h"

namespace dypho {
namespace {

using ::dypho::testing::SharedData;

constexpr char kRpy[] = "tum_fr1_rpy_head250";

cv::Mat Gray(const Frame& frame) {
  cv::Mat gray;
  cv::cvtColor(CvView(frame.rgb), gray, cv::COLOR_RGB2GRAY);
  return gray;
}

void ExpectSameFeatures(const OrbFeatures& a, const OrbFeatures& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a.keypoints[i].pt, b.keypoints[i].pt) << what << ", feature " << i;
    ASSERT_EQ(a.keypoints[i].angle, b.keypoints[i].angle) << what << ", feature " << i;
    ASSERT_EQ(a.keypoints[i].response, b.keypoints[i].response) << what << ", feature " << i;
    ASSERT_EQ(a.keypoints[i].octave, b.keypoints[i].octave) << what << ", feature " << i;
    ASSERT_EQ(a.points[i], b.points[i]) << what << ", feature " << i;
    ASSERT_EQ(a.weights[i], b.weights[i]) << what << ", feature " << i;
  }
  EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_HAMMING), 0.0) << what;
}

// Masks of growing coverage: none, a person-sized blob, 40 % of the width.
std::vector<cv::Mat> Masks(int width, int height) {
  std::vector<cv::Mat> masks(1);
  cv::Mat blob(height, width, CV_8UC1, cv::Scalar(0));
  cv::ellipse(blob, cv::Point(width / 3, height / 2), cv::Size(70, 180), 0, 0, 360, cv::Scalar(255), cv::FILLED);
  masks.push_back(blob);
  cv::Mat band(height, width, CV_8UC1, cv::Scalar(0));
  band(cv::Rect(width / 2, 0, static_cast<int>(0.4 * width), height)).setTo(255);
  masks.push_back(band);
  return masks;
}

TEST(OrbPrepared, SameFeaturesAtAnyPreparedThreshold) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const auto dataset = OpenDataset(SharedData(kRpy));
  const Camera& camera = dataset->camera();
  OrbExtractorOptions options;
  OrbExtractor plain(options, camera), ahead(options, camera);
  const int levels = options.num_levels;
  int prepared_levels = 0, redetected_levels = 0, compared = 0;
  for (size_t index : {0, 57, 120, 201}) {
    const cv::Mat gray = Gray(dataset->Load(index));
    for (const cv::Mat& mask : Masks(camera.width, camera.height)) {
      cv::Mat weight;
      if (!mask.empty()) {
        weight = cv::Mat(mask.size(), CV_32FC1, cv::Scalar(1.0f));
        weight.setTo(0.25f, mask);
      }
      OrbExtractionStats stats;
      const OrbFeatures expected = plain.Extract(gray, mask, weight, &stats);
      ASSERT_GT(expected.size(), 500u);
      EXPECT_EQ(stats.prepared_levels, 0);
      // Thresholds: the lowest allowed; 40 (above every main pass: all
      // detected again); then what the pipeline uses, the last extraction's
      // less 3 (the last extraction had this mask, as consecutive frames
      // nearly do: every level prepared).
      for (int s = 0; s < 3; ++s) {
        const std::vector<int> thresholds = s == 0   ? std::vector<int>(levels, options.min_fast_threshold)
                                            : s == 1 ? std::vector<int>(levels, 40)
                                                     : ahead.PrepareThresholds();
        const auto prepared = ahead.Prepare(gray, thresholds);
        OrbExtractionStats ahead_stats;
        const OrbFeatures got = ahead.Extract(gray, mask, weight, &ahead_stats, prepared.get());
        ExpectSameFeatures(expected, got,
                           "frame " + std::to_string(index) + ", mask " + std::to_string(cv::countNonZero(mask)) +
                               " px, thresholds " + std::to_string(s));
        EXPECT_EQ(ahead_stats.prepared_levels + ahead_stats.redetected_levels, levels);
        EXPECT_EQ(ahead_stats.prepared_levels, s == 1 ? 0 : levels) << "thresholds " << s;
        prepared_levels += ahead_stats.prepared_levels;
        redetected_levels += ahead_stats.redetected_levels;
        ++compared;
      }
    }
  }
  std::printf("%d extractions compared, the same features: %d levels prepared, %d detected again\n", compared,
              prepared_levels, redetected_levels);
}

TEST(OrbPrepared, BadInputThrowsNamingTheArgument) {
  Camera camera;
  camera.fx = camera.fy = 300;
  camera.cx = 79.5;
  camera.cy = 59.5;
  camera.width = 160;
  camera.height = 120;
  OrbExtractor extractor(OrbExtractorOptions(), camera);
  const cv::Mat gray(120, 160, CV_8UC1, cv::Scalar(0));
  const std::vector<int> thresholds = extractor.PrepareThresholds();
  ASSERT_EQ(thresholds.size(), 8u);
  auto message = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const InvalidInput& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_NE(message([&] { extractor.Prepare(cv::Mat(100, 160, CV_8UC1), thresholds); }).find("image"),
            std::string::npos);
  EXPECT_NE(message([&] { extractor.Prepare(gray, {20, 20}); }).find("thresholds"), std::string::npos);
  EXPECT_NE(message([&] { extractor.Prepare(gray, std::vector<int>(8, 0)); }).find("threshold"), std::string::npos);
  const auto other = extractor.Prepare(gray.clone(), thresholds);
  EXPECT_NE(message([&] { extractor.Extract(gray, cv::Mat(), cv::Mat(), nullptr, other.get()); }).find("prepared"),
            std::string::npos);
}

// Two trackers over the same frames, one given PrepareJob's result made on
// another thread: the same pose and inliers at every frame.
TEST(OrbPrepared, TrackerPosesAreTheSameWithPreparedFrames) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const auto dataset = OpenDataset(SharedData(kRpy));
  OrbTracker plain(dataset->camera()), ahead(dataset->camera());
  SideWorker worker(/*threaded=*/true, "test-prepare");
  cv::Mat mask(dataset->camera().height, dataset->camera().width, CV_8UC1, cv::Scalar(0));
  for (size_t i = 0; i < 40; ++i) {
    const Frame frame = dataset->Load(i);
    TrackerFrame tf;
    tf.timestamp = frame.timestamp;
    tf.image = CvView(frame.rgb);
    tf.depth = CvView(frame.depth);
    // A mask that moves over the frames, as a walker's would.
    mask.setTo(0);
    cv::rectangle(mask, cv::Rect(static_cast<int>(10 * i) % 400, 100, 160, 300), cv::Scalar(255), cv::FILLED);
    tf.dynamic_mask = mask;
    const TrackResult expected = plain.Track(tf);
    TrackerPrepareJob job = ahead.PrepareJob(tf.image);
    ASSERT_TRUE(job);
    tf.prepared = worker.Submit(job).get();
    ASSERT_NE(tf.prepared, nullptr);
    const TrackResult got = ahead.Track(tf);
    ASSERT_EQ(expected.status, got.status) << "frame " << i;
    ASSERT_EQ(expected.num_inliers, got.num_inliers) << "frame " << i;
    ASSERT_TRUE(expected.cam_from_world.ToMatrix() == got.cam_from_world.ToMatrix()) << "frame " << i;
  }
  // A prepared result of another image is not used (the pose stays right).
  const Frame a = dataset->Load(40), b = dataset->Load(41);
  TrackerFrame tf;
  tf.timestamp = a.timestamp;
  tf.image = CvView(a.rgb);
  tf.depth = CvView(a.depth);
  tf.prepared = ahead.PrepareJob(CvView(b.rgb))();
  const TrackResult expected = plain.Track(TrackerFrame{tf.timestamp, tf.image, tf.depth});
  const TrackResult got = ahead.Track(tf);
  EXPECT_EQ(expected.num_inliers, got.num_inliers);
  // Nothing to prepare for an image the tracker would refuse.
  EXPECT_FALSE(ahead.PrepareJob(cv::Mat(10, 10, CV_8UC3)));
}

TEST(SideWorker, RunsJobsInOrderOnItsThreadAndPassesExceptions) {
  SideWorker worker(/*threaded=*/true, "test-side");
  const std::thread::id caller = std::this_thread::get_id();
  std::vector<int> order;
  std::vector<std::future<std::string>> results;
  for (int i = 0; i < 5; ++i) {
    results.push_back(worker.Submit(std::function<std::string()>([&order, i, caller] {
      EXPECT_NE(std::this_thread::get_id(), caller);
      order.push_back(i);
      char name[16] = {};
      pthread_getname_np(pthread_self(), name, sizeof(name));
      return std::string(name);
    })));
  }
  for (auto& r : results) EXPECT_EQ(r.get(), "test-side");
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3, 4}));
  auto failing = worker.Submit(std::function<int()>([]() -> int { throw std::runtime_error("job failed"); }));
  EXPECT_THROW(failing.get(), std::runtime_error);
  EXPECT_EQ(worker.Submit(std::function<int()>([] { return 7; })).get(), 7);  // the thread lives on
}

TEST(SideWorker, NotThreadedRunsAtSubmit) {
  SideWorker worker(/*threaded=*/false, "unused");
  const std::thread::id caller = std::this_thread::get_id();
  bool ran = false;
  std::future<int> f = worker.Submit(std::function<int()>([&] {
    ran = true;
    EXPECT_EQ(std::this_thread::get_id(), caller);
    return 3;
  }));
  EXPECT_TRUE(ran);
  EXPECT_EQ(f.get(), 3);
}

TEST(SideWorker, AwaitedWaitsForItsJobWhenDropped) {
  SideWorker worker(/*threaded=*/true, "test-side");
  std::promise<void> release;
  std::shared_future<void> gate = release.get_future().share();
  bool done = false;
  std::thread opener;
  {
    Awaited<int> pending(worker.Submit(std::function<int()>([&done, gate] {
      gate.wait();
      done = true;
      return 1;
    })));
    opener = std::thread([&release] {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      release.set_value();
    });
  }  // waits here for the job
  EXPECT_TRUE(done);
  opener.join();
}

}  // namespace
}  // namespace dypho
