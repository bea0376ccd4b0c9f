#include "train/trainer/checkpoint.h"

#include <filesystem>

#include "core/util/error.h"

namespace spikems::train {

void save_checkpoint(const std::string& path, torch::nn::Module& net, torch::optim::Optimizer& opt,
                     const CheckpointState& st) {
  torch::serialize::OutputArchive ar, model, optim;
  net.save(model);
  opt.save(optim);
  ar.write("model", model);
  ar.write("optimizer", optim);
  ar.write("step", torch::tensor(st.step, torch::kInt64));
  ar.write("best_val_iou", torch::tensor(st.best_val_iou, torch::kFloat64));
  ar.write("best_step", torch::tensor(st.best_step, torch::kInt64));
  ar.write("wall_seconds", torch::tensor(st.wall_seconds, torch::kFloat64));
  if (!st.ema.empty()) {
    ar.write("ema_count", torch::tensor(int64_t(st.ema.size()), torch::kInt64));
    ar.write("ema_updates", torch::tensor(st.ema_updates, torch::kInt64));
    for (size_t k = 0; k < st.ema.size(); ++k)
      ar.write("ema_" + std::to_string(k), st.ema[k].to(torch::kCPU));
  }
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  try {
    ar.save_to(tmp);
    std::filesystem::rename(tmp, path);
  } catch (const std::exception& e) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    fail(path, "", std::string("cannot write the checkpoint: ") + e.what());
  }
}

CheckpointState load_checkpoint(const std::string& path, torch::nn::Module& net,
                                torch::optim::Optimizer& opt) {
  CheckpointState st;
  try {
    torch::serialize::InputArchive ar, model, optim;
    ar.load_from(path);
    ar.read("model", model);
    ar.read("optimizer", optim);
    net.load(model);
    opt.load(optim);
    // A fresh tensor per key: read() into a defined tensor keeps that tensor's dtype and
    // reinterprets the bytes (a double read into the int64 "step" tensor came back as bits).
    auto scalar = [&](const char* key) {
      torch::Tensor t;
      ar.read(key, t);
      return t;
    };
    st.step = scalar("step").item<int64_t>();
    st.best_val_iou = scalar("best_val_iou").item<double>();
    st.best_step = scalar("best_step").item<int64_t>();
    st.wall_seconds = scalar("wall_seconds").item<double>();
    torch::Tensor n;
    if (ar.try_read("ema_count", n)) {
      st.ema_updates = scalar("ema_updates").item<int64_t>();
      for (int64_t k = 0; k < n.item<int64_t>(); ++k)
        st.ema.push_back(scalar(("ema_" + std::to_string(k)).c_str()));
    }
  } catch (const c10::Error& e) {
    fail(path, "",
         "not a usable spikems checkpoint for this network: " +
             std::string(e.what_without_backtrace()));
  }
  return st;
}

}  // namespace spikems::train
