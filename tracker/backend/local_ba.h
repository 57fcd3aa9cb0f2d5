// Local bundle adjustment: after a new keyframe, the poses of it and its
// covisible keyframes and the positions of the map points they see are
// optimised together; the other keyframes that see those points enter with
// fixed poses (ORB-SLAM's local BA).
//
// Residuals of an observation (keyframe k sees point X at feature f: pixel
// (u, v), depth z_f (optional), sigma s = scale_factor^level, static weight
// w, rolling-shutter correction C = Exp(twist_k * tau(row_f))), with
// P = C * cam_from_world_k * X: the same as the motion-only optimiser
// (tracker/pose_optimizer.h): reprojection r_uv = (proj(P) - (u, v)) / s and
// the virtual-stereo disparity residual r_d = (bf / P.z - bf / z_f) /
// (s * disparity_sigma_scale). Cost sum w * Huber(e^2) with delta^2 = chi2 of
// the observation's kind; observations with w = 0 carry no residual.
//
// Passes: first_iterations LM iterations, then the observations with
// e^2 > chi2 (or behind the camera) are dropped and `iterations` more run;
// observations still over chi2 at the end are outliers, which ApplyLocalBa
// erases from the map. Two solvers of the same cost (LocalBaOptions::solver):
//  - "eigen" (default): our sparse LM (tracker/backend/sparse_lm.h):
//    analytic Jacobians (those of the motion-only optimiser), SE(3) left
//    update, the points eliminated by the Schur complement (3x3 blocks),
//    the dense reduced camera system solved by LDLT, Ceres's LM
//    trust-region rules and tolerances.
//  - "ceres": Ceres (automatic derivatives, Eigen quaternion manifold plus
//    translation, Huber inside ScaledLoss, DENSE_SCHUR with the points
//    eliminated, LM with Ceres's default trust region and tolerances).
// On the same problem both reach the same cost (within 1e-4 relative at
// the default iterations in the tests, the same optimum at convergence);
// the poses differ by the steps' different paths (SE(3) vs quaternion +
// translation update): well under a millimetre in the tests, the head250
// and walkers trajectories within 0.6 mm, the same ATEs. "eigen" is 8-10x
// faster per BA on the tracking thread (head250: 3.4 vs 31 ms with a
// keyframe every 30 frames, 8.5 vs 72 ms every 5; global BA after the
// synthetic loop 19 vs 210 ms). Of Ceres's 74 ms (head250, every 5
// frames) 27 ms are its Schur linear solver, 16 ms its automatic
// Jacobians, 15 ms building and preprocessing its problem (BENCHMARKS.md,
// "Local BA: our sparse LM against Ceres").
//
// The stages are split so that the solve can run on another thread on a
// snapshot: BuildLocalBaProblem (reads the map), SolveLocalBa (no map),
// ApplyLocalBa (writes the map; skips what was culled in between).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/camera.h"
#include "common/rigid3.h"
#include "tracker/backend/sparse_map.h"
#include "tracker/pose_optimizer.h"

