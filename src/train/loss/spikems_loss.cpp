#include "train/loss/spikems_loss.h"

#include <algorithm>

#include "train/neuron/psp.h"

namespace spikems::train {

namespace {
// fg_mask as [T or 1, B, 1, H, W].
torch::Tensor mask5(const torch::Tensor& m) {
  TORCH_CHECK(m.dim() == 3 || m.dim() == 4, "loss: fg_mask must be [B, H, W] or [T, B, H, W]");
  return m.dim() == 3 ? m.unsqueeze(0).unsqueeze(2) : m.unsqueeze(2);
}
// 1 at the pixels [B, H, W] where input [T, B, C, H, W] has any event, else 0 (no gradient).
torch::Tensor event_pixels(const torch::Tensor& input, torch::Dtype dtype) {
  return (input.detach().sum(std::vector<int64_t>{0, 2}) > 0).to(dtype);
}
// 1 at the pixels [B, H, W] with a moving input event (L_bce's y), else 0 (no gradient).
torch::Tensor moving_pixels(const torch::Tensor& input, const torch::Tensor& fg_mask,
                            torch::Dtype dtype) {
  return (foreground_target(input.detach(), fg_mask).sum(std::vector<int64_t>{0, 2}) > 0).to(dtype);
}
// The mean of a per-pixel value [B, H, W] over the pixels where input [T, B, C, H, W] has events.
torch::Tensor mean_over_event_pixels(const torch::Tensor& v, const torch::Tensor& input) {
  const torch::Tensor had = event_pixels(input, v.scalar_type());
  return (v * had).sum() / torch::clamp_min(had.sum(), 1.0);
}
}  // namespace

torch::Tensor spike_projection(const torch::Tensor& out, double ts) {
  TORCH_CHECK(out.dim() == 5, "loss: spikes must be [T, B, C, H, W]");
  return out.sum(std::vector<int64_t>{0, 2}) * ts;
}

torch::Tensor output_projection(const torch::Tensor& out, const LossOptions& o) {
  if (!o.potential_readout) return spike_projection(out, o.ts);
  TORCH_CHECK(out.dim() == 5, "loss: the readout potential must be [T, B, C, H, W]");
  TORCH_CHECK(o.projection == LossOptions::Projection::Sigmoid,
              "loss: the potential readout needs the sigmoid projection");
  return out.amax(std::vector<int64_t>{0, 2}) / o.readout_theta;
}

torch::Tensor projection_probability(const torch::Tensor& P, const LossOptions& o) {
  if (o.potential_readout) return torch::sigmoid(o.alpha * (P - 1.0));
  if (o.projection == LossOptions::Projection::Sigmoid)
    return torch::sigmoid(o.alpha * (P - o.beta));
  return 1 - torch::exp(-P / o.kappa);
}

torch::Tensor foreground_target(const torch::Tensor& input, const torch::Tensor& fg_mask) {
  return input * mask5(fg_mask).to(input.dtype());
}

torch::Tensor bce_loss(const torch::Tensor& out, const torch::Tensor& input,
                       const torch::Tensor& fg_mask, const LossOptions& o) {
  TORCH_CHECK(
      out.size(1) == input.size(1) && out.size(3) == input.size(3) && out.size(4) == input.size(4),
      "loss: output and input must share batch and pixel grid (use align_to_input)");
  torch::Tensor P = output_projection(out, o);  // [B, H, W]
  torch::Tensor had = event_pixels(input, out.scalar_type());
  torch::Tensor fg = moving_pixels(input, fg_mask, out.scalar_type());
  torch::Tensor l;
  if (o.projection == LossOptions::Projection::Sigmoid) {
    torch::Tensor z = o.alpha * (P - (o.potential_readout ? 1.0 : o.beta));
    // -[y log s(z) + (1-y) log(1-s(z))] = y softplus(-z) + (1-y) softplus(z)
    l = o.pos_weight * fg * torch::softplus(-z) + (1 - fg) * torch::softplus(z);
  } else {
    torch::Tensor z = P / o.kappa;
    torch::Tensor logp = torch::log(torch::clamp_min(-torch::expm1(-z), o.floor));
    l = -(o.pos_weight * fg * logp) + (1 - fg) * z;  // log(1 - p) = -P/kappa exactly
  }
  if (o.all_pixels) had = torch::ones_like(had);
  if (o.balanced) {
    torch::Tensor bg = had * (1 - fg);
    torch::Tensor lf = (l * fg).sum() / torch::clamp_min(fg.sum(), 1.0);
    torch::Tensor lb = (l * bg).sum() / torch::clamp_min(bg.sum(), 1.0);
    return 0.5 * (lf + lb);
  }
  torch::Tensor n = had.sum();
  return (l * had).sum() / torch::clamp_min(n, 1.0);
}

torch::Tensor offevent_loss(const torch::Tensor& out, const torch::Tensor& input,
                            const torch::Tensor& fg_mask, const LossOptions& o) {
  TORCH_CHECK(
      out.size(1) == input.size(1) && out.size(3) == input.size(3) && out.size(4) == input.size(4),
      "loss: output and input must share batch and pixel grid (use align_to_input)");
  TORCH_CHECK(o.projection == LossOptions::Projection::Sigmoid,
              "loss: the off-event term needs the sigmoid projection");
  const torch::Tensor z =
      o.alpha * (output_projection(out, o) - (o.potential_readout ? 1.0 : o.beta));  // [B, H, W]
  const torch::Tensor off = 1 - event_pixels(input, out.scalar_type());
  const torch::Tensor n_fg = moving_pixels(input, fg_mask, out.scalar_type()).sum();
  const torch::Tensor near = (z.detach() > -2.0).to(out.dtype());
  return 0.5 * (torch::softplus(z) * off * near).sum() / torch::clamp_min(n_fg, 1.0);
}

torch::Tensor soft_iou_loss(const torch::Tensor& out, const torch::Tensor& input,
                            const torch::Tensor& fg_mask, const LossOptions& o) {
  TORCH_CHECK(
      out.size(1) == input.size(1) && out.size(3) == input.size(3) && out.size(4) == input.size(4),
      "loss: output and input must share batch and pixel grid (use align_to_input)");
  torch::Tensor p = o.potential_readout ? projection_probability(output_projection(out, o), o)
                                        : -torch::expm1(-spike_projection(out, o.ts) / o.kappa);
  if (o.gate_events) p = p * event_pixels(input, out.scalar_type());
  torch::Tensor y = moving_pixels(input, fg_mask, out.scalar_type());
  const std::vector<int64_t> px{1, 2};
  torch::Tensor inter = (p * y).sum(px), uni = (p + y - p * y).sum(px);
  // Only samples with moving objects, as the metric skips windows without them: counted with
  // the others, a crop of background alone made silence the cheapest answer (measured).
  torch::Tensor has = (y.sum(px) > 0).to(out.dtype());
  return ((1 - (inter + 1) / (uni + 1)) * has).sum() / torch::clamp_min(has.sum(), 1.0);
}

torch::Tensor distill_loss(const torch::Tensor& out, const torch::Tensor& input,
                           const torch::Tensor& teacher_prob, const LossOptions& o,
                           const torch::Tensor& sample_weight) {
  TORCH_CHECK(
      out.size(1) == input.size(1) && out.size(3) == input.size(3) && out.size(4) == input.size(4),
      "loss: output and input must share batch and pixel grid (use align_to_input)");
  TORCH_CHECK(teacher_prob.dim() == 3 && teacher_prob.size(0) == out.size(1) &&
                  teacher_prob.size(1) == out.size(3) && teacher_prob.size(2) == out.size(4),
              "distillation: the teacher's probabilities must be [B, H, W] on the output's grid");
  TORCH_CHECK(!sample_weight.defined() ||
                  (sample_weight.dim() == 1 && sample_weight.size(0) == out.size(1)),
              "distillation: the sample weights must be [B]");
  const torch::Tensor P = output_projection(out, o);
  // The mean over event pixels, each sample's pixels weighted by its sample weight.
  const auto mean = [&](const torch::Tensor& v) {
    if (!sample_weight.defined()) return mean_over_event_pixels(v, input);
    const torch::Tensor had = event_pixels(input, v.scalar_type()) *
                              sample_weight.detach().to(v.dtype()).view({-1, 1, 1});
    return (v * had).sum() / torch::clamp_min(had.sum(), 1.0);
  };
  const torch::Tensor q = teacher_prob.detach().to(P.dtype());
  if (o.potential_readout || o.projection == LossOptions::Projection::Sigmoid) {
    // From the logit z: -(q log s(z) + (1-q) log(1-s(z))) = q softplus(-z) + (1-q) softplus(z),
    // exact at any z, so a pixel far on the wrong side keeps its gradient (a clamped p had none:
    // with a steep alpha the potential readout saturates p within float precision).
    const torch::Tensor z = o.alpha * (P - (o.potential_readout ? 1.0 : o.beta));
    return mean(q * torch::softplus(-z) + (1 - q) * torch::softplus(z));
  }
  const torch::Tensor p = torch::clamp(projection_probability(P, o), 1e-6, 1 - 1e-6);
  const torch::Tensor bce = -(q * torch::log(p) + (1 - q) * torch::log1p(-p));
  return mean(bce);
}

DistillTargets static_distill_targets(const torch::Tensor& teacher_prob, const torch::Tensor& input,
                                      const torch::Tensor& fg_mask, const std::string& mode) {
  if (mode == "teacher") return {teacher_prob, {}};
  TORCH_CHECK(mode == "labels" || mode == "skip",
              "loss.teacher_static must be teacher, labels or skip, not ", mode);
  const torch::Tensor moving =
      (foreground_target(input.detach(), fg_mask).sum(std::vector<int64_t>{0, 2, 3, 4}) > 0)
          .to(teacher_prob.scalar_type());
  if (mode == "labels") return {teacher_prob * moving.view({-1, 1, 1}), {}};
  return {teacher_prob, moving};
}

torch::Tensor teacher_entropy(const torch::Tensor& input, const torch::Tensor& teacher_prob) {
  torch::NoGradGuard ng;
  const torch::Tensor q = teacher_prob.detach();
  return mean_over_event_pixels(-(torch::xlogy(q, q) + torch::xlogy(1 - q, 1 - q)), input);
}

torch::Tensor teacher_mean_entropy(const torch::Tensor& input, const torch::Tensor& teacher_prob) {
  torch::NoGradGuard ng;
  const torch::Tensor m = mean_over_event_pixels(teacher_prob.detach(), input);
  return -(torch::xlogy(m, m) + torch::xlogy(1 - m, 1 - m));
}

namespace {

// Per sample, a flattened map scaled to unit L2 norm; the eps keeps a silent layer's map at
// zero with a finite gradient.
torch::Tensor unit_rows(const torch::Tensor& m) {
  return m / (m.norm(2, 1, true) + 1e-8);
}

}  // namespace

torch::Tensor attention_map(const torch::Tensor& activation) {
  TORCH_CHECK(activation.dim() == 4, "attention map: activation must be [B, C, h, w]");
  return unit_rows(activation.pow(2).mean(1).flatten(1));
}

namespace {

// The mean over layer pairs of the mean over samples of |map(s) - map(t)|^2, both cut to their
// common top-left part (the padding); the teacher is not trained. `channels`: the pairs must
// have the same channel counts.
template <class Map>
torch::Tensor paired_map_loss(const std::vector<torch::Tensor>& student,
                              const std::vector<torch::Tensor>& teacher, const char* name,
                              bool channels, Map map) {
  TORCH_CHECK(student.size() == teacher.size() && !student.empty(), name,
              ": needs one teacher layer per student layer");
  torch::Tensor total = torch::zeros({}, student[0].options());
  for (size_t k = 0; k < student.size(); ++k) {
    const torch::Tensor &s = student[k], &t = teacher[k];
    TORCH_CHECK(s.dim() == 4 && t.dim() == 4 && s.size(0) == t.size(0) &&
                    (!channels || s.size(1) == t.size(1)),
                name, ": layer ", k, " shapes ", s.sizes(), " and ", t.sizes(),
                channels ? " (the channel counts must match)" : "");
    const int64_t h = std::min(s.size(2), t.size(2)), w = std::min(s.size(3), t.size(3));
    const torch::Tensor ms = map(s.narrow(2, 0, h).narrow(3, 0, w));
    const torch::Tensor mt = map(t.detach().narrow(2, 0, h).narrow(3, 0, w));
    total = total + (ms - mt).pow(2).sum(1).mean();
  }
  return total / double(student.size());
}

}  // namespace

torch::Tensor attention_transfer_loss(const std::vector<torch::Tensor>& student,
                                      const std::vector<torch::Tensor>& teacher) {
  return paired_map_loss(student, teacher, "attention transfer", false, attention_map);
}

torch::Tensor feature_transfer_loss(const std::vector<torch::Tensor>& student,
                                    const std::vector<torch::Tensor>& teacher) {
  return paired_map_loss(student, teacher, "feature transfer", true,
                         [](const torch::Tensor& a) { return unit_rows(a.flatten(1)); });
}

torch::Tensor van_rossum_loss(const torch::Tensor& out, const torch::Tensor& target,
                              const LossOptions& o) {
  TORCH_CHECK(!o.potential_readout, "loss: L_spike compares spike trains, not a readout potential");
  torch::Tensor tgt = target;
  if (out.size(2) == 1 && target.size(2) != 1) tgt = target.sum(2, true);
  TORCH_CHECK(out.sizes() == tgt.sizes(), "van Rossum loss: output and target shapes differ");
  torch::Tensor f = psp(out, o.kernel, o.ts), g = psp(tgt.detach(), o.kernel, o.ts);
  const double pixels = double(out.size(1) * out.size(3) * out.size(4));
  return (f - g).pow(2).sum() * (o.ts / o.tau / pixels);
}

LossTerms spikems_loss(const torch::Tensor& out, const torch::Tensor& input,
                       const torch::Tensor& fg_mask, const LossOptions& o) {
  LossTerms t;
  t.bce = bce_loss(out, input, fg_mask, o);
  t.spike = van_rossum_loss(out, foreground_target(input, fg_mask), o);
  t.total = t.bce + o.lambda * t.spike;
  return t;
}

}  // namespace spikems::train
