// The SpikeMS spatio-temporal loss, L_total = L_bce + lambda * L_spike (docs/model.md).
//
// Shapes: out, input: [T, B, C, H, W] spikes (values 1/Ts) on the same pixel grid (align the
// network output first with align_to_input); fg_mask: [B, H, W] (one mask per window) or
// [T, B, H, W] (per time bin), 1 = independently moving object, 0 = background.
//
// L_bce: P(x) = Ts * sum_{t,c} out = the output spike count at pixel x, mapped to a probability
//   Sigmoid:     p = sigmoid(alpha (P - beta))          (default alpha 2, beta 1)
//   Exponential: p = 1 - exp(-P / kappa)                 (log p floored at log(floor))
// label y(x) = 1 where the pixel had at least one foreground input event, 0 where its events
// were all background; binary cross-entropy averaged over the pixels with input events (the
// paper), or over all pixels (`all_pixels`: a spike where no event fell is a false positive
// of the IoU too), foreground terms weighted by `pos_weight`; or class-balanced (`balanced`).
// L_spike (van Rossum): f = eps * out, g = eps * target, target = input * fg_mask, both with
// the spike-response kernel eps (psp, scale Ts); L = (Ts / tau) * sum_{t,c,x} (f - g)^2 / (B H W)
// (a sum over time and channels, a mean over samples and pixels). Channels are compared one to
// one; a 1-channel output is compared with the target summed over channels.
#pragma once

#include <torch/torch.h>

#include <string>
#include <vector>

#include "train/neuron/temporal_kernel.h"

