// Test helper: prints a model file's tensors as spikems loads them (load_model, with all its
// validation), as JSON {"layers.k.weight": {"shape": [...], "values": [...]}, ...}, so that
// tests/python/test_safetensors.py can compare them with an independent numpy reader.
// Floats are printed with 9 significant digits, which round-trips every float32 exactly.
#include <cstdio>
#include <string>
#include <vector>

#include "core/model/model_file.h"
#include "core/util/error.h"

namespace {

void print_tensor(const std::string& name, const std::vector<long>& shape,
                  const std::vector<float>& v, bool& first) {
  std::printf("%s\n  \"%s\": {\"shape\": [", first ? "" : ",", name.c_str());
  for (size_t i = 0; i < shape.size(); ++i) std::printf("%s%ld", i ? ", " : "", shape[i]);
  std::printf("], \"values\": [");
  for (size_t i = 0; i < v.size(); ++i) std::printf("%s%.9g", i ? ", " : "", double(v[i]));
  std::printf("]}");
  first = false;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s MODEL.safetensors\n", argv[0]);
    return 2;
  }
  try {
    const spikems::ModelSpec m = spikems::load_model(argv[1]);
    bool first = true;
    std::printf("{");
    for (size_t k = 0; k < m.layers.size(); ++k) {
      const auto& l = m.layers[k];
      const std::string p = "layers." + std::to_string(k) + ".";
      // PyTorch layouts: conv [C_out, C_in, k, k], transposed conv [C_in, C_out, k, k].
      const long a = l.kind == spikems::LayerKind::Conv ? l.out_channels : l.in_channels;
      const long b = l.kind == spikems::LayerKind::Conv ? l.in_channels : l.out_channels;
      print_tensor(p + "weight", {a, b, l.kernel, l.kernel}, l.weight, first);
      if (!l.srm_kernel.empty())
        print_tensor(p + "srm_kernel", {long(l.srm_kernel.size())}, l.srm_kernel, first);
      if (!l.ref_kernel.empty())
        print_tensor(p + "ref_kernel", {long(l.ref_kernel.size())}, l.ref_kernel, first);
      if (!l.delay.empty()) print_tensor(p + "delay", {long(l.delay.size())}, l.delay, first);
    }
    std::printf("\n}\n");
  } catch (const spikems::Error& e) {
    std::fprintf(stderr, "spikems_dump_model: %s\n", e.what());
    return 1;
  }
  return 0;
}
