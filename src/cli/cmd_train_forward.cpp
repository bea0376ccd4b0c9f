// `spikems forward --model MODEL --input IN.npz --output OUT.npz`: dense forward pass of a
// model file (LibTorch) on a spike tensor. The npz layout is the authors' (N, C, H, W, T),
// time last; the output holds layer1 ... layerL in the same layout (float32, spikes 1/Ts).
#include <cstdio>

#include "cli/command.h"
#include "cli/torch_helper.h"
#include "core/events/formats/npy.h"
#include "core/model/model_file.h"
#include "core/util/error.h"
#include "train/network/spikems_network.h"
#include "train/threads.h"

namespace {

struct Args {
  std::string model, input, output, key = "input";
  int threads = 0;
};

void run(const Args& a) {
  spikems::ModelSpec spec = spikems::load_model(a.model);
  auto z = spikems::read_npz(a.input);
  auto it = z.find(a.key);
  if (it == z.end()) spikems::fail(a.input, "", "no array '" + a.key + "' (use --key to name it)");
  const auto& arr = it->second;
  if (arr.shape.size() != 5)
    spikems::fail(a.input, a.key, "expected a 5-D spike tensor (N, C, H, W, T)");
  if (arr.shape[1] != spec.layers.front().in_channels)
    spikems::fail(a.input, a.key,
                  "has " + std::to_string(arr.shape[1]) + " channels, the model takes " +
                      std::to_string(spec.layers.front().in_channels));
  auto [oh, ow] = spec.output_size(int(arr.shape[2]), int(arr.shape[3]));
  if (oh <= 0 || ow <= 0) spikems::fail(a.input, a.key, "spatial size too small for this model");
  int nt = spikems::train::set_torch_threads(a.threads);
  std::vector<float> v = arr.to<float>();
  torch::Tensor x =
      torch::from_blob(v.data(), arr.shape, torch::kFloat).permute({4, 0, 1, 2, 3}).contiguous();
  auto layers = spikems::train::forward_all_layers(spec, x);
  std::map<std::string, spikems::NpyArray> out;
  std::printf("%s: input %lldx%lldx%lldx%lld, T %lld, %d threads\n", a.model.c_str(),
              (long long)arr.shape[0], (long long)arr.shape[1], (long long)arr.shape[2],
              (long long)arr.shape[3], (long long)arr.shape[4], nt);
  for (size_t k = 0; k < layers.size(); ++k) {
    torch::Tensor y = layers[k].permute({1, 2, 3, 4, 0}).contiguous();
    std::vector<float> yv(y.data_ptr<float>(), y.data_ptr<float>() + y.numel());
    std::vector<int64_t> shape(y.sizes().begin(), y.sizes().end());
    std::printf(
        "  layer%zu: %s, %.0f spikes\n", k + 1,
        [&] {
          std::string s;
          for (auto d : shape) s += (s.empty() ? "" : "x") + std::to_string(d);
          return s;
        }()
            .c_str(),
        y.sum().item<double>() * spec.time_step_ms);
    out["layer" + std::to_string(k + 1)] = spikems::NpyArray::from(yv, shape);
  }
  spikems::write_npz(a.output, out, true);
}

void add(CLI::App& app) {
  static Args a;
  auto* cmd = app.add_subcommand("forward", spikems::cli::torch_command("forward").description);
  cmd->add_option("--model,-m", a.model, "model file")->required()->check(CLI::ExistingFile);
  cmd->add_option("--input,-i", a.input, "input .npz")->required()->check(CLI::ExistingFile);
  cmd->add_option("--output,-o", a.output, "output .npz")->required();
  cmd->add_option("--key", a.key, "array name of the input in the npz")->capture_default_str();
  cmd->add_option("--threads", a.threads, "LibTorch threads (0 = hardware threads)")
      ->check(CLI::Range(0, 1024));
  cmd->footer(
      "Example:\n"
      "  spikems forward --model m.safetensors --input spikes.npz --output layers.npz");
  cmd->callback([] { run(a); });
}

}  // namespace

SPIKEMS_COMMAND(forward, 62, add);
