#!/usr/bin/env bash
# tests/run.sh - build the kifmm.h test suite in every configuration and run it.
#
#   bash tests/run.sh                 the default configurations (below)
#   CONFIGS="gcc-c11-omp asan" bash tests/run.sh   a subset, by name
#   CONFIGS=all bash tests/run.sh     all seventeen
#
# Configurations: {gcc, clang} x {-std=c99, -std=c11} x {with, without -fopenmp},
# all with -Wall -Wextra -Werror -pedantic -O2 -march=native; one
# AddressSanitizer + UndefinedBehaviorSanitizer build (gcc, OpenMP, -O1 -g1:
# line tables, for the reports' lines, at a third less compile time than -g);
# one without -march (gcc, OpenMP: the portable C loops and the BLAS level
# passes that a plain `cc -O2` build gets); the builds users make when they
# debug or forget the flags: gcc -O0 with OpenMP and without -march (the
# README's minimal compile line) and clang -std=c99 -O0 with -march=native
# and OpenMP; the tests
# compiled as C++ (g++ -x c++, plus tests/test_extern_c.cpp, a C++ host that
# wraps the includes in extern "C"), with and without OpenMP; and a
# ThreadSanitizer build (clang with its OpenMP runtime and Archer, see
# TSAN_OPTIONS below).
# By default five of them run, which still cover each compiler, each
# standard, with and without OpenMP, -O0 and -O2, builds without -march, C++
# and both sanitizers: gcc-c11-omp, asan, gcc-O0-omp (no -march, C99), gxx
# (C++ without OpenMP) and tsan (clang, C11, OpenMP, -O1; clang also builds
# the fuzz target); on a CPU with AVX-512 a sixth, gcc-avx2 (-mno-avx512f),
# builds the near-field hooks' tests only (test_p2p, test_yukawa_p2p,
# test_stokes_p2p, test_sincos, test_helmholtz: 50 s), whose AVX2 + FMA
# code no other configuration compiles there; where Debian's aarch64 cross
# compiler, qemu-user and arm64 OpenBLAS are installed, aarch64 builds
# test_p2p for aarch64 and runs it under qemu (the vector layer's NEON hooks
# and a whole FMM on the portable loops; about 35 s). The others run with CONFIGS=all or by name: gcc-c99 (C
# without OpenMP) and gxx-omp were defaults until on 2 cores of an AMD EPYC
# (AVX2) the seven defaults' tests took about 40 minutes; clang-O0-omp until
# the six took 37 minutes on an AMD EPYC with AVX-512 (Zen 4), 2 cores, with
# test_contract, test_tol_outputs and the fuzz target added (it ran 260 s).
# The full tables run in gcc-c11-omp only; elsewhere the tests are built
# with -DKIFMM_TEST_QUICK (test_accuracy at orders 4 and 6 only, fewer points
# in test_accuracy, test_kernels, test_small, test_threads and test_offset,
# order 12 left out except in the sanitizer build) to keep the whole run
# short. The tsan and gcc-O0-omp configurations leave test_alloc out
# unless CONFIGS=all or TESTS names it (the fourth field of a configuration
# below): it runs there for about 220 s each (2 cores, AMD EPYC Zen 4),
# and fails every allocation in gcc-c11-omp (each one) and in asan (every
# third, with LeakSanitizer) anyway. Both leave out test_tol too (46 and
# 49 s there; the order-from-tolerance logic and its accuracy tables run in
# gcc-c11-omp) and test_slab (80 and 92 s), gcc-O0-omp also
# test_tol_outputs (30 s) and test_periodic3 (102 s; it still runs in
# gcc-c11-omp), to make room for test_helmholtz
# (about 70 s of runs and 90 of builds over the five) and the MPI cases of
# stokes_dl and helmholtz: make test took 55 minutes on a clean clone
# before these two, on 2 cores of an AMD EPYC (Zen 4). tsan leaves out
# test_periodic3 too, for gcc-avx2 and the Helmholtz kernels in the
# library and the Python package. gcc-O0-omp leaves out test_tree (61 s
# there), test_update (32 s), test_periodic (21 s) and test_operators (19
# s), asan test_tol (36 s), test_update (43 s) and test_threads (31 s),
# for the compiled library's three instruction-set levels and the wheel
# (make lib: 75 s became 5 minutes on 2 cores of an Intel Xeon with
# AVX-512; make test took 58 min 55 s there with these last two still in
# asan); all still run in gcc-c11-omp, test_tree, test_periodic and
# test_operators in asan too, and all but test_tol and test_operators in
# tsan. gcc-O0-omp, the one default build without -march, keeps
# test_shipped, test_helmholtz and the contract and error tests on the
# portable loops that the library's base level runs.
#
# Each test program ends with "RESULT <passed> <failed>".  This script sums
# them over all programs and configurations; a build failure, a crash, a
# timeout or a nonzero exit without a reported failure counts as one failed
# check.  The last line of output is "N passed, N failed"; the exit status is
# nonzero if anything failed.
#
# Environment: TESTS (the programs to build and run, by name; default all),
# JOBS (parallel compiles, default 2), TEST_TIMEOUT (seconds per
# test program, default 900), CONFIGS (see above), EXTRA_CFLAGS (added to
# every compile, e.g. an -I for cblas.h; the Makefile sets it when needed).  OPENBLAS_CORETYPE is left
# alone if set; otherwise it is set to SkylakeX on CPUs with AVX-512 (where
# OpenBLAS may misdetect the CPU), and OpenBLAS's own detection is used
# elsewhere (SkylakeX kernels would die with SIGILL there).

