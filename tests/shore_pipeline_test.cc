// The nearshore comparison (`dypho ablate --preset shore`) on the synthetic
// harbour (engine/synth/shore/), counted against the generator's exact
// masks: the shore mask leaves no feature inside water or sky (features
// there without it), and the shore + semantic + epipolar masks keep the
// ORB tracker within a third of the ATE it has without masks. The
// generator's dynamic masks (masks/) stand in for the detector.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <string>

#include "common/check.h"
#include "engine/pipeline/feature_classes.h"
#include "engine/pipeline/pipeline.h"
#include "tests/pipeline_test_options.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

// Water/sky features more than 4 px inside the class: the shore mask's
// morphology (erode 5, dilate 15, erode 9 px at half size) moves its
// boundary by a few pixels; at 2 px 8 water and 14 sky features remain in
// 100 frames (skyline corners, glint specks), at 4 px none.
constexpr int kInnerPx = 4;

PipelineOptions ShoreOptions() {
  PipelineOptions o = PresetOptions("shore");
  o.synth.frames = 100;  // the boat crosses the view in the second half
  o.sequential = true;
  o.iterations_per_keyframe = 5;
  o.final_iterations = 0;
  testing::SkipExtraOutputs(&o);
  return o;
}

const Dataset& Harbour() {
  static const std::unique_ptr<Dataset> dataset =
      MakeBuiltInSequence(ShoreOptions(), std::string(DYPHO_BINARY_DIR) + "/test_tmp/shore_pipeline_sequence");
  return *dataset;
}

struct Row {
  PipelineResult result;
  FeatureClassCounts exact;  // features on the exact class pixels
  FeatureClassCounts inner;  // ... more than kInnerPx inside water / sky
};

// One row of the shore ablation, run once per test program.
const Row& RunRow(const std::vector<std::string>& disabled) {
  static std::map<std::vector<std::string>, Row> rows;
  auto it = rows.find(disabled);
  if (it != rows.end()) return it->second;
  PipelineOptions o = ShoreOptions();
  for (const std::string& s : disabled) DisableStage(&o, s);
  FeatureClassCounter exact(Harbour()), inner(Harbour(), kInnerPx);
  PipelineHooks hooks;
  hooks.show_progress = false;
  hooks.on_features = [&](size_t i, const std::vector<Eigen::Vector2f>& p) {
    exact.Add(i, p);
    inner.Add(i, p);
  };
  std::string name;
  for (const std::string& s : disabled) name += "_" + s;
  Row row;
  row.result = RunPipeline(o, Harbour(), std::string(DYPHO_BINARY_DIR) + "/test_tmp/shore_pipeline_row" + name, hooks);
  row.exact = exact.counts();
  row.inner = inner.counts();
  const FeatureClassCounts& c = row.exact;
  std::printf("shore row [%s]: ATE %.2f cm, %ld frames, features/frame %.1f, on water %.2f (inside %.2f), sky %.2f "
              "(inside %.2f), moving %.2f\n",
              name.c_str(), 100 * row.result.ate_rmse, c.frames, c.PerFrame(c.features), c.PerFrame(c.water),
              row.inner.PerFrame(row.inner.water), c.PerFrame(c.sky), row.inner.PerFrame(row.inner.sky),
              c.PerFrame(c.dynamic));
  return rows.emplace(disabled, std::move(row)).first->second;
}

const std::vector<std::string> kNoMasks = {"masking"};
const std::vector<std::string> kShoreOnly = {"refine", "flow", "semantic", "epipolar"};
const std::vector<std::string> kShoreSemanticEpipolar = {"refine", "flow"};

TEST(ShorePipeline, ShoreMaskLeavesNoFeatureInsideWaterOrSky) {
  const Row& off = RunRow(kNoMasks);
  const Row& shore = RunRow(kShoreOnly);
  ASSERT_EQ(shore.exact.frames, 100);
  ASSERT_GT(shore.exact.features, 100 * 300);
  // Without it, features come from ripples, glints and clouds.
  EXPECT_GT(off.inner.water, 100 * 20);
  EXPECT_GT(off.inner.sky, 100 * 5);
  EXPECT_EQ(shore.inner.water, 0);
  EXPECT_EQ(shore.inner.sky, 0);
  // On the exact boundary (a corner on the skyline or the quay's water
  // line), a few per frame.
  EXPECT_LT(shore.exact.PerFrame(shore.exact.water + shore.exact.sky), 15.0);
  // The shore mask alone keeps the moving things.
  EXPECT_GT(shore.exact.dynamic, 100 * 20);
}

TEST(ShorePipeline, ShoreSemanticEpipolarAteIsAtMostAThirdOfNoMasks) {
  const Row& off = RunRow(kNoMasks);
  const Row& full = RunRow(kShoreSemanticEpipolar);
  ASSERT_TRUE(off.result.has_ate && full.result.has_ate);
  EXPECT_EQ(full.result.tracked, 100);
  EXPECT_EQ(full.exact.dynamic, 0);
  EXPECT_LE(3 * full.result.ate_rmse, off.result.ate_rmse);
  EXPECT_LT(full.result.ate_rmse, 0.10);  // [m]
  EXPECT_GT(off.result.ate_rmse, 0.30);
}

TEST(ShorePipeline, ClassCounterNamesAMissingMask) {
  FeatureClassCounter counter(Harbour());
  EXPECT_THROW(counter.Add(Harbour().size() + 5, {}), std::exception);
  EXPECT_THROW(FeatureClassCounter(Harbour(), -1), InvalidInput);
}

}  // namespace
}  // namespace dypho