namespace dypho {

struct LocalBaOptions {
  bool enabled = true;          // run local BA after every keyframe
  bool threaded = false;        // solve on a back-end thread (applied at a later frame); false = on the tracking thread, deterministic
  // Threaded: the solution of the keyframe made at frame f is applied at
  // frame f + fixed_lag exactly (the tracker waits for a late one; a new
  // solve starts only after that), so the results do not depend on timing;
  // 0 = applied at the first frame after it is ready [frames], 0..1000.
  // Not threaded: > 0 solves on the tracking thread and applies the
  // solution at f + fixed_lag as a threaded run does; 0 applies it at once.
  int fixed_lag = 0;
  int max_keyframes = 10;       // covisible keyframes optimised with the new one (most shared points first), >= 1
  int min_shared = 5;           // shared map points that make two keyframes covisible, >= 1 (head250: 5 gives 1.13 cm, 15 gives 1.18)
  int max_fixed_keyframes = 20; // other keyframes that see the local points, entering fixed (most shared first), >= 1
  int first_iterations = 5;     // LM iterations before the outliers are dropped, >= 1
  int iterations = 10;          // LM iterations after that, >= 0
  bool cull_keyframes = true;   // cull redundant local keyframes after the BA (tracker/backend/keyframe_culling.h)
  // The solver of both passes (and of the global BA after a loop, which
  // takes these options): "eigen" (our sparse LM, tracker/backend/sparse_lm.h;
  // 8-10x faster per BA, the same ATEs; see the header comment) or "ceres"
  // (Ceres, automatic derivatives, DENSE_SCHUR); the same cost.
  std::string solver = "eigen";
  // The depth residual's sigma scale in the BA (PoseOptimizerOptions::
  // disparity_sigma_scale of the BA's cost); 0 = the motion-only
  // optimiser's. >= 0.
  double disparity_sigma_scale = 0.0;

  bool IsValid(std::string* error) const;
};

struct LocalBaObservation {
  int pose = -1;       // index into LocalBaProblem::keyframes
  int point = -1;      // index into LocalBaProblem::points
  int feature = -1;    // feature index in that keyframe
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // undistorted [px]
  double depth = 0.0;  // [m], <= 0 = no depth residual (has_depth)
  double sigma = 1.0;  // [px]
  double weight = 1.0; // static weight
  Rigid3d row_cam_from_cam;  // rolling-shutter correction (identity for a global shutter)

  bool has_depth() const { return std::isfinite(depth) && depth > 0.0; }
};

// A snapshot of the local window.
struct LocalBaProblem {
  int keyframe = -1;                     // the new keyframe
  std::vector<int> keyframes;            // keyframe ids in the problem
  std::vector<Rigid3d> cam_from_world;   // their poses
  std::vector<char> fixed;               // per keyframe: pose held fixed
  std::vector<long> points;              // map point ids
  std::vector<Eigen::Vector3d> positions;  // their world positions [m]
  std::vector<LocalBaObservation> observations;

  int num_free_keyframes() const;
};

struct LocalBaSolution {
  LocalBaProblem problem;                // with the optimised poses and positions
  std::vector<char> outlier;             // per observation
  double initial_cost = 0.0;             // cost before / after (Ceres's 0.5 * sum of robust terms; -1: not evaluated)
  double final_cost = 0.0;
  int iterations = 0;                    // LM steps done, taken or not (Ceres also counts its start, +1 a pass)
  double solve_ms = 0.0;                 // wall time of SolveLocalBa
  bool usable = false;                   // the solve ran and gave finite values
};

// The local window of keyframe `kf`. Uses `readout` [s] and camera.height for
// the rolling-shutter correction (readout 0 = global shutter) and
// `scale_factor` for the sigma of each level.
LocalBaProblem BuildLocalBaProblem(const SparseMap& map, int kf, const LocalBaOptions& options, const Camera& camera,
                                   double scale_factor, double readout);

// Every live keyframe (keyframe `fixed_keyframe` fixed, the others free) and
// every live point: the global BA after a loop closure.
LocalBaProblem BuildGlobalBaProblem(const SparseMap& map, int fixed_keyframe, const Camera& camera,
                                    double scale_factor, double readout);
// Optimises the problem (no access to the map).
LocalBaSolution SolveLocalBa(const Camera& camera, LocalBaProblem problem, const LocalBaOptions& options,
                             const PoseOptimizerOptions& residuals);

struct LocalBaApplied {
  int keyframes = 0;      // poses written
  int points = 0;         // positions written
  int erased = 0;         // outlier observations erased
};

// Writes the solution into the map: free poses of keyframes that are not bad,
// positions of points that are not bad, and erases the outlier observations
// that still exist.
LocalBaApplied ApplyLocalBa(const LocalBaSolution& solution, SparseMap* map);

}  // namespace dypho