# The body is one brace group: bash reads all of it before running any of
# it, so editing this file during a run does not disturb the run.
{
set -u
cd "$(dirname "$0")/.." || exit 1
ROOT=$(pwd)
BUILD="$ROOT/build/tests"
JOBS=${JOBS:-2}
TEST_TIMEOUT=${TEST_TIMEOUT:-900}
LIBS="-llapacke -lopenblas -lm"
WARN="-Wall -Wextra -Werror -pedantic"
# every tests/test_*.c with a main is a program; test_multi_tu_a.c and
# test_multi_tu_b.c link together into test_multi_tu; test_linkage_a and
# test_linkage_b link against libkifmm_linkage.a, built first from
# tests/linkage_lib.c (KIFMM_IMPLEMENT, see tests/test_linkage.h)
# (TESTS="test_tree test_alloc" bash tests/run.sh: those programs only)
NAMED=${TESTS:+1} # programs named by TESTS run even where a configuration leaves them out
TESTS=${TESTS:-$(for f in tests/test_*.c; do
    n=$(basename "$f" .c)
    case "$n" in test_multi_tu_a) echo test_multi_tu ;; test_multi_tu_b) ;; *) echo "$n" ;; esac
done | tr '\n' ' ')}

# One run at a time: a second run.sh waits for the first instead of
# rebuilding the same directories under it.
mkdir -p "$BUILD"
if command -v flock >/dev/null 2>&1; then
    exec 9>"$BUILD/.lock"
    if ! flock -n 9; then
        echo "another tests/run.sh is running; waiting for it to finish"
        flock 9
    fi
fi

if [ -z "${OPENBLAS_CORETYPE+x}" ]; then
    if grep -qw avx512f /proc/cpuinfo 2>/dev/null; then
        export OPENBLAS_CORETYPE=SkylakeX
    fi
fi

