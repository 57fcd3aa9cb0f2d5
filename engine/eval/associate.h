// Timestamp association as in the TUM RGB-D benchmark's associate.py
// (Sturm et al., IROS 2012, https://cvg.cit.tum.de/data/datasets/rgbd-dataset/tools):
// every pair (a, b) with |a - (b + offset)| < max_difference is a candidate;
// candidates are taken greedily by increasing time difference, each element
// of either list used at most once. Used for RGB-depth pairing in the dataset
// readers and for matching estimated to ground-truth poses in the ATE.
#pragma once

#include <cstddef>
#include <vector>

namespace dypho {

struct TimestampMatch {
  size_t first = 0;   // index into the first list
  size_t second = 0;  // index into the second list
};

// Greedy one-to-one association of two timestamp lists [s] (each sorted
// ascending). Ties in the time difference are broken by the smaller first
// timestamp, then the smaller second one (the order of Python's tuple sort).
// The result is sorted by `first`. The difference must be strictly below
// `max_difference` [s]; `offset` [s] is added to the second list's stamps.
std::vector<TimestampMatch> AssociateTimestamps(const std::vector<double>& first,
                                                const std::vector<double>& second, double max_difference,
                                                double offset = 0.0);

// Index of the element of `sorted` closest to `t`, found by the same binary
// search as the TUM tools' find_closest_index (so ties resolve as they do
// there). `sorted` must be non-empty and ascending.
size_t FindClosestIndex(const std::vector<double>& sorted, double t);

}  // namespace dypho
