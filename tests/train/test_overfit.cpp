// The network, loss and optimizer can learn: on one fixed batch of simulated samples, Adam
// drives the loss down and the window IoU up (a broken gradient path would not). About 23 s:
// ctest label "slow"; Trainer.LossFallsAndValidationBeatsTheUntrainedNetwork runs in CI.
#include <gtest/gtest.h>

#include "common/test_paths.h"
#include "core/dataset/batch_loader.h"
#include "core/model/model_file.h"
#include "train/loss/spikems_loss.h"
#include "train/network/spikems_network.h"
#include "train/trainer/batch_tensors.h"
#include "train/trainer/weight_init.h"

namespace spikems::train {
namespace {

TEST(OverfitSlow, OneBatchIsLearnt) {
  const std::string dir = test::scratch_dir() + "/data";
  std::string out;
  ASSERT_EQ(test::run_command(test::spikems_binary() +
                                  " simulate --preset tiny --sequences 1 --duration 0.2s --seed 5 "
                                  "--threads 1 --no-progress --out " +
                                  dir,
                              &out),
            0)
      << out;
  LabelledSequence seq = load_sequence(dir + "/seq_0000.h5");
  SampleOptions so;
  so.crop = 32;
  so.warmup_us = 5000;
  so.centred_fraction = 1;
  std::vector<const LabelledSequence*> seqs{&seq};
  Batch b = BatchLoader::make(seqs, {1.0}, so, 4, 3, 0);
  BatchTensors bt = to_tensors(b.samples, 1.0, torch::kCPU);
  torch::manual_seed(1);
  at::set_num_threads(1);
  SpikeMSNetwork net(spikems_architecture(true, Discretisation::IIR));
  init_weights_from_data(net, bt.input, {0.03, 0.03, 0.03, 0.03, 0.03, 0.02}, 1.0, 1);
  torch::optim::Adam opt(net->parameters(), torch::optim::AdamOptions(3e-3).amsgrad(true));
  LossOptions lo;
  lo.alpha = 4;
  lo.beta = 0.5;
  lo.all_pixels = true;
  lo.balanced = true;
  const int64_t w0 = bt.warmup_steps, tw = bt.input.size(0) - w0;
  auto step = [&](bool learn, WindowScores* ws) {
    auto y = align_to_input(net->forward(bt.input), 32, 32).narrow(0, w0, tw);
    auto loss = bce_loss(y, bt.input.narrow(0, w0, tw), bt.fg.narrow(0, w0, tw), lo);
    if (ws)
      for (const auto& m : window_counts(y, bt.fg.narrow(0, w0, tw))) ws->add(m);
    if (learn) {
      opt.zero_grad();
      loss.backward();
      opt.step();
    }
    return loss.item<double>();
  };
  WindowScores before, after;
  const double l0 = step(false, &before);
  for (int i = 0; i < 150; ++i) step(true, nullptr);
  const double l1 = step(false, &after);
  std::printf("loss %.4f -> %.4f, IoU %.1f -> %.1f %%\n", l0, l1, 100 * before.mean_iou(),
              100 * after.mean_iou());
  EXPECT_LT(l1, 0.5 * l0);
  EXPECT_GT(after.mean_iou(), before.mean_iou() + 0.2);
}

}  // namespace
}  // namespace spikems::train
