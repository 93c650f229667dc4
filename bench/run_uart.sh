#!/usr/bin/env bash
# The UART benchmarks of bench/bench_uart.cpp (command in bench/README.md, figures in
# docs/performance.md): builds build-bench in Release and runs them, three repetitions each,
# medians reported. Extra arguments go to Google Benchmark (--benchmark_filter=SigrokRead_Decode, --benchmark_format=json, ...).
# About 3.5 minutes on 2 cores, half of it writing the .sr sessions (deflate).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build-bench --target drivetap_bench
build-bench/bench/drivetap_bench --benchmark_filter='Uart|Sigrok' --benchmark_min_time=1 \
  --benchmark_repetitions=3 --benchmark_report_aggregates_only=true "$@"
