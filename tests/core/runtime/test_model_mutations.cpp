// Mutated model files. A model file is user input like any event file (`segment --model` takes
// a path from anywhere): every leaf of a shipped model's spec (its layers, neurons, gate, grid)
// is replaced by edge values of every JSON type, or removed, and the file is then loaded and,
// when it is accepted, built into the streaming runtime and run on a few events. Each case must
// end in a spikems::Error or a finished run: never a crash, another exception type, or a run
// that allocates without bound. About 30 s: ctest label "slow".
#include <gtest/gtest.h>

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <typeinfo>
#include <vector>

#include "common/test_paths.h"
#include "core/model/model_file.h"
#include "core/model/safetensors.h"
#include "core/runtime/segmenter.h"
#include "core/util/error.h"

namespace spikems {
namespace {

using Json = nlohmann::json;

// JSON pointers to every scalar leaf, every array and object member (for removal), in order.
// Long arrays (sampled kernels) count as one leaf: their elements are weights, not structure.
void collect(const Json& j, const Json::json_pointer& at, std::vector<Json::json_pointer>& leaves,
             std::vector<Json::json_pointer>& members) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      members.push_back(at / it.key());
      collect(it.value(), at / it.key(), leaves, members);
    }
  } else if (j.is_array() && j.size() <= 16) {
    for (size_t i = 0; i < j.size(); ++i) collect(j[i], at / i, leaves, members);
  } else {
    leaves.push_back(at);
  }
}

TEST(ModelMutationsSlow, EveryLeafReplacedOrRemovedGivesAnErrorOrARun) {
  const std::string path = test::source_dir() + "/models/spikems-default.safetensors";
  SafeTensors st = read_safetensors(path);
  const Json spec = Json::parse(st.metadata.at("spec"));
  std::vector<Json::json_pointer> leaves, members;
  collect(spec, Json::json_pointer(), leaves, members);
  ASSERT_GT(leaves.size(), 100u) << "the shipped model's spec should have hundreds of fields";

  const std::vector<Json> values = {
      0,   -1,   1,       2,   7,    1 << 20,       1e300,         -1e300,
      0.5, 1e-9, nullptr, "x", true, Json::array(), Json::object()};
  EventStream ev;  // 60 ms of events over a small sensor, both polarities
  for (int i = 0; i < 600; ++i)
    ev.push_back(int64_t(i) * 100, uint16_t((i * 7) % 48), uint16_t((i * 5) % 36), uint8_t(i % 2));

  size_t accepted = 0, refused = 0, structural_accepted = 0, structural_refused = 0;
  auto attempt = [&](const Json& mutated, const std::string& what) {
    // The provenance (training, calibration) and the name are free-form: anything goes there.
    const bool structural = what.rfind("/training", 0) != 0 &&
                            what.rfind("without /training", 0) != 0 && what.rfind("/name", 0) != 0;
    st.metadata["spec"] = mutated.dump();
    try {
      const ModelSpec model = model_from_safetensors(st, what);
      Segmenter seg(model, SensorSize{48, 36}, SegmenterOptions{});
      seg.push(ev);
      seg.finish();
      ++accepted;
      structural_accepted += structural;
    } catch (const Error&) {
      ++refused;
      structural_refused += structural;
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": " << typeid(e).name() << ": " << e.what();
    }
  };
  attempt(spec, "the model itself");
  ASSERT_EQ(accepted, 1u) << "the unmutated model must load and run";
  for (const auto& at : leaves)
    for (const Json& v : values) {
      Json m = spec;
      m[at] = v;
      attempt(m, at.to_string() + " = " + v.dump());
    }
  for (const auto& at : members) {
    Json m = spec;
    m[at.parent_pointer()].erase(at.back());
    attempt(m, "without " + at.to_string());
  }
  // Most edits of the network's structure must be caught: a loader that accepted anything would
  // pass the loop above.
  EXPECT_GT(structural_refused, 2 * structural_accepted)
      << structural_accepted << " structural edits accepted, " << structural_refused << " refused";
  EXPECT_EQ(accepted + refused, 1 + leaves.size() * values.size() + members.size());
}

}  // namespace
}  // namespace spikems