namespace spikems::train {

struct LossOptions {
  enum class Projection { Sigmoid, Exponential };
  Projection projection = Projection::Sigmoid;
  double alpha = 2.0, beta = 1.0;    // Sigmoid
  double kappa = 1.0, floor = 1e-4;  // Exponential
  double lambda = 1.0;               // weight of L_spike
  bool all_pixels = false;           // L_bce over every pixel, not only those with events
  double pos_weight = 1.0;           // weight of the foreground terms of L_bce
  // Class-balanced L_bce: the mean over foreground pixels plus the mean over background pixels
  // (each half weighted 1/2), so rare moving objects weigh as much as the background.
  bool balanced = false;
  // Predictions count only where input events fell (eval --gate-events): the soft IoU's p is
  // taken at pixels with input events only (L_bce with all_pixels = false already is).
  bool gate_events = false;
  // The potential readout (model.readout = "potential", docs/training.md): `out` is then the
  // output layer's synaptic potential u [T, B, C, H, W], not spikes, and P(x) = max_{t,c}
  // u / readout_theta; p = sigmoid(alpha (P - 1)), so p > 1/2 exactly where the runtime, whose
  // output layer then spikes at every step with u >= theta (no refractory), labels events
  // moving. Sigmoid projection only; L_spike does not apply.
  bool potential_readout = false;
  double readout_theta = 1.0;
  double ts = 1.0;   // time step (ms)
  double tau = 2.0;  // van Rossum kernel time constant (ms)
  TemporalKernel kernel = TemporalKernel::alpha(2.0, 1.0, 1.0);  // eps for L_spike
};

struct LossTerms {
  torch::Tensor bce, spike, total;
};

// P(x): [B, H, W] output spike counts.
torch::Tensor spike_projection(const torch::Tensor& out, double ts);
// P(x) of the loss's output: spike_projection, or with potential_readout max_{t,c} u / theta.
torch::Tensor output_projection(const torch::Tensor& out, const LossOptions& o);
// The probability p(P) of the chosen projection (for evaluation and plots).
torch::Tensor projection_probability(const torch::Tensor& counts, const LossOptions& o);
torch::Tensor bce_loss(const torch::Tensor& out, const torch::Tensor& input,
                       const torch::Tensor& fg_mask, const LossOptions& o);
// Off-event false positives (beyond the paper): the plain IoU counts every output spike at a
// pixel where no input event fell as a false positive (G holds event pixels only), while the
// balanced L_bce weighs such a pixel 1/(2 n_bg), ~100 k background pixels sharing one half,
// so a decoder that spreads its answer a pixel or two around the events it labels pays almost
// nothing for it. This term weighs each such pixel as L_bce weighs a moving one:
// L = 1/2 sum over pixels without input events whose logit z = alpha (P - c) > -2 (within
// reach of the threshold; c = 1 for the potential readout, beta for spike counts) of
// softplus(z), divided by the number of moving pixels of the batch (at least 1). Silent
// pixels far below the threshold add nothing, so it does not push the whole map to silence.
// Sigmoid projection only.
torch::Tensor offevent_loss(const torch::Tensor& out, const torch::Tensor& input,
                            const torch::Tensor& fg_mask, const LossOptions& o);
torch::Tensor van_rossum_loss(const torch::Tensor& out, const torch::Tensor& target,
                              const LossOptions& o);
// Soft IoU (Jaccard), beyond the paper: the evaluation's metric made differentiable, immune to
// the class imbalance that makes plain L_bce fall silent. Per sample, p = 1 - exp(-P / kappa)
// (0 where the output is silent, at every pixel: a spike where no event fell is a false
// positive of the IoU too), y as in L_bce; L = mean over the samples with moving objects of
// 1 - (sum p y + 1) / (sum (p + y - p y) + 1); 0 when no sample has any. Samples without
// moving objects are left out, as the metric skips such windows (counted in, they made silence
// the cheapest answer: measured); L_bce or the sparsity term handle their false positives.
torch::Tensor soft_iou_loss(const torch::Tensor& out, const torch::Tensor& input,
                            const torch::Tensor& fg_mask, const LossOptions& o);
// Distillation from a teacher (beyond the paper): teacher_prob [B, H, W] is another model's
// probability that the pixel's events are moving (the ANN-2D's sigmoid of its logit); the
// student's p = projection_probability(P) is pulled to it by the binary cross-entropy
// -(q log p + (1 - q) log(1 - p)) averaged over the pixels with input events (where the
// teacher's answer means something). Unlike the mask it says at every ego-motion event how
// sure a net that discriminates is that it is background. Computed from the logit (exact at
// any potential) for the sigmoid projections; the exponential one clamps p to [1e-6, 1 - 1e-6].
// sample_weight [B] (optional): a weight per sample of its pixels in the mean (0 leaves a
// sample out; loss.teacher_static = "skip").
torch::Tensor distill_loss(const torch::Tensor& out, const torch::Tensor& input,
                           const torch::Tensor& teacher_prob, const LossOptions& o,
                           const torch::Tensor& sample_weight = {});
// loss.teacher_static for the samples whose window [T, B, C, H, W] has no moving event
// (fg_mask as in bce_loss): "teacher" keeps the teacher's q; "labels" sets their q to 0 (their
// labels); "skip" keeps q and returns sample weights [B] of 0 for them, 1 for the others (for
// distill_loss). Other modes throw.
struct DistillTargets {
  torch::Tensor q;              // [B, H, W]
  torch::Tensor sample_weight;  // [B], or undefined: every sample counts
};
DistillTargets static_distill_targets(const torch::Tensor& teacher_prob, const torch::Tensor& input,
                                      const torch::Tensor& fg_mask, const std::string& mode);
// The distillation's floor: the teacher's own mean binary entropy -(q log q + (1 - q) log(1 - q))
// (0 log 0 = 0) over the pixels with input events: distill_loss of a student that matched it.
torch::Tensor teacher_entropy(const torch::Tensor& input, const torch::Tensor& teacher_prob);
// The distillation's ceiling for a student that ignores its input: the binary entropy of the
// teacher's mean q over the pixels with input events, distill_loss of the constant p = mean q
// (the best constant). A student between this and teacher_entropy has learnt part of the
// teacher's judgement; at it, none.
torch::Tensor teacher_mean_entropy(const torch::Tensor& input, const torch::Tensor& teacher_prob);
// Attention transfer (Zagoruyko & Komodakis, ICLR 2017), beyond the paper: where each hidden
// layer of the student is active, matched to where the teacher's layer of the same geometry is.
// A layer's map is the per-pixel mean over channels of the squared activation, flattened and
// scaled to unit L2 norm per sample, so channel counts and activation scales may differ
// (spike rates against ReLU outputs). Per layer: the squared distance of the two maps, mean
// over samples; the loss is the mean over the pairs. student[k], teacher[k]: [B, C, h, w];
// sizes may differ by the padding (both are cut to the common top-left part). It gives the
// coarse levels, whose weights get ~10^4 times smaller gradients than the output layer's
// (docs/training.md), a signal of their own.
torch::Tensor attention_map(const torch::Tensor& activation);  // [B, C, h, w] -> [B, h * w]
torch::Tensor attention_transfer_loss(const std::vector<torch::Tensor>& student,
                                      const std::vector<torch::Tensor>& teacher);
// Feature transfer (FitNets' hints, Romero et al., ICLR 2015, made scale-free as attention
// transfer is), beyond the paper: each hidden layer's activity matched channel by channel to the
// teacher's layer of the same index, not only where it is active. A layer's activity [B, C, h, w]
// is flattened per sample and scaled to unit L2 norm (rates against ReLU outputs: the scales
// differ, the pattern must not); per layer the squared distance of the two, mean over samples;
// the loss is the mean over the pairs, in [0, 2] for non-negative activities. The channel counts
// must match (the same model.channels); sizes may differ by the padding (cut to the common
// top-left part). Why: attention maps say where a layer is busy, not what it computes there; the
// teacher's channels carry the context that tells object from camera motion, and a per-layer
// target gives every layer a gradient that does not cross the whole spiking stack.
torch::Tensor feature_transfer_loss(const std::vector<torch::Tensor>& student,
                                    const std::vector<torch::Tensor>& teacher);
// target = input masked by the foreground mask, [T, B, C, H, W].
torch::Tensor foreground_target(const torch::Tensor& input, const torch::Tensor& fg_mask);
LossTerms spikems_loss(const torch::Tensor& out, const torch::Tensor& input,
                       const torch::Tensor& fg_mask, const LossOptions& o);

}  // namespace spikems::train