# gxx checks that the headers compile and run as C++: every shipped kernel
# (test_shipped), a C++ host (test_extern_c), threads and handles, the
# contract, errors, two translation units, linkage, the periodic and
# Helmholtz paths; tsan, the passes on threads: the shipped kernels'
# passes (test_shipped), tree building, updates, periodic sets,
# Helmholtz, handles on threads. The rest of each runs with CONFIGS=all
# (together about 540 s on 2 cores of an Intel Xeon with AVX-512, where
# make test took 75 minutes with them; CI took 4,495 s). test_deep (the
# anchors on deep trees) runs in gcc-c11-omp; the anchors' passes
# run on threads and in C++ through test_shipped (with
# it everywhere, make test took about 62 minutes there). asan leaves
# test_periodic3 (64 s) to gcc-c11-omp; test_periodic runs three periodic
# directions under it. Where make test took 75 minutes (2 cores of an Intel
# Xeon with AVX-512), these left for CONFIGS=all too: asan's test_families,
# test_laplace_family, test_deep, test_tol_outputs, test_estimate (builds
# 450 s and runs 215 s of CPU on 2 cores of an AMD EPYC, Zen 4),
# test_operators and test_slab (runs 76 and 77 s there); tsan's
# test_families (build 97 s, run 151 s) and test_periodic (run 131 s;
# periodic sets still run on threads under it in test_update, test_tree,
# test_contract and test_helmholtz); gcc-O0-omp's test_families (run 120
# s). The families' hooks still run under ASan and UBSan in the fuzz target
# (laplace, yukawa, stokes, stokes_dl, biot_savart) and the MPI sanitizer
# build, every family in gcc-c11-omp, and the portable loops of the shipped
# ones in gcc-O0-omp (test_shipped). run.sh took 2,377 s with asan's five
# and none of the rest left out there (Zen 4).
GXX_LEFT="test_families test_laplace_family test_update test_periodic3 test_tree test_tol_outputs
 test_kernels test_edges test_slab test_tol test_estimate test_alloc test_yukawa_p2p test_roles
 test_offset test_stokes_p2p test_small test_p2p test_operators test_check_order test_sincos test_ewald
 test_deep"
TSAN_LEFT="test_alloc test_tol test_slab test_periodic3 test_laplace_family test_tol_outputs
 test_kernels test_edges test_estimate test_yukawa_p2p test_roles test_offset test_stokes_p2p
 test_small test_p2p test_operators test_check_order test_sincos test_ewald test_multi_tu
 test_linkage test_errors test_deep test_families test_periodic"
GXX_LEFT=$(echo $GXX_LEFT)
TSAN_LEFT=$(echo $TSAN_LEFT)

# name | compiler | flags | programs left out unless CONFIGS=all (or, after
# "only: ", the only programs it builds)
ALL_CONFIGS="
gcc-c99|gcc|-std=c99 -O2 -march=native -DKIFMM_TEST_QUICK
gcc-c99-omp|gcc|-std=c99 -O2 -march=native -fopenmp -DKIFMM_TEST_QUICK
gcc-c11|gcc|-std=c11 -O2 -march=native -DKIFMM_TEST_QUICK
gcc-c11-omp|gcc|-std=c11 -O2 -march=native -fopenmp
clang-c99|clang|-std=c99 -O2 -march=native -DKIFMM_TEST_QUICK
clang-c99-omp|clang|-std=c99 -O2 -march=native -fopenmp -DKIFMM_TEST_QUICK
clang-c11|clang|-std=c11 -O2 -march=native -DKIFMM_TEST_QUICK
clang-c11-omp|clang|-std=c11 -O2 -march=native -fopenmp -DKIFMM_TEST_QUICK
asan|gcc|-std=c11 -O1 -g1 -march=native -fopenmp -fsanitize=address,undefined -fno-sanitize-recover=all -DKIFMM_TEST_QUICK|test_periodic3 test_tol test_update test_threads test_families test_laplace_family test_deep test_tol_outputs test_estimate test_operators test_slab
gcc-c11-omp-portable|gcc|-std=c11 -O2 -fopenmp -DKIFMM_TEST_QUICK
gcc-O0-omp|gcc|-std=c99 -O0 -fopenmp -DKIFMM_TEST_QUICK|test_alloc test_tol test_tol_outputs test_slab test_periodic3 test_laplace_family test_threads test_deep test_tree test_update test_periodic test_operators test_families
clang-O0-omp|clang|-std=c99 -O0 -march=native -fopenmp -DKIFMM_TEST_QUICK
gxx-omp|g++|-x c++ -std=c++11 -O2 -march=native -fopenmp -DKIFMM_TEST_QUICK
gxx|g++|-x c++ -std=c++11 -O2 -march=native -DKIFMM_TEST_QUICK|$GXX_LEFT
tsan|clang|-std=c11 -O1 -g1 -march=native -fopenmp -fsanitize=thread -DKIFMM_TEST_QUICK|$TSAN_LEFT
gcc-avx2|gcc|-std=c11 -O2 -march=native -mno-avx512f -fopenmp -DKIFMM_TEST_QUICK|only: test_p2p test_yukawa_p2p test_stokes_p2p test_sincos test_helmholtz
aarch64|aarch64-linux-gnu-gcc|-std=c11 -O2 -DKIFMM_TEST_QUICK|only: test_p2p
"

