// A long run of the ORB tracker (local BA, keyframe and map-point culling,
// loops) over the synthetic loop (engine/synth, motion "loop", 320x240, no
// walkers): one lap (12 s at 15 fps) is rendered once and replayed lap after
// lap with increasing timestamps (the loop's pose repeats exactly after a
// lap), so every lap after the first revisits mapped ground. Samples the map
// size and the process's memory after every lap. Shared by
// tests/tracker_long_run_test.cc (a few laps) and
// tests/bench/long_run_bench.cc (3000 frames).
#pragma once

#include <malloc.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "engine/synth/camera_motion.h"
#include "engine/synth/synthetic_scene.h"
#include "tracker/cv_view.h"
#include "tracker/orb_tracker.h"

namespace dypho::testing {

constexpr double kLongRunFps = 15.0;
constexpr int kLongRunLapFrames = static_cast<int>(synth::kLoopPeriod * kLongRunFps);

struct LongRunSample {
  int frame = 0;            // frames tracked so far
  int live_keyframes = 0;   // keyframes not culled
  int keyframes = 0;        // keyframes ever made (culled ones keep their id)
  int live_points = 0;      // map points not culled
  long point_slots = 0;     // map point slots (live, culled, released for reuse)
  size_t loops = 0;         // loops closed so far
  int culled_keyframes = 0; // keyframes culled so far
  double rss_mb = 0.0;      // resident memory of the process [MiB]
  double heap_mb = 0.0;     // heap in use (malloc'd, not freed) [MiB]; RSS also counts what the allocator keeps
};

struct LongRun {
  std::vector<LongRunSample> laps;  // after every lap (and after the last frame)
  int tracked = 0;
  double track_ms_total = 0.0;      // [ms] sum of Track() wall times
  OrbBackendStats stats;
};

inline double HeapInUseMb() {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  const struct mallinfo2 info = mallinfo2();
  return (info.uordblks + info.hblkhd) / 1048576.0;
#else
  return 0.0;
#endif
}

inline double ResidentMb() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * static_cast<double>(sysconf(_SC_PAGESIZE)) / 1048576.0;
}

// `frames` frames of the repeated lap through a tracker with `options`.
inline LongRun TrackRepeatedLoop(int frames, const OrbTrackerOptions& options) {
  SynthOptions so;
  so.width = 320;
  so.height = 240;
  so.fps = kLongRunFps;
  so.frames = kLongRunLapFrames;
  so.num_walkers = 0;
  so.seed = 5;
  so.motion = SynthMotion::kLoop;
  const SyntheticScene scene(so);
  std::vector<cv::Mat> rgb, depth;
  double t0 = 0.0;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const SynthFrame f = scene.Render(i);
    if (i == 0) t0 = f.timestamp;
    rgb.push_back(CvView(f.rgb).clone());
    depth.push_back(CvView(f.depth).clone());
  }
  OrbTracker tracker(scene.camera(), options);
  LongRun run;
  auto sample = [&](int frame) {
    LongRunSample s;
    s.frame = frame;
    s.live_keyframes = tracker.num_live_keyframes();
    s.keyframes = tracker.num_keyframes();
    s.live_points = tracker.num_map_points();
    s.point_slots = tracker.num_map_point_slots();
    s.loops = tracker.backend_stats().loops.size();
    s.culled_keyframes = tracker.backend_stats().culled_keyframes;
    s.rss_mb = ResidentMb();
    s.heap_mb = HeapInUseMb();
    run.laps.push_back(s);
  };
  for (int i = 0; i < frames; ++i) {
    TrackerFrame frame;
    frame.timestamp = t0 + i / kLongRunFps;
    frame.image = rgb[i % kLongRunLapFrames];
    frame.depth = depth[i % kLongRunLapFrames];
    const TrackResult r = tracker.Track(frame);
    run.tracked += IsTracked(r.status);
    run.track_ms_total += r.timing.total_ms;
    if ((i + 1) % kLongRunLapFrames == 0 || i + 1 == frames) sample(i + 1);
  }
  tracker.FlushBackend();
  run.stats = tracker.backend_stats();
  return run;
}

inline void PrintLongRun(const LongRun& run) {
  std::printf("frame  live kf  kf made  culled  live points  point slots  loops  RSS MiB  heap MiB\n");
  for (const LongRunSample& s : run.laps)
    std::printf("%5d  %7d  %7d  %6d  %11d  %11ld  %5zu  %7.1f  %8.1f\n", s.frame, s.live_keyframes, s.keyframes,
                s.culled_keyframes, s.live_points, s.point_slots, s.loops, s.rss_mb, s.heap_mb);
}

}  // namespace dypho::testing
