// AdamParam (engine/torch/adam.h) against an independent scalar Adam in
// double precision: the fused sparse step on CPU and the dense step, with
// rows that are not visible left exactly as they were (values, moments and
// step counts).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "engine/torch/adam.h"

namespace dypho {
namespace {

struct Reference {  // one row-major matrix, per-row step counts
  std::vector<double> value, m, v;
  std::vector<int> steps;
  int cols = 0;
  void Step(const std::vector<float>& grad, const std::vector<bool>& visible, const std::vector<double>& lr) {
    for (size_t r = 0; r < steps.size(); ++r) {
      if (!visible[r]) continue;
      const int n = ++steps[r];
      for (int c = 0; c < cols; ++c) {
        const size_t i = r * cols + c;
        m[i] = 0.9 * m[i] + 0.1 * grad[i];
        v[i] = 0.999 * v[i] + 0.001 * grad[i] * grad[i];
        const double mh = m[i] / (1 - std::pow(0.9, n)), vh = v[i] / (1 - std::pow(0.999, n));
        value[i] -= lr[c] * mh / (std::sqrt(vh) + 1e-15);
      }
    }
  }
};

// `column_rates`: Step gets a [1, cols] tensor of rates (the pose twists'
// translation and rotation rates) instead of the scalar lr.
void CheckSteps(bool sparse, bool column_rates = false) {
  const int rows = 300, cols = 4;
  const float lr = 0.01f;
  const std::vector<float> rates = {0.01f, 0.02f, 0.005f, 0.03f};
  std::vector<double> ref_lr(cols, lr);
  if (column_rates) ref_lr.assign(rates.begin(), rates.end());
  const torch::Tensor rate_tensor =
      column_rates ? torch::tensor(rates, torch::kFloat32).view({1, cols}) : torch::Tensor();
  std::mt19937 rng(7);
  std::normal_distribution<float> normal;
  std::vector<float> init(rows * cols);
  for (float& x : init) x = normal(rng);
  AdamParam p;
  p.Init(torch::from_blob(init.data(), {rows, cols}, torch::kFloat32).clone(), lr);
  Reference ref{std::vector<double>(init.begin(), init.end()), std::vector<double>(init.size(), 0.0),
                std::vector<double>(init.size(), 0.0), std::vector<int>(rows, 0), cols};
  for (int step = 0; step < 5; ++step) {
    std::vector<float> grad(rows * cols);
    for (float& g : grad) g = normal(rng);
    std::vector<bool> visible(rows, true);
    std::vector<uint8_t> vis_bytes(rows, 1);
    if (sparse) {
      for (int r = 0; r < rows; ++r) {
        visible[r] = (r + step) % 3 != 0;
        vis_bytes[r] = visible[r];
        if (!visible[r]) std::fill(grad.begin() + r * cols, grad.begin() + (r + 1) * cols, 0.0f);
      }
    }
    const torch::Tensor before = p.value.detach().clone(), m_before = p.m.clone();
    p.value.mutable_grad() = torch::from_blob(grad.data(), {rows, cols}, torch::kFloat32).clone();
    if (sparse) {
      p.Step(torch::from_blob(vis_bytes.data(), {rows}, torch::kUInt8).to(torch::kBool), rate_tensor);
    } else {
      p.Step(torch::Tensor(), rate_tensor);
    }
    ref.Step(grad, visible, ref_lr);
    EXPECT_FALSE(p.value.grad().defined());
    const float* got = p.value.data_ptr<float>();
    for (int r = 0; r < rows; ++r) {
      EXPECT_EQ(p.steps[r].item<float>(), ref.steps[r]) << "row " << r;
      for (int c = 0; c < cols; ++c) {
        const size_t i = r * cols + c;
        EXPECT_NEAR(got[i], ref.value[i], 2e-6) << "row " << r << " step " << step;
        if (!visible[r]) {
          EXPECT_EQ(got[i], before[r][c].item<float>());  // untouched, bit for bit
          EXPECT_EQ(p.m[r][c].item<float>(), m_before[r][c].item<float>());
        }
      }
    }
    if (step == 0) {
      // First step: the bias-corrected update is lr * g / |g| = lr * sign(g).
      for (size_t i = 0; i < grad.size(); ++i) {
        if (visible[i / cols] && grad[i] != 0)
          EXPECT_NEAR(got[i], init[i] - ref_lr[i % cols] * (grad[i] > 0 ? 1 : -1), 1e-6);
      }
    }
  }
}

TEST(AdamParam, DenseStepMatchesAScalarReference) { CheckSteps(false); }

TEST(AdamParam, SparseStepUpdatesOnlyVisibleRowsAndMatchesTheReference) { CheckSteps(true); }

TEST(AdamParam, RatesPerColumnDenseAndSparseMatchTheReference) {
  CheckSteps(false, true);
  CheckSteps(true, true);
}

TEST(AdamParam, AppendedRowsStartTheirOwnBiasCorrection) {
  AdamParam p;
  p.Init(torch::zeros({2, 1}), 0.1f);
  p.value.mutable_grad() = torch::ones({2, 1});
  p.Step(torch::ones({2}, torch::kBool));
  p.Append(torch::zeros({1, 1}));
  p.value.mutable_grad() = torch::full({3, 1}, -1.0f);
  p.Step(torch::ones({3}, torch::kBool));
  // The new row's first step is a full lr step (sign of the gradient).
  EXPECT_NEAR(p.value[2][0].item<float>(), 0.1f, 1e-6);
  EXPECT_EQ(p.steps[2].item<float>(), 1.0f);
  EXPECT_EQ(p.steps[0].item<float>(), 2.0f);
}

}  // namespace
}  // namespace dypho