DEFAULT_CONFIGS="gcc-c11-omp asan gcc-O0-omp gxx tsan"
# on an AVX-512 machine the AVX2 + FMA near-field hooks (and the vectorised
# sin, cos and exp under them) are compiled by no other configuration:
# gcc-avx2 builds the tests of the hooks without AVX-512 (about a minute)
if grep -qw avx512f /proc/cpuinfo 2>/dev/null; then DEFAULT_CONFIGS="$DEFAULT_CONFIGS gcc-avx2"; fi
# aarch64: Debian's cross compiler and arm64 OpenBLAS and LAPACKE, run
# under qemu-user (.ci/run installs them): the near-field hooks of the
# vector layer in NEON, against long double sums, and a whole FMM
# (test_p2p, about 20 s under qemu). Without OpenMP and with one OpenBLAS
# thread: qemu-aarch64 7.2 hung here at the first thread a program started.
QEMU_ARM="qemu-aarch64 -L /usr/aarch64-linux-gnu"
if command -v aarch64-linux-gnu-gcc >/dev/null 2>&1 && command -v qemu-aarch64 >/dev/null 2>&1 &&
    [ -e /usr/lib/aarch64-linux-gnu/libopenblas.so ] && [ -e /usr/lib/aarch64-linux-gnu/liblapacke.so ]; then
    DEFAULT_CONFIGS="$DEFAULT_CONFIGS aarch64"
    ARM_OK=1
else
    ARM_OK=0
fi

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
# ThreadSanitizer with clang's OpenMP runtime: libomp loads its Archer tool
# when it sees TSan, which tells TSan about barriers, reductions and tasks;
# the OpenMP runtime itself is not instrumented and is left out (without
# this option TSan reports races inside libomp's own locks). A report makes
# the program exit with status 66, counted as a failure. Kernels with a
# 32-bit mmap randomisation make clang 14's TSan fail at start-up; setarch -R
# (no address randomisation) avoids that.
export TSAN_OPTIONS=${TSAN_OPTIONS:-ignore_noninstrumented_modules=1}

total_pass=0
total_fail=0
start_all=$SECONDS

echo "kifmm.h test suite: $(gcc --version 2>/dev/null | head -n1); $(clang --version 2>/dev/null | head -n1)"
echo "OPENBLAS_CORETYPE=${OPENBLAS_CORETYPE:-<unset: OpenBLAS detects the CPU>}, OMP_NUM_THREADS=${OMP_NUM_THREADS:-<unset>}"
echo "full tables in gcc-c11-omp only; the other configurations build with -DKIFMM_TEST_QUICK:"
echo "  test_accuracy orders 4 and 6 only, fewer points in test_accuracy/test_kernels/test_small, order 12 only in gcc-c11-omp and asan"

# sources of one program
sources_of() {
    case "$1" in
        test_multi_tu) echo "tests/test_multi_tu_a.c tests/test_multi_tu_b.c" ;;
        laplace) echo "examples/laplace.c" ;;
        test_extern_c) echo "tests/test_extern_c.cpp" ;;
        *) echo "tests/$1.c" ;;
    esac
}

# the library of instances that the test_linkage programs link against
build_linkage_lib() {
    local cc=$1 flags=$2 dir=$3
    # shellcheck disable=SC2086
    $cc $WARN $flags ${EXTRA_CFLAGS:-} -I. -c tests/linkage_lib.c -o "$dir/linkage_lib.o" \
        </dev/null >"$dir/libkifmm_linkage.build.log" 2>&1 &&
        ar rcs "$dir/libkifmm_linkage.a" "$dir/linkage_lib.o" >>"$dir/libkifmm_linkage.build.log" 2>&1
}

