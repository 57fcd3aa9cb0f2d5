#include "engine/eval/kitti_error.h"

#include "common/check.h"

namespace dypho {

KittiError ComputeKittiError(const Trajectory& gt, const Trajectory& est, const std::vector<double>& lengths) {
  DYPHO_CHECK_INPUT(gt.size() == est.size()) << "KITTI error: " << gt.size() << " ground-truth poses but "
                                             << est.size() << " estimated ones (one per frame expected)";
  std::vector<double> distance(gt.size(), 0.0);
  for (size_t i = 1; i < gt.size(); ++i)
    distance[i] = distance[i - 1] + (gt.world_from_cam[i].translation - gt.world_from_cam[i - 1].translation).norm();
  KittiError e;
  double t_sum = 0, r_sum = 0;
  for (size_t i = 0; i < gt.size(); ++i)
    for (double length : lengths) {
      size_t j = i;
      while (j < gt.size() && distance[j] - distance[i] < length) ++j;
      if (j >= gt.size()) continue;
      const Rigid3d gt_rel = gt.world_from_cam[i].Inverse() * gt.world_from_cam[j];
      const Rigid3d est_rel = est.world_from_cam[i].Inverse() * est.world_from_cam[j];
      const Rigid3d error = gt_rel.Inverse() * est_rel;
      t_sum += error.translation.norm() / length;
      r_sum += Eigen::AngleAxisd(error.rotation).angle() / length;
      ++e.segments;
    }
  if (e.segments > 0) {
    e.translation_percent = 100 * t_sum / e.segments;
    e.rotation_deg_per_m = r_sum / e.segments * 180 / M_PI;
  }
  return e;
}

}  // namespace dypho
