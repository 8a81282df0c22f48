#!/usr/bin/env bash
# tests/fuzz.sh - build tests/fuzz_create.c with clang's libFuzzer, ASan and
# UBSan, and fuzz the public API for FUZZ_TIME seconds (default 60).
#
#   bash tests/fuzz.sh                  (make test runs it this way)
#   FUZZ_TIME=300 bash tests/fuzz.sh    (make fuzz FUZZ_TIME=300)
#
# The run starts from tests/fuzz_corpus/, copied afresh into build/fuzz/corpus/
# (new inputs go there, not into the repository; FUZZ_KEEP=1 starts from
# what an earlier run left there instead).  A crash, leak, sanitizer
# report or failed check leaves build/fuzz/crash-* (or leak-*, timeout-*,
# oom-*) and the log build/fuzz/fuzz.log; reproduce with
#   FUZZ_TRACE=1 build/fuzz_create build/fuzz/crash-...
# The last line is "fuzz: ok (N runs in S s)", "fuzz: FAILED (...)" or
# "fuzz: skipped (...)", the last only where clang or its libFuzzer runtime is
# missing (Debian: the clang and libclang-rt-dev packages).
#
# Environment: FUZZ_TIME (seconds), FUZZ_KEEP, FUZZ_SEED (libFuzzer's -seed:
# make test sets 1, so that its run repeats; unset, a fresh seed each run),
# EXTRA_CFLAGS (e.g. an -I for cblas.h),
# FUZZ_ARGS (more libFuzzer options), CLANG (default clang).
set -u
cd "$(dirname "$0")/.." || exit 1
FUZZ_TIME=${FUZZ_TIME:-60}
CLANG=${CLANG:-clang}
EXTRA_CFLAGS=${EXTRA_CFLAGS:-}
OUT=build/fuzz
BIN=build/fuzz_create
LIBS="-llapacke -lopenblas -lm"
CFLAGS="-std=c11 -g1 -O1 -march=native -fopenmp -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all -Wall -Wextra"

mkdir -p "$OUT" || exit 1

if ! command -v "$CLANG" >/dev/null 2>&1; then
    echo "fuzz: skipped ($CLANG not found; it needs clang and its libFuzzer runtime)"
    exit 0
fi
probe="$OUT/probe"
if ! printf 'int LLVMFuzzerTestOneInput(const unsigned char *d, unsigned long n) { (void)d; (void)n; return 0; }\n' \
        | "$CLANG" -fsanitize=fuzzer,address,undefined -x c - -o "$probe" >"$OUT/probe.log" 2>&1 \
   || ! "$probe" -runs=1 >>"$OUT/probe.log" 2>&1; then
    echo "fuzz: skipped ($CLANG cannot build or run a libFuzzer program: libclang_rt.fuzzer missing?" \
         "Debian: apt-get install libclang-rt-dev; see $OUT/probe.log)"
    exit 0
fi

# rebuild when the target or the headers are newer than the binary
# three objects, two at a time: the harness (instances declared only) and
# the two halves of the instances (tests/fuzz_instances.h)
SRCS="tests/fuzz_create.c tests/fuzz_instances.c tests/fuzz_instances.h tests/fuzz_mode.h kifmm.h kifmm_kernels.h"
stale=0
[ -x "$BIN" ] || stale=1
for f in $SRCS; do [ "$f" -nt "$BIN" ] && stale=1; done
if [ "$stale" = 1 ]; then
    echo "fuzz: $CLANG $CFLAGS $EXTRA_CFLAGS -I. -c tests/fuzz_create.c, tests/fuzz_instances.c" \
         "(-DFUZZ_PART=1, 2); linked into $BIN with $LIBS"
    rm -f "$BIN" "$OUT"/*.o
    # shellcheck disable=SC2086
    "$CLANG" $CFLAGS $EXTRA_CFLAGS -I. -DFUZZ_PART=1 -c tests/fuzz_instances.c -o "$OUT/part1.o" &
    p1=$!
    # shellcheck disable=SC2086
    "$CLANG" $CFLAGS $EXTRA_CFLAGS -I. -DFUZZ_PART=2 -c tests/fuzz_instances.c -o "$OUT/part2.o" &
    p2=$!
    wait "$p1"
    r1=$?
    # shellcheck disable=SC2086
    "$CLANG" $CFLAGS $EXTRA_CFLAGS -I. -c tests/fuzz_create.c -o "$OUT/harness.o"
    r0=$?
    wait "$p2"
    r2=$?
    # shellcheck disable=SC2086
    if [ "$r0$r1$r2" != 000 ] ||
        ! "$CLANG" $CFLAGS "$OUT/harness.o" "$OUT/part1.o" "$OUT/part2.o" -o "$BIN" $LIBS; then
        echo "fuzz: FAILED (build of $BIN)"
        exit 1
    fi
fi

# a fresh copy each time: libFuzzer first runs every input of its corpus, and
# one grown by earlier runs (thousands of inputs) would take minutes of the
# time given; FUZZ_KEEP=1 keeps the grown one (make fuzz FUZZ_KEEP=1)
if [ "${FUZZ_KEEP:-0}" != 1 ]; then rm -rf "$OUT/corpus"; fi
mkdir -p "$OUT/corpus"
cp -p tests/fuzz_corpus/* "$OUT/corpus/" 2>/dev/null
rm -f "$OUT"/crash-* "$OUT"/leak-* "$OUT"/timeout-* "$OUT"/oom-* "$OUT"/slow-unit-*

# One BLAS thread and at most two OpenMP threads (the target passes nthreads
# 0, 1 or 2): the machine may be shared.  Inputs are capped to run in about a
# second, so a 60 s timeout means a hang.
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=2
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
start=$(date +%s)
# shellcheck disable=SC2086
"./$BIN" -max_len=256 -max_total_time="$FUZZ_TIME" -timeout=60 -rss_limit_mb=4096 \
    -print_final_stats=1 -artifact_prefix="$OUT/" ${FUZZ_SEED:+-seed=$FUZZ_SEED} ${FUZZ_ARGS:-} \
    "$OUT/corpus" >"$OUT/fuzz.log" 2>&1
rc=$?
secs=$(( $(date +%s) - start ))
runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$OUT/fuzz.log" | tail -n 1)
artifact=$(ls "$OUT"/crash-* "$OUT"/leak-* "$OUT"/timeout-* "$OUT"/oom-* 2>/dev/null | head -n 1)
if [ "$rc" -ne 0 ] || [ -n "$artifact" ]; then
    grep -v -E '^#[0-9]+.*(NEW|REDUCE|pulse)|NEW_FUNC' "$OUT/fuzz.log" | tail -n 60
    echo "fuzz: FAILED (exit $rc after $secs s; input ${artifact:-none}; log $OUT/fuzz.log;" \
         "reproduce: FUZZ_TRACE=1 $BIN ${artifact:-INPUT})"
    exit 1
fi
echo "fuzz: ok (${runs:-?} runs in $secs s)"
exit 0