# compile one program in the background; status in $dir/$name.status
compile() {
    local cc=$1 flags=$2 dir=$3 name=$4 link=""
    case "$name" in test_linkage_*) link="-L$dir -lkifmm_linkage" ;; esac
    (
        local t0=$SECONDS
        # shellcheck disable=SC2046,SC2086
        if $cc $WARN $flags ${EXTRA_CFLAGS:-} -I. $(sources_of "$name") -o "$dir/$name" $link $LIBS \
            </dev/null >"$dir/$name.build.log" 2>&1; then
            echo 0 >"$dir/$name.status"
        else
            echo 1 >"$dir/$name.status"
        fi
        echo $((SECONDS - t0)) >"$dir/$name.btime"
    ) &
}

# run_prog FLAGS DIR PROG JOBS: one test program, its output in DIR/PROG.log
# and its exit status in DIR/PROG.rc
run_prog() {
    local flags=$1 dir=$2 prog=$3 pj=$4 runner="" rc t0=$SECONDS
    case " $flags " in
        *" -fsanitize=thread "*)
            if command -v setarch >/dev/null 2>&1; then runner="setarch $(uname -m) -R"; fi ;;
    esac
    # the sanitizer builds run OpenBLAS on one thread a call (unless the
    # caller set it), where create factors the operators on several
    # threads at once (docs/api.md, "Threads and BLAS"); the others with
    # OpenBLAS's default threads, where it factors them one after the other
    case " $flags " in
        *" -fsanitize="*) runner="env OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1} $runner" ;;
    esac
    case "$dir" in */aarch64) runner="env OPENBLAS_NUM_THREADS=1 $QEMU_ARM" ;; esac
    if [ "$pj" -gt 1 ]; then
        # shellcheck disable=SC2086
        OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive} timeout "$TEST_TIMEOUT" $runner "$dir/$prog" \
            </dev/null >"$dir/$prog.log" 2>&1
    else
        # shellcheck disable=SC2086
        timeout "$TEST_TIMEOUT" $runner "$dir/$prog" </dev/null >"$dir/$prog.log" 2>&1
    fi
    rc=$?
    echo "$rc" >"$dir/$prog.rc"
    echo $((SECONDS - t0)) >"$dir/$prog.rtime"
}

