// Synapse (conv / transposed conv over T*B frames), axonal delay, loss pieces and the network
// built from a ModelSpec: against explicit formulas and finite differences (double, small).
#include <gtest/gtest.h>

#include <cmath>

#include "train/axon/delay.h"
#include "train/loss/spikems_loss.h"
#include "train/network/spikems_network.h"
#include "train/synapse/conv.h"
#include "train_test_util.h"

namespace spikems::train {
namespace {

TEST(Synapse, ConvAndConvTransposeMatchTheReadmeFormulas) {
  torch::manual_seed(7);
  const int64_t T = 3, B = 2, Ci = 3, Co = 4, H = 7, W = 9;
  torch::Tensor a = torch::randn({T, B, Ci, H, W}, torch::kDouble);
  torch::Tensor wc = torch::randn({Co, Ci, 3, 3}, torch::kDouble);
  torch::Tensor u = synapse_forward(a, wc, {LayerKind::Conv, 2, 0, 0});
  ASSERT_EQ(u.sizes(), (std::vector<int64_t>{T, B, Co, 3, 4}));
  auto A = a.accessor<double, 5>();
  auto Wc = wc.accessor<double, 4>();
  double err = 0;
  for (int64_t t = 0; t < T; ++t)
    for (int64_t b = 0; b < B; ++b)
      for (int64_t co = 0; co < Co; ++co)
        for (int64_t y = 0; y < 3; ++y)
          for (int64_t x = 0; x < 4; ++x) {
            double s = 0;
            for (int64_t ci = 0; ci < Ci; ++ci)
              for (int ky = 0; ky < 3; ++ky)
                for (int kx = 0; kx < 3; ++kx)
                  s += Wc[co][ci][ky][kx] * A[t][b][ci][2 * y + ky][2 * x + kx];
            err = std::max(err, std::abs(s - u[t][b][co][y][x].item<double>()));
          }
  EXPECT_LT(err, 1e-12);
  // convT: u[co, Y, X] = sum over 2y+ky = Y, 2x+kx = X of Wt[ci, co, ky, kx] a[ci, y, x].
  torch::Tensor wt = torch::randn({Ci, Co, 3, 3}, torch::kDouble);
  torch::Tensor v = synapse_forward(a, wt, {LayerKind::ConvTranspose, 2, 0, 0});
  ASSERT_EQ(v.sizes(), (std::vector<int64_t>{T, B, Co, 2 * H + 1, 2 * W + 1}));
  torch::Tensor ref = torch::zeros_like(v);
  auto R = ref.accessor<double, 5>();
  auto Wt = wt.accessor<double, 4>();
  for (int64_t t = 0; t < T; ++t)
    for (int64_t b = 0; b < B; ++b)
      for (int64_t ci = 0; ci < Ci; ++ci)
        for (int64_t y = 0; y < H; ++y)
          for (int64_t x = 0; x < W; ++x)
            for (int64_t co = 0; co < Co; ++co)
              for (int ky = 0; ky < 3; ++ky)
                for (int kx = 0; kx < 3; ++kx)
                  R[t][b][co][2 * y + ky][2 * x + kx] += Wt[ci][co][ky][kx] * A[t][b][ci][y][x];
  EXPECT_LT((v - ref).abs().max().item<double>(), 1e-12);
  // Padded geometry: padding 1, output_padding 1 doubles the size.
  EXPECT_EQ(synapse_forward(a, wt, {LayerKind::ConvTranspose, 2, 1, 1}).size(3), 2 * H);
  EXPECT_EQ(synapse_forward(a, wc, {LayerKind::Conv, 2, 1, 0}).size(3), (H + 1) / 2);
}

TEST(Delay, ShiftsWithLinearInterpolationAndHasExactGradients) {
  torch::manual_seed(8);
  const int64_t T = 12, C = 3;
  torch::Tensor x = torch::randn({T, 2, C, 2, 2}, torch::kDouble);
  torch::Tensor d = torch::tensor({0.3, 1.25, 2.6}, torch::kDouble);
  torch::Tensor y = axonal_delay(x, d);
  for (int64_t c = 0; c < C; ++c) {
    double dc = d[c].item<double>();
    int64_t k = int64_t(std::floor(dc));
    double f = dc - k;
    for (int64_t t = 0; t < T; ++t) {
      torch::Tensor x0 = t - k >= 0 ? x[t - k].select(1, c) : torch::zeros_like(x[0].select(1, c));
      torch::Tensor x1 = t - k - 1 >= 0 ? x[t - k - 1].select(1, c) : torch::zeros_like(x0);
      EXPECT_LT((y[t].select(1, c) - ((1 - f) * x0 + f * x1)).abs().max().item<double>(), 1e-12);
    }
  }
  EXPECT_LT(spikems::test::finite_difference_error(
                [&](const torch::Tensor& v) { return axonal_delay(v, d); }, x),
            1e-7);
  EXPECT_LT(spikems::test::finite_difference_error(
                [&](const torch::Tensor& v) { return axonal_delay(x, v); }, d),
            1e-6);
}

// The distillation loss by hand (sigmoid projection of the spike count): the mean over the
// event pixels of the given samples of -(q log p + (1 - q) log(1 - p)); *pixels: how many.
double distill_by_hand(const torch::Tensor& out, const torch::Tensor& in, const torch::Tensor& q,
                       const LossOptions& o, std::initializer_list<int64_t> samples,
                       double* pixels = nullptr) {
  const torch::Tensor P = out.sum(std::vector<int64_t>{0, 2});
  double num = 0, den = 0;
  for (int64_t b : samples)
    for (int64_t y = 0; y < q.size(1); ++y)
      for (int64_t x = 0; x < q.size(2); ++x) {
        if (in.select(1, b).select(2, y).select(2, x).sum().item<double>() == 0) continue;
        const double p = 1 / (1 + std::exp(-o.alpha * (P[b][y][x].item<double>() - o.beta)));
        const double t = q[b][y][x].item<double>();
        num += -(t * std::log(p) + (1 - t) * std::log(1 - p));
        den += 1;
      }
  if (pixels) *pixels = den;
  return num / den;
}

// Distillation: the BCE between the student's projected probability and the teacher's, over
// the pixels with input events, by hand; its gradient by finite differences; zero where the
// student already agrees (d/dP = alpha (p - q) for the sigmoid projection).
TEST(Loss, DistillMatchesItsFormulaAndGradient) {
  torch::manual_seed(10);
  const int64_t T = 5, B = 2, C = 2, H = 3, W = 4;
  const torch::Tensor in = (torch::rand({T, B, C, H, W}, torch::kDouble) < 0.3).to(torch::kDouble);
  const torch::Tensor out = torch::rand({T, B, 1, H, W}, torch::kDouble);
  torch::Tensor q = torch::rand({B, H, W}, torch::kDouble);
  LossOptions o;
  o.alpha = 4;
  o.beta = 0.5;
  const torch::Tensor P = out.sum(std::vector<int64_t>{0, 2});
  double den = 0;
  const double by_hand = distill_by_hand(out, in, q, o, {0, 1}, &den);
  ASSERT_GT(den, 0);
  EXPECT_NEAR(distill_loss(out, in, q, o).item<double>(), by_hand, 1e-10);
  EXPECT_LT(spikems::test::finite_difference_error(
                [&](const torch::Tensor& v) { return distill_loss(v, in, q, o); }, out),
            1e-6);
  // The teacher agreeing with the student: no gradient anywhere, and the loss is the
  // teacher's own entropy (the floor the trainer logs).
  const torch::Tensor agree = projection_probability(P, o);
  torch::Tensor v = out.clone().requires_grad_(true);
  const torch::Tensor at_agreement = distill_loss(v, in, agree, o);
  at_agreement.backward();
  EXPECT_LT(v.grad().abs().max().item<double>(), 1e-12);
  EXPECT_NEAR(at_agreement.item<double>(), teacher_entropy(in, agree).item<double>(), 1e-10);
  // The entropy by hand, with 0 log 0 = 0 at a certain teacher.
  torch::Tensor sure = q.clone();
  sure[0][0][0] = 0.0;
  sure[1][2][3] = 1.0;
  double h = 0, n = 0;
  for (int64_t b = 0; b < B; ++b)
    for (int64_t y = 0; y < H; ++y)
      for (int64_t x = 0; x < W; ++x) {
        if (in.select(1, b).select(2, y).select(2, x).sum().item<double>() == 0) continue;
        const double t = sure[b][y][x].item<double>();
        h += (t > 0 ? -t * std::log(t) : 0) + (t < 1 ? -(1 - t) * std::log(1 - t) : 0);
        n += 1;
      }
  EXPECT_NEAR(teacher_entropy(in, sure).item<double>(), h / n, 1e-10);
  // The best constant student: p = the teacher's mean over the event pixels, by hand; its
  // distillation loss is that mean's entropy, and no other constant does better.
  double qm = 0;
  for (int64_t b = 0; b < B; ++b)
    for (int64_t y = 0; y < H; ++y)
      for (int64_t x = 0; x < W; ++x)
        if (in.select(1, b).select(2, y).select(2, x).sum().item<double>() > 0)
          qm += q[b][y][x].item<double>() / den;
  const double hm = -(qm * std::log(qm) + (1 - qm) * std::log(1 - qm));
  EXPECT_NEAR(teacher_mean_entropy(in, q).item<double>(), hm, 1e-10);
  LossOptions pot = o;
  pot.potential_readout = true;
  pot.readout_theta = 1;
  auto constant_student = [&](double p) {  // P with sigmoid(alpha (P - 1)) = p at every step
    const double P = 1 + std::log(p / (1 - p)) / pot.alpha;
    return distill_loss(torch::full({T, B, 1, H, W}, P, torch::kDouble), in, q, pot).item<double>();
  };
  EXPECT_NEAR(constant_student(qm), hm, 1e-9);
  EXPECT_GT(constant_student(qm + 0.05), hm);
  EXPECT_GT(constant_student(qm - 0.05), hm);
  EXPECT_THROW(distill_loss(out, in, q.narrow(2, 0, 2), o), std::exception);  // wrong grid
  // Far on the wrong side (alpha 40, P = 0 against a sure teacher: z = -20, p = 2e-9) the loss
  // is softplus(20) per pixel and its gradient alpha (p - q) ~ -alpha: not cut at a clamped p.
  LossOptions steep = o;
  steep.alpha = 40;
  const torch::Tensor in1 = torch::ones({1, 1, 1, 1, 1}, torch::kDouble);
  torch::Tensor silent = torch::zeros({1, 1, 1, 1, 1}, torch::kDouble).requires_grad_(true);
  const torch::Tensor l = distill_loss(silent, in1, torch::ones({1, 1, 1}, torch::kDouble), steep);
  l.backward();
  EXPECT_NEAR(l.item<double>(), 20 + std::log1p(std::exp(-20.0)), 1e-12);
  EXPECT_NEAR(silent.grad().item<double>(), -40 / (1 + std::exp(-20.0)), 1e-9);
}

// loss.teacher_static: which samples have a moving event is read from the labels of their
// window's events; "labels" zeroes the static samples' targets, "skip" weights them out of the
// mean (the loss then equals the moving samples' own, and the static ones get no gradient).
TEST(Loss, DistillOfStaticSamplesFollowsTeacherStatic) {
  torch::manual_seed(11);
  const int64_t T = 4, B = 3, C = 2, H = 3, W = 4;
  torch::Tensor in = (torch::rand({T, B, C, H, W}, torch::kDouble) < 0.4).to(torch::kDouble);
  in[0][0][0][0][0] = 1.0;  // every sample has events; sample 0 one at (0, 0) at t = 0
  in[1][2][1][2][3] = 1.0;  // sample 2 one at (2, 3) at t = 1
  torch::Tensor fg = torch::zeros({T, B, H, W}, torch::kDouble);
  fg[0][0][0][0] = 1.0;  // sample 0: the event at (0, 0) moves
  fg[1][2][2][3] = 1.0;  // sample 2: the event at (2, 3) moves
  fg[2][1][1][1] = 1.0;  // sample 1: a moving mask where no event fell: still static
  for (int64_t c = 0; c < C; ++c) in[2][1][c][1][1] = 0.0;
  const torch::Tensor q = torch::rand({B, H, W}, torch::kDouble);
  const DistillTargets keep = static_distill_targets(q, in, fg, "teacher");
  EXPECT_TRUE(keep.q.equal(q));
  EXPECT_FALSE(keep.sample_weight.defined());
  const DistillTargets lab = static_distill_targets(q, in, fg, "labels");
  EXPECT_TRUE(lab.q[0].equal(q[0]));
  EXPECT_TRUE(lab.q[2].equal(q[2]));
  EXPECT_EQ(lab.q[1].abs().sum().item<double>(), 0.0);
  EXPECT_FALSE(lab.sample_weight.defined());
  const DistillTargets skip = static_distill_targets(q, in, fg, "skip");
  EXPECT_TRUE(skip.q.equal(q));
  ASSERT_TRUE(skip.sample_weight.defined());
  EXPECT_EQ(skip.sample_weight[0].item<double>(), 1.0);
  EXPECT_EQ(skip.sample_weight[1].item<double>(), 0.0);
  EXPECT_EQ(skip.sample_weight[2].item<double>(), 1.0);
  EXPECT_THROW(static_distill_targets(q, in, fg, "none"), std::exception);

  LossOptions o;
  o.alpha = 4;
  o.beta = 0.5;
  torch::Tensor out = torch::rand({T, B, 1, H, W}, torch::kDouble).requires_grad_(true);
  // Skipping sample 1 is the loss of samples 0 and 2 alone, by hand: the mean over their event
  // pixels (not the mean of two per-sample means).
  const torch::Tensor l = distill_loss(out, in, skip.q, o, skip.sample_weight);
  EXPECT_NEAR(l.item<double>(), distill_by_hand(out.detach(), in, q, o, {0, 2}), 1e-10);
  l.backward();
  EXPECT_EQ(out.grad().select(1, 1).abs().max().item<double>(), 0.0);
  EXPECT_GT(out.grad().select(1, 0).abs().max().item<double>(), 0.0);
  // Weights of one are no weights; a weight per sample of the wrong length is refused.
  EXPECT_NEAR(distill_loss(out, in, q, o, torch::ones({B}, torch::kDouble)).item<double>(),
              distill_loss(out, in, q, o).item<double>(), 1e-12);
  EXPECT_THROW(distill_loss(out, in, q, o, torch::ones({B + 1}, torch::kDouble)), std::exception);
}

// Attention transfer: per layer, the squared distance of the unit-norm maps mean_c a^2, by hand;
// blind to channel counts and scales; exact gradients; the teacher's padding cut off.
TEST(Loss, AttentionTransferMatchesItsFormulaAndGradient) {
  // One active pixel each, different pixels: two orthogonal unit vectors, distance^2 = 2.
  torch::Tensor s = torch::zeros({1, 2, 1, 2}, torch::kDouble), t = s.clone();
  s[0][0][0][0] = 0.3;
  t[0][1][0][1] = 5.0;
  // (Tolerances of 1e-6: the norm's 1e-8 guard against a silent layer.)
  EXPECT_NEAR(attention_transfer_loss({s}, {t}).item<double>(), 2.0, 1e-6);
  // The same spatial pattern with other channel counts and scales: no loss.
  torch::manual_seed(11);
  const torch::Tensor pattern = torch::rand({2, 1, 3, 4}, torch::kDouble);
  const torch::Tensor s3 = pattern.repeat({1, 3, 1, 1}) * 0.1;
  const torch::Tensor t7 = pattern.repeat({1, 7, 1, 1}) * 40.0;
  EXPECT_LT(attention_transfer_loss({s3}, {t7}).item<double>(), 1e-12);
  // Random layers, by hand (two layers: the loss is their mean).
  const torch::Tensor a1 = torch::rand({2, 3, 3, 4}, torch::kDouble);
  const torch::Tensor b1 = torch::rand({2, 5, 3, 4}, torch::kDouble);
  const torch::Tensor a2 = torch::rand({2, 2, 2, 2}, torch::kDouble);
  const torch::Tensor b2 = torch::rand({2, 4, 2, 2}, torch::kDouble);
  auto by_hand = [](const torch::Tensor& a, const torch::Tensor& b) {
    double total = 0;
    const int64_t B = a.size(0), C1 = a.size(1), C2 = b.size(1), H = a.size(2), W = a.size(3);
    for (int64_t n = 0; n < B; ++n) {
      std::vector<double> ma, mb;
      double na = 0, nb = 0;
      for (int64_t y = 0; y < H; ++y)
        for (int64_t x = 0; x < W; ++x) {
          double va = 0, vb = 0;
          for (int64_t c = 0; c < C1; ++c) va += std::pow(a[n][c][y][x].item<double>(), 2) / C1;
          for (int64_t c = 0; c < C2; ++c) vb += std::pow(b[n][c][y][x].item<double>(), 2) / C2;
          ma.push_back(va);
          mb.push_back(vb);
          na += va * va;
          nb += vb * vb;
        }
      for (size_t i = 0; i < ma.size(); ++i)
        total += std::pow(ma[i] / std::sqrt(na) - mb[i] / std::sqrt(nb), 2);
    }
    return total / double(B);
  };
  EXPECT_NEAR(attention_transfer_loss({a1, a2}, {b1, b2}).item<double>(),
              (by_hand(a1, b1) + by_hand(a2, b2)) / 2, 1e-6);
  EXPECT_LT(spikems::test::finite_difference_error(
                [&](const torch::Tensor& v) { return attention_transfer_loss({v}, {b1}); }, a1),
            1e-6);
  // A teacher one row and two columns larger (its padding): the extra part is ignored.
  torch::Tensor padded = torch::rand({2, 5, 4, 6}, torch::kDouble) * 100;
  padded.narrow(2, 0, 3).narrow(3, 0, 4).copy_(b1);
  EXPECT_NEAR(attention_transfer_loss({a1}, {padded}).item<double>(),
              attention_transfer_loss({a1}, {b1}).item<double>(), 1e-12);
  // A silent student: the loss is 1 (0 against a unit vector) and the gradient finite.
  torch::Tensor silent = torch::zeros({2, 3, 3, 4}, torch::kDouble).requires_grad_(true);
  const torch::Tensor l = attention_transfer_loss({silent}, {b1});
  l.backward();
  EXPECT_NEAR(l.item<double>(), 1.0, 1e-6);
  EXPECT_TRUE(torch::isfinite(silent.grad()).all().item<bool>());
  // Mismatched lists or samples are refused.
  EXPECT_THROW(attention_transfer_loss({a1, a2}, {b1}), std::exception);
  EXPECT_THROW(attention_transfer_loss({a1}, {b1.narrow(0, 0, 1)}), std::exception);
}

// Feature transfer: per layer, the squared distance of the unit-norm flattened activities, the
// mean over samples and layers; channel by channel, so the same spatial pattern in other channels
// is a miss where attention transfer would see none.
TEST(Loss, FeatureTransferMatchesItsFormulaAndGradient) {
  torch::manual_seed(13);
  // A scaled copy: no loss (the scales of rates and ReLU outputs may differ).
  const torch::Tensor a1 = torch::rand({2, 3, 3, 4}, torch::kDouble);
  EXPECT_LT(feature_transfer_loss({a1 * 0.05}, {a1 * 30.0}).item<double>(), 1e-12);
  // One active unit each, the same pixel, other channels: orthogonal, distance^2 = 2 (attention
  // transfer calls these the same).
  torch::Tensor s = torch::zeros({1, 2, 1, 2}, torch::kDouble), t = s.clone();
  s[0][0][0][1] = 0.3;
  t[0][1][0][1] = 5.0;
  EXPECT_NEAR(feature_transfer_loss({s}, {t}).item<double>(), 2.0, 1e-6);
  EXPECT_LT(attention_transfer_loss({s}, {t}).item<double>(), 1e-6);
  // Random layers, by hand (two layers: the loss is their mean).
  const torch::Tensor b1 = torch::rand({2, 3, 3, 4}, torch::kDouble);
  const torch::Tensor a2 = torch::rand({2, 4, 2, 2}, torch::kDouble);
  const torch::Tensor b2 = torch::rand({2, 4, 2, 2}, torch::kDouble);
  auto by_hand = [](const torch::Tensor& a, const torch::Tensor& b) {
    double total = 0;
    const int64_t B = a.size(0);
    for (int64_t n = 0; n < B; ++n) {
      std::vector<double> va, vb;
      double na = 0, nb = 0;
      for (int64_t c = 0; c < a.size(1); ++c)
        for (int64_t y = 0; y < a.size(2); ++y)
          for (int64_t x = 0; x < a.size(3); ++x) {
            va.push_back(a[n][c][y][x].item<double>());
            vb.push_back(b[n][c][y][x].item<double>());
            na += va.back() * va.back();
            nb += vb.back() * vb.back();
          }
      for (size_t i = 0; i < va.size(); ++i)
        total += std::pow(va[i] / std::sqrt(na) - vb[i] / std::sqrt(nb), 2);
    }
    return total / double(B);
  };
  EXPECT_NEAR(feature_transfer_loss({a1, a2}, {b1, b2}).item<double>(),
              (by_hand(a1, b1) + by_hand(a2, b2)) / 2, 1e-6);
  EXPECT_LT(spikems::test::finite_difference_error(
                [&](const torch::Tensor& v) { return feature_transfer_loss({v}, {b1}); }, a1),
            1e-6);
  // The teacher's padding (a larger map) is cut away.
  torch::Tensor padded = torch::rand({2, 3, 4, 6}, torch::kDouble) * 100;
  padded.narrow(2, 0, 3).narrow(3, 0, 4).copy_(b1);
  EXPECT_NEAR(feature_transfer_loss({a1}, {padded}).item<double>(),
              feature_transfer_loss({a1}, {b1}).item<double>(), 1e-12);
  // A silent student: 1, with a finite gradient.
  torch::Tensor silent = torch::zeros({2, 3, 3, 4}, torch::kDouble).requires_grad_(true);
  const torch::Tensor l = feature_transfer_loss({silent}, {b1});
  l.backward();
  EXPECT_NEAR(l.item<double>(), 1.0, 1e-6);
  EXPECT_TRUE(torch::isfinite(silent.grad()).all().item<bool>());
  // Other channel counts, samples or list lengths are refused.
  EXPECT_THROW(feature_transfer_loss({a1}, {torch::rand({2, 5, 3, 4}, torch::kDouble)}),
               std::exception);
  EXPECT_THROW(feature_transfer_loss({a1}, {b1.narrow(0, 0, 1)}), std::exception);
  EXPECT_THROW(feature_transfer_loss({a1, a2}, {b1}), std::exception);
}

// The potential readout: P = max over steps and channels of u / theta, p = sigmoid(alpha (P - 1))
// (1/2 exactly at threshold), in L_bce, the soft IoU and the distillation alike; L_spike
// refuses a potential.
TEST(Loss, PotentialReadoutScoresTheLargestPotential) {
  torch::manual_seed(12);
  const int64_t T = 5, B = 2, C = 2, H = 3, W = 4;
  const torch::Tensor in = (torch::rand({T, B, C, H, W}, torch::kDouble) < 0.3).to(torch::kDouble);
  torch::Tensor mask = (torch::rand({B, H, W}, torch::kDouble) < 0.5).to(torch::kDouble);
  const torch::Tensor u = torch::rand({T, B, 1, H, W}, torch::kDouble) * 0.6 - 0.2;
  LossOptions o;
  o.potential_readout = true;
  o.readout_theta = 0.22;
  o.alpha = 3;
  o.beta = 7;  // ignored: the readout's decision level is theta
  double bce = 0, den = 0, inter = 0, uni = 0;
  for (int64_t b = 0; b < B; ++b)
    for (int64_t y = 0; y < H; ++y)
      for (int64_t x = 0; x < W; ++x) {
        const double m = u.select(1, b).select(2, y).select(2, x).max().item<double>();
        EXPECT_NEAR(output_projection(u, o)[b][y][x].item<double>(), m / 0.22, 1e-12);
        const double p = 1 / (1 + std::exp(-3 * (m / 0.22 - 1)));
        const double ev = in.select(1, b).select(2, y).select(2, x).sum().item<double>();
        const bool fg = mask[b][y][x].item<double>() > 0;
        if (b == 0) {  // soft IoU of sample 0 alone (sample 1 has no moving object below)
          const double g = ev > 0 && fg ? 1 : 0;
          inter += p * g;
          uni += p + g - p * g;
        }
        if (ev == 0) continue;
        bce += fg ? -std::log(p) : -std::log(1 - p);
        den += 1;
      }
  ASSERT_GT(den, 0);
  EXPECT_NEAR(bce_loss(u, in, mask, o).item<double>(), bce / den, 1e-10);
  EXPECT_LT(spikems::test::finite_difference_error(
                [&](const torch::Tensor& v) { return bce_loss(v, in, mask, o); }, u),
            1e-6);
  torch::Tensor m1 = mask.clone();
  m1[1].zero_();
  EXPECT_NEAR(soft_iou_loss(u, in, m1, o).item<double>(), 1 - (inter + 1) / (uni + 1), 1e-10);
  // The teacher saying what the readout says: no distillation gradient.
  torch::Tensor v = u.clone().requires_grad_(true);
  distill_loss(v, in, projection_probability(output_projection(u, o), o), o).backward();
  EXPECT_LT(v.grad().abs().max().item<double>(), 1e-12);
  EXPECT_THROW(van_rossum_loss(u, u, o), std::exception);
  LossOptions ex = o;
  ex.projection = LossOptions::Projection::Exponential;
  EXPECT_THROW(bce_loss(u, in, mask, ex), std::exception);
}

// The off-event term: only pixels without input events whose logit is above -2 count, each
// softplus(z), halved and divided by the moving pixels of the batch; exact gradients; pixels
// with events, or far below the threshold, add nothing.
TEST(Loss, OffEventTermCountsEventlessPixelsNearTheThreshold) {
  torch::manual_seed(13);
  const int64_t T = 4, B = 2, C = 2, H = 4, W = 5;
  const torch::Tensor in = (torch::rand({T, B, C, H, W}, torch::kDouble) < 0.15).to(torch::kDouble);
  const torch::Tensor mask = (torch::rand({B, H, W}, torch::kDouble) < 0.5).to(torch::kDouble);
  const torch::Tensor u = torch::rand({T, B, 1, H, W}, torch::kDouble) * 0.5;
  for (const bool potential : {true, false}) {
    LossOptions o;
    o.potential_readout = potential;
    o.readout_theta = 0.22;
    o.alpha = 3;
    o.beta = 0.5;
    double sum = 0, n_fg = 0, counted = 0, with_events_above = 0;
    for (int64_t b = 0; b < B; ++b)
      for (int64_t y = 0; y < H; ++y)
        for (int64_t x = 0; x < W; ++x) {
          const torch::Tensor ux = u.select(1, b).select(2, y).select(2, x);
          const double P = potential ? ux.max().item<double>() / 0.22 : ux.sum().item<double>();
          const double z = 3 * (P - (potential ? 1.0 : 0.5));
          const double ev = in.select(1, b).select(2, y).select(2, x).sum().item<double>();
          if (ev > 0 && mask[b][y][x].item<double>() > 0) n_fg += 1;
          if (ev > 0) {
            with_events_above += z > -2;
            continue;
          }
          if (z <= -2) continue;
          sum += std::log1p(std::exp(z));
          counted += 1;
        }
    ASSERT_GT(n_fg, 0);
    ASSERT_GT(counted, 0) << "the case must have event-less pixels near the threshold";
    ASSERT_GT(with_events_above, 0) << "and pixels with events above it, which must not count";
    EXPECT_NEAR(offevent_loss(u, in, mask, o).item<double>(), 0.5 * sum / n_fg, 1e-10);
    EXPECT_LT(spikems::test::finite_difference_error(
                  [&](const torch::Tensor& v) { return offevent_loss(v, in, mask, o); }, u),
              1e-6);
    // Far below the threshold everywhere: zero, with no gradient (no push towards silence).
    torch::Tensor quiet = (u * 0 - 1).requires_grad_(true);
    const torch::Tensor l = offevent_loss(quiet, in, mask, o);
    l.backward();
    EXPECT_EQ(l.item<double>(), 0.0);
    EXPECT_EQ(quiet.grad().abs().max().item<double>(), 0.0);
    // No moving pixel in the batch: divided by 1, not by 0.
    EXPECT_NEAR(offevent_loss(u, in, torch::zeros_like(mask), o).item<double>(), 0.5 * sum, 1e-10);
  }
  LossOptions ex;
  ex.projection = LossOptions::Projection::Exponential;
  EXPECT_THROW(offevent_loss(u, in, mask, ex), std::exception);
}

TEST(Loss, BceAndVanRossumMatchTheirFormulasAndGradients) {
  torch::manual_seed(9);
  const int64_t T = 6, B = 2, C = 2, H = 3, W = 4;
  torch::Tensor in = (torch::rand({T, B, C, H, W}, torch::kDouble) < 0.3).to(torch::kDouble);
  torch::Tensor mask = (torch::rand({B, H, W}, torch::kDouble) < 0.5).to(torch::kDouble);
  torch::Tensor out = torch::rand({T, B, C, H, W}, torch::kDouble);  // relaxed spikes
  for (auto proj : {LossOptions::Projection::Sigmoid, LossOptions::Projection::Exponential}) {
    LossOptions o;
    o.projection = proj;
    // Explicit BCE.
    torch::Tensor P = out.sum(std::vector<int64_t>{0, 2});
    double num = 0, den = 0;
    for (int64_t b = 0; b < B; ++b)
      for (int64_t y = 0; y < H; ++y)
        for (int64_t x = 0; x < W; ++x) {
          double ev = in.select(1, b).select(2, y).select(2, x).sum().item<double>();
          if (ev == 0) continue;
          bool fg = mask[b][y][x].item<double>() > 0;
          double p = P[b][y][x].item<double>();
          double prob = proj == LossOptions::Projection::Sigmoid
                            ? 1 / (1 + std::exp(-o.alpha * (p - o.beta)))
                            : 1 - std::exp(-p / o.kappa);
          num += fg ? -std::log(prob) : -std::log(1 - prob);
          den += 1;
        }
    EXPECT_NEAR(bce_loss(out, in, mask, o).item<double>(), num / den, 1e-10);
    EXPECT_LT(spikems::test::finite_difference_error(
                  [&](const torch::Tensor& v) { return bce_loss(v, in, mask, o); }, out),
              1e-6);
  }
  {  // Soft IoU: explicit per-sample sums.
    LossOptions o;
    o.kappa = 1.5;
    torch::Tensor P = out.sum(std::vector<int64_t>{0, 2});
    // Sample 1 without moving objects: left out of the mean.
    torch::Tensor m = mask.clone();
    m[1].zero_();
    double sum = 0;
    double sum_gated = 0;  // gate_events: p counts only at pixels with input events
    for (int64_t b = 0; b < 1; ++b) {
      double inter = 0, uni = 0, uni_gated = 0;
      for (int64_t y = 0; y < H; ++y)
        for (int64_t x = 0; x < W; ++x) {
          const double ev = in.select(1, b).select(2, y).select(2, x).sum().item<double>();
          const double ev_fg = ev * m[b][y][x].item<double>();
          const double g = ev_fg > 0 ? 1 : 0, p = 1 - std::exp(-P[b][y][x].item<double>() / 1.5);
          inter += p * g;
          uni += p + g - p * g;
          uni_gated += ev > 0 ? p + g - p * g : 0;
        }
      sum += 1 - (inter + 1) / (uni + 1);
      sum_gated += 1 - (inter + 1) / (uni_gated + 1);  // g = 1 only where events fell
    }
    EXPECT_NEAR(soft_iou_loss(out, in, m, o).item<double>(), sum, 1e-10);
    LossOptions og = o;
    og.gate_events = true;
    EXPECT_NEAR(soft_iou_loss(out, in, m, og).item<double>(), sum_gated, 1e-10);
    EXPECT_GT(std::abs(sum_gated - sum), 1e-6);  // the case has spikes where no event fell
    EXPECT_LT(spikems::test::finite_difference_error(
                  [&](const torch::Tensor& v) { return soft_iou_loss(v, in, m, o); }, out),
              1e-6);
    // A perfect prediction scores ~0, silence on a sample with moving objects ~1.
    torch::Tensor perfect = foreground_target(in, m) * 50.0;
    EXPECT_LT(soft_iou_loss(perfect, in, m, o).item<double>(), 1e-6);
    EXPECT_GT(soft_iou_loss(torch::zeros_like(out), in, m, o).item<double>(), 0.5);
  }
  LossOptions o;
  torch::Tensor tgt = foreground_target(in, mask);
  EXPECT_EQ(tgt.sum().item<double>(), (in * mask.unsqueeze(0).unsqueeze(2)).sum().item<double>());
  // Explicit van Rossum with the impulse response of eps.
  auto h = o.kernel.impulse_response(int(T));
  double s = 0;
  for (int64_t t = 0; t < T; ++t) {
    torch::Tensor f = torch::zeros({B, C, H, W}, torch::kDouble), g = torch::zeros_like(f);
    for (int64_t i = 0; i <= t; ++i) {
      f += h[size_t(i)] * out[t - i];
      g += h[size_t(i)] * tgt[t - i];
    }
    s += (f - g).pow(2).sum().item<double>();
  }
  EXPECT_NEAR(van_rossum_loss(out, tgt, o).item<double>(), s * o.ts / o.tau / double(B * H * W),
              1e-10);
  EXPECT_LT(spikems::test::finite_difference_error(
                [&](const torch::Tensor& v) { return van_rossum_loss(v, tgt, o); }, out),
            1e-6);
  auto terms = spikems_loss(out, in, mask, o);
  EXPECT_NEAR(terms.total.item<double>(),
              terms.bce.item<double>() + o.lambda * terms.spike.item<double>(), 1e-12);
  EXPECT_EQ(van_rossum_loss(tgt, tgt, o).item<double>(), 0.0);
}

TEST(Network, BuildsFromSpecExportsBackAndTrains) {
  ModelSpec spec = spikems_architecture(true);
  torch::manual_seed(10);
  for (auto& l : spec.layers)
    for (auto& w : l.weight) w = float(torch::randn({1}).item<double>() * 0.6);
  SpikeMSNetwork net(spec);
  torch::Tensor x = (torch::rand({8, 2, 2, 16, 24}) < 0.2).to(torch::kFloat);
  torch::Tensor y = net->forward(x);
  ASSERT_EQ(y.sizes(), (std::vector<int64_t>{8, 2, 2, 16, 24}));  // padded: same size
  // Exported spec equals the input spec; a changed weight round-trips through a model file.
  ModelSpec back = net->to_spec();
  EXPECT_EQ(back.layers[3].weight, spec.layers[3].weight);
  std::string path = spikems::test::scratch_dir() + "/m.safetensors";
  {
    torch::NoGradGuard ng;
    net->layer(0)->weight.mul_(2);
  }
  save_model(path, net->to_spec());
  EXPECT_FLOAT_EQ(load_model(path).layers[0].weight[5], 2 * spec.layers[0].weight[5]);
  // Gradients reach every weight; one Adam step changes the loss.
  torch::Tensor mask = (torch::rand({2, 16, 24}) < 0.3).to(torch::kFloat);
  auto loss = spikems_loss(net->forward(x), x, mask, LossOptions{}).total;
  loss.backward();
  for (size_t k = 0; k < net->size(); ++k)
    EXPECT_GT(net->layer(k)->weight.grad().abs().sum().item<double>(), 0) << k;
  // forward_all_layers equals the module's per-layer outputs.
  auto all = forward_all_layers(spec, x);
  ASSERT_EQ(all.size(), 6u);
  EXPECT_EQ(all[1].size(2), 32);
}

TEST(Network, AlignToInputCropsOrPadsTopLeft) {
  torch::Tensor y = torch::arange(12, torch::kFloat).view({1, 3, 4});
  torch::Tensor c = align_to_input(y, 2, 3);
  EXPECT_EQ(c.sizes(), (std::vector<int64_t>{1, 2, 3}));
  EXPECT_EQ(c[0][1][2].item<float>(), 6.f);
  torch::Tensor p = align_to_input(y, 4, 5);
  EXPECT_EQ(p.sizes(), (std::vector<int64_t>{1, 4, 5}));
  EXPECT_EQ(p[0][2][3].item<float>(), 11.f);
  EXPECT_EQ(p[0][3][4].item<float>(), 0.f);
  // The authors' geometry on 64x80 gives 63x79; the padded one keeps 64x80; 346x260 padded gives
  // 352x264.
  EXPECT_EQ(spikems_architecture(false).output_size(64, 80), (std::pair<int, int>{63, 79}));
  EXPECT_EQ(spikems_architecture(true).output_size(260, 346), (std::pair<int, int>{264, 352}));
}

}  // namespace
}  // namespace spikems::train
