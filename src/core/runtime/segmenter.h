// The streaming segmentation pipeline: time-ordered event chunks in, per-event labels and
// mask frames out, in bounded memory whatever the stream's length.
//
// Binning (the paper's input representation): step k covers [origin + k*step,
// origin + (k+1)*step), origin = the first event's time; all events of one polarity at one pixel
// within a step are one input spike (channel = polarity, 0 OFF, 1 ON). Each completed step
// advances the network once; silent stretches advance it with empty steps (cheap: idle neurons
// are never touched).
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <vector>

#include "core/events/event_stream.h"
#include "core/model/model_file.h"
#include "core/runtime/event_labeller.h"
#include "core/runtime/mask_accumulator.h"
#include "core/runtime/streaming_network.h"

namespace spikems {

struct SegmenterOptions {
  int label_tolerance_steps = 3;  // label window = latency (layers) + this
  int64_t mask_window_us = 0;     // 0: no mask frames
  int threads = 1;                // threads inside the network (StreamingNetwork::set_threads)
  // Steps the network takes layer by layer in one go (StreamingNetwork::step_block): faster
  // (each layer's state stays in the cache), but a step's output comes up to block_steps - 1
  // steps later (with threads, as many blocks more as layers: the layers then work on different
  // blocks at once). 1 for the lowest latency (live streams).
  int block_steps = 1;
  // Run every neuron of the model's fitted size, padding included (StreamingNetwork's `whole`):
  // the labels are the same; energy counts the network's SynOps as the LibTorch network does.
  bool whole_network = false;
  // The network sees the events at 1/downsample of the sensor's resolution, pixel (x / f, y / f)
  // (1, 2, 4 or 8), as a model trained on `spikems convert --downsample f` data expects; the
  // labels still go to the original events. Mask frames are then at the network's resolution
  // (PredictionFrame::scale). Callers choose it with resolve_downsample (model_scale.h).
  int downsample = 1;
};

// The block a file is run in when the user does not choose one: about 40 ms of steps on one
// thread, 20 ms with threads (the layers' pipeline holds a block per layer, so its latency and
// its filling cost grow with the block), 1 to 16 steps. Measured on a held-out room of 1 M
// ev/s (docs/performance.md, "Threads and blocks of steps"): at 10 ms steps blocks of 4 run as fast
// as 16 on one thread, and with two threads blocks of 2 run 1.7x faster than 16; at 2 ms steps 10
// is a little faster than 16 with two threads.
int default_block_steps(double step_ms, int threads);

class Segmenter {
 public:
  // Throws Error when the model does not fit the sensor (size fixed by the model, a network
  // too deep for the sensor, unsupported layer features).
  Segmenter(const ModelSpec& model, SensorSize sensor, SegmenterOptions opt,
            std::string source = "input");
  // A chunk of events in time order (continuing the previous chunks). Throws Error, naming the
  // event's index in the whole stream, for an event outside the sensor, a bad polarity, or a
  // timestamp earlier than the previous one.
  void push(const EventStream& chunk);
  // End of stream: completes the last step, runs the label window out, closes the last frame.
  void finish();

  // Labelled events decided so far (take and clear them as you go), input order.
  EventStream& labelled() { return labelled_; }
  std::vector<PredictionFrame>& frames() { return frames_; }

  const StreamingNetwork& network() const { return net_; }
  uint64_t events_in() const { return events_in_; }
  int64_t steps() const { return net_.steps_done(); }
  int64_t step_us() const { return step_us_; }
  int label_window_steps() const { return labeller_.window_steps(); }
  int downsample() const { return 1 << ds_shift_; }  // the factor the network sees the sensor at
  uint64_t foreground_events() const { return labeller_.foreground_count(); }
  double network_seconds() const { return net_seconds_; }  // wall time inside the network

 private:
  void end_step();             // the current step's input is complete: queues it for the network
  void run_block();            // the queued steps into the network
  void deliver(size_t ready);  // the next `ready` steps' outputs to the labeller and masks
  std::string source_;
  SensorSize sensor_;
  int ds_shift_;           // log2(opt.downsample)
  SensorSize net_sensor_;  // the sensor as the network sees it (downsampled)
  int64_t step_us_;
  SegmenterOptions opt_;
  StreamingNetwork net_;
  EventLabeller labeller_;
  std::optional<MaskAccumulator> masks_;
  bool started_ = false, finished_ = false;
  int64_t origin_ = 0, last_t_ = 0, cur_step_ = 0;
  uint64_t events_in_ = 0;
  // The queued steps' input spikes, ascending, in one of two sets: with threads, the network
  // runs the other set's block meanwhile (StreamingNetwork::start_block).
  std::vector<std::vector<uint32_t>> inputs_[2];
  int set_ = 0;
  size_t queued_ = 0;     // steps queued in inputs_[set_]
  int64_t out_step_ = 0;  // the next step whose output comes
  // Mask frames: the events (pixel index) of the steps whose output has not come yet, and how
  // many each step has (the current step's are counted in step_events_).
  std::deque<uint32_t> mask_events_;
  std::deque<uint32_t> mask_counts_;
  uint32_t step_events_ = 0;
  std::vector<uint64_t> input_bits_;   // this step's input neurons, one bit each
  std::vector<uint64_t> input_words_;  // one bit per input_bits_ word that is not zero
  size_t input_count_ = 0;             // bits set in input_bits_
  EventStream labelled_;
  std::vector<PredictionFrame> frames_;
  double net_seconds_ = 0;
};

}  // namespace spikems