# slowest EXT DIR: the four programs whose DIR/*.EXT seconds are the largest
slowest() {
    local f
    for f in "$2"/*."$1"; do
        [ -e "$f" ] && echo "$(cat "$f") $(basename "$f" ".$1")"
    done | sort -n -r | head -n 4 | awk '{printf "%s%s %ss", (NR > 1 ? ", " : ""), $2, $1}'
}

run_config() {
    local name=$1 cc=$2 flags=$3 skip=$4
    local dir="$BUILD/$name" pass=0 fail=0 t0=$SECONDS tb notes="" prog progs="" left=
    rm -rf "$dir"
    mkdir -p "$dir"

    # build, at most $JOBS compiles at once (the library first)
    build_linkage_lib "$cc" "$flags" "$dir"
    local running=0
    for prog in $TESTS; do
        case "$skip" in
            "only: "*) case " ${skip#only:} " in *" $prog "*) progs="$progs $prog" ;; esac; continue ;;
        esac
        case " $skip " in
            *" $prog "*) case " ${CONFIGS:-}${NAMED:+ all} " in *" all "*) ;; *) left="$left $prog"; continue ;; esac ;;
        esac
        progs="$progs $prog"
    done
    case "$skip" in
        "only: "*) ;;
        *) case " $flags " in *" -x c++ "*) progs="$progs test_extern_c" ;; *) progs="$progs laplace" ;; esac ;;
    esac
    for prog in $progs; do
        if [ "$running" -ge "$JOBS" ]; then
            wait -n 2>/dev/null || true
            running=$((running - 1))
        fi
        compile "$cc" "$flags" "$dir" "$prog"
        running=$((running + 1))
    done
    wait
    tb=$((SECONDS - t0))

    for prog in $progs; do
        if [ "$(cat "$dir/$prog.status" 2>/dev/null)" != 0 ]; then
            fail=$((fail + 1))
            notes="$notes
    build of $prog failed ($dir/$prog.build.log):
$(grep -m 3 -E "error|undefined" "$dir/$prog.build.log" | sed 's/^/      /')"
        fi
    done

    # run: two programs at a time (RUN_JOBS, default $JOBS), their OpenMP
    # threads waiting passively (OMP_WAIT_POLICY, unless set) so that the two
    # programs' threads share the cores without spinning (the full tables'
    # programs too: their references in long double and their serial steps
    # left a core idle)
    local pj=${RUN_JOBS:-$JOBS}
    running=0
    for prog in ${progs% laplace}; do
        [ -x "$dir/$prog" ] || continue
        if [ "$running" -ge "$pj" ]; then
            wait -n 2>/dev/null || true
            running=$((running - 1))
        fi
        run_prog "$flags" "$dir" "$prog" "$pj" &
        running=$((running + 1))
    done
    wait
    for prog in ${progs% laplace}; do
        [ -x "$dir/$prog" ] || continue
        local log="$dir/$prog.log" rc res p f
        rc=$(cat "$dir/$prog.rc" 2>/dev/null || echo 1)
        res=$(grep -E '^RESULT [0-9]+ [0-9]+$' "$log" | tail -n 1)
        if [ -z "$res" ]; then
            fail=$((fail + 1))
            if [ "$rc" = 124 ]; then
                notes="$notes
    $prog: timed out after ${TEST_TIMEOUT}s ($log)"
            else
                notes="$notes
    $prog: no RESULT line, exit status $rc ($log):
$(tail -n 15 "$log" | sed 's/^/      /')"
            fi
            continue
        fi
        p=$(echo "$res" | cut -d' ' -f2)
        f=$(echo "$res" | cut -d' ' -f3)
        pass=$((pass + p))
        fail=$((fail + f))
        if [ "$f" != 0 ]; then
            notes="$notes
    $prog: $f failed ($log):
$(grep -E 'FAIL' "$log" | head -n 20 | sed 's/^/      /')"
        elif [ "$rc" != 0 ]; then
            fail=$((fail + 1))
            notes="$notes
    $prog: RESULT reports no failure but the exit status is $rc ($log):
$(tail -n 15 "$log" | sed 's/^/      /')"
        fi
    done

    local tail="${left:+   (left out, CONFIGS=all runs them:$left)}"
    case "$skip" in "only: "*) tail="   (these programs only:${skip#only:})" ;; esac
    printf '%-14s %6d passed, %3d failed   (build %3ds, run %3ds)%s\n' "$name" "$pass" "$fail" \
        "$tb" $((SECONDS - t0 - tb)) "$tail"
    echo "               slowest builds: $(slowest btime "$dir"); runs: $(slowest rtime "$dir")"
    if [ -n "$notes" ]; then echo "$notes" | sed '1{/^$/d}'; fi
    total_pass=$((total_pass + pass))
    total_fail=$((total_fail + fail))
}

selected=0
while IFS='|' read -r name cc flags skip; do
    [ -n "$name" ] || continue
    case " ${CONFIGS:-$DEFAULT_CONFIGS} " in *" $name "* | *" all "*) ;; *) continue ;; esac
    if [ "$name" = aarch64 ] && [ "$ARM_OK" = 0 ]; then
        echo "aarch64        skipped: needs aarch64-linux-gnu-gcc, qemu-aarch64 and arm64 libopenblas-dev and liblapacke-dev (.ci/run installs them)"
        case " ${CONFIGS:-} " in *" aarch64 "*) total_fail=$((total_fail + 1)) ;; esac
        continue
    fi
    selected=$((selected + 1))
    run_config "$name" "$cc" "$flags" "${skip:-}"
done <<EOF
$ALL_CONFIGS
EOF

if [ "$selected" = 0 ]; then
    echo "no configuration matches CONFIGS='${CONFIGS:-}'"
    total_fail=$((total_fail + 1))
fi
echo "total time $((SECONDS - start_all))s"
echo "$total_pass passed, $total_fail failed"
[ "$total_fail" = 0 ]
exit
}
