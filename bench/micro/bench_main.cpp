// The main of every Google Benchmark binary here: each registers its cases in register_benchmarks()
// (they depend on which captures exist, so they cannot be static BENCHMARK() registrations).
#include <benchmark/benchmark.h>

#include "bench_data.hpp"

int main(int argc, char** argv) {
  sensor_rig::bench::register_benchmarks();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 2;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
