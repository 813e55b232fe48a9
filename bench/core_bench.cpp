#include <benchmark/benchmark.h>

#include <vector>

#include "talus/core/random.hpp"

namespace {

using talus::core::RandomStream;
using talus::core::Stream;

void BM_NormalsBulk(benchmark::State& state) {
  const RandomStream s(1, Stream::terrain_roughness, 0);
  std::vector<double> out(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    s.normals(0, out.data(), out.size());
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_NormalsBulk)->Arg(1 << 20);

void BM_Uniform(benchmark::State& state) {
  const RandomStream s(1, Stream::impact, 0);
  std::uint64_t k = 0;
  for (auto _ : state) benchmark::DoNotOptimize(s.uniform(k++));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Uniform);

}  // namespace
