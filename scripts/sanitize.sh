#!/usr/bin/env bash
# AddressSanitizer + UndefinedBehaviorSanitizer run. Configures a separate
# build folder (default build-asan/), builds only the CLI, the per-module
# unit tests and the reliability/mutation tests with
# -fsanitize=address,undefined, and runs them with ctest. Any sanitizer
# report aborts the process (also in the CLI processes the tests start), so
# it fails the test that ran it.
# The mutation test runs SVBRDF_MUTATIONS (default 60) of its 302 seeded
# corruptions: under ASan every CLI start-up costs several times the ~0.6 s
# CPU it takes uninstrumented, and its stride spreads the first N over every
# input kind and command (set SVBRDF_MUTATIONS=302 for all of them).
# Usage: JOBS=2 bash scripts/sanitize.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-asan}
start=$(date +%s)
# EIGEN_MALLOC_ALREADY_ALIGNED=1: Eigen switches to its hand-made aligned
# allocator when __SANITIZE_ADDRESS__ is defined (Memory.h), while Debian's
# static libceres.a was built without ASan and uses plain malloc; Jet buffers
# allocated by one copy and freed by the other read 8 bytes before the block
# (a false heap-buffer-overflow). glibc and ASan both return 16-byte-aligned
# memory, so plain malloc is right for Eigen's 16-byte default alignment.
san="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -DEIGEN_MALLOC_ALREADY_ALIGNED=1"
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSVBRDF_BUILD_BENCHMARKS=OFF \
  -DCMAKE_CXX_FLAGS="$san" -DCMAKE_EXE_LINKER_FLAGS="$san" >/dev/null
targets="svbrdf e2e_mutation_test e2e_reliability_test"
for f in tests/*_test.cc; do targets+=" $(basename "$f" .cc)"; done
ninja -C "$build" -j "${JOBS:-$(nproc)}" $targets
# Suppressions name third-party libraries only; each is documented in the file.
supp="$PWD/scripts/sanitize.supp"
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=1:detect_leaks=1:strict_string_checks=1"
export LSAN_OPTIONS="suppressions=$supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:abort_on_error=1:print_stacktrace=1"
export SVBRDF_MUTATIONS=${SVBRDF_MUTATIONS:-60}
built=$(date +%s)
echo "sanitize.sh: built in $(( built - start )) s"
cd "$build"
ctest --output-on-failure -j "$(nproc)" --timeout 1800 -L unit
ctest --output-on-failure -j "$(nproc)" --timeout 1800 -R '^(MutationTest|Reliability)\.'
echo "sanitize.sh: clean (ASan + UBSan): build $(( built - start )) s, tests $(( $(date +%s) - built )) s"
