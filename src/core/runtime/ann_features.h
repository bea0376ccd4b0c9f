// The ANN-2D baseline's input: an event frame of one window, computed from the window's binary
// spikes (events/binning.h: one spike per pixel, polarity and step), 4 channels of [H, W]:
//   0, 1: log(1 + n) for OFF, ON, n = the steps of the window with a spike at the pixel
//   2, 3: the mean time of those spikes for OFF, ON, as (t + 1/2) / T in (0, 1); 0 without any
// Counts say where and how much, the mean times say which way an edge moved during the window
// (the timestamp images of EV-IMO and EVDodgeNet); both are bounded for any window length.
// The trainer and the evaluation call this one function, so the features cannot drift apart.
#pragma once

#include <cstdint>
#include <vector>

namespace spikems {

inline constexpr int kAnnFeatureChannels = 4;

// spikes: [T, 2, H, W] (values 0/1); returns [4, H, W]. Throws Error when T, H or W < 1.
std::vector<float> ann_features(const uint8_t* spikes, int T, int H, int W);

}  // namespace spikems
