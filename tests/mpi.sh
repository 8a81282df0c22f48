#!/usr/bin/env bash
# tests/mpi.sh - MPI mode (KIFMM_MPI, <prefix>_create_mpi): tests/mpi/test_mpi.c
# built with mpicc (C11, -O2 -march=native, OpenMP, -Werror), with ASan and
# UBSan, and with mpicxx (as C++, without OpenMP), run under mpirun with 1,
# 2, 3 and 4 ranks (the C build; the sanitizer build with 2, the C++ one
# with 3; those two and the C build's 1-, 3- and 4-rank runs with fewer
# cases, KIFMM_TEST_MPI_LIGHT (the 3-rank one took 63 s with all, 2 cores
# of an AMD EPYC), unless CONFIGS=all, which also adds stokes_dl at p = 8 to the 2-rank run,
# KIFMM_TEST_MPI_ALL), oversubscribed (--oversubscribe; as root also
# --allow-run-as-root), one OpenMP thread a rank, two for the one rank; each
# run fails about 50 allocations of create_mpi, evaluate and update_points
# on one rank, and with CONFIGS=all the 3-rank run fails every one in turn
# (KIFMM_TEST_ALLOC_ALL: about 50 s more on 2 cores).
# Then examples/mpi_nbody.c, 20,000 bodies on 3 ranks (it checks itself
# against direct sums). Without mpicc it prints why and passes: MPI is
# optional. The last line is
# "mpi: N passed, N failed"; the exit status is nonzero on failure.
# Environment: EXTRA_CFLAGS (added to the compiles), MPI_TIMEOUT (seconds per
# run, default 300).
set -u
cd "$(dirname "$0")/.." || exit 1
if ! command -v mpicc > /dev/null 2>&1 || ! command -v mpirun > /dev/null 2>&1; then
    echo "mpi: skipped (no mpicc or mpirun: apt-get install libopenmpi-dev openmpi-bin)"
    exit 0
fi
B=build/mpi
mkdir -p "$B"
LIBS="-llapacke -lopenblas -lm"
WARN="-Wall -Wextra -Werror -pedantic"
RUN=(mpirun --oversubscribe --bind-to none)
[ "$(id -u)" = 0 ] && RUN+=(--allow-run-as-root)
# shared-memory transport without the cross-memory attach containers forbid
export OMPI_MCA_btl_vader_single_copy_mechanism=none
if [ -z "${OPENBLAS_CORETYPE:-}" ] && grep -q avx512f /proc/cpuinfo 2>/dev/null; then
    export OPENBLAS_CORETYPE=SkylakeX
fi
pass=0 fail=0
# a probe: 2 ranks and one allreduce; where shared memory between the ranks
# fails (a container's small /dev/shm), the runs go over TCP on loopback
printf '#include <mpi.h>\nint main(int c, char **v) { int x = 1, y = 0; MPI_Init(&c, &v);\n'\
'MPI_Allreduce(&x, &y, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD); MPI_Finalize(); return y != 2; }\n' > "$B/probe.c"
if mpicc "$B/probe.c" -o "$B/probe" > "$B/probe.log" 2>&1; then
    if ! timeout 120 "${RUN[@]}" -np 2 "$B/probe" >> "$B/probe.log" 2>&1; then
        export OMPI_MCA_btl=self,tcp
        echo "mpi: shared memory between ranks failed (build/mpi/probe.log); using OMPI_MCA_btl=self,tcp"
        timeout 120 "${RUN[@]}" -np 2 "$B/probe" >> "$B/probe.log" 2>&1 || echo "mpi: the probe fails over TCP too"
    fi
fi
# build NAME COMPILER FLAGS...: tests/mpi/test_mpi.c into $B/NAME in the
# background (two compiles at a time: the three builds and the example took
# 197 s one after the other, 2 cores of an AMD EPYC); built NAME waits for
# it and says whether it built
build() {
    local n=$1 cc=$2
    shift 2
    rm -f "$B/$n" "$B/$n.ok"
    while [ "$(jobs -rp | wc -l)" -ge 2 ]; do wait -n; done
    { "$cc" "$@" $WARN ${EXTRA_CFLAGS:-} -I. tests/mpi/test_mpi.c -o "$B/$n" $LIBS > "$B/$n.build.log" 2>&1 &&
        touch "$B/$n.ok"; } &
}
built() {
    wait
    [ -e "$B/$1.ok" ] && return 0
    echo "mpi: $1: build FAILED"
    cat "$B/$1.build.log"
    fail=$((fail + 1))
    return 1
}
run() { # name ranks threads
    local n=$1 np=$2 th=$3 log="$B/$1.np$2.log" r
    OMP_NUM_THREADS=$th timeout "${MPI_TIMEOUT:-300}" "${RUN[@]}" -np "$np" "$B/$n" > "$log" 2>&1
    r=$?
    grep -E '^==|FAIL' "$log" | sed "s/^/[$n np $np] /"
    set -- $(grep '^RESULT' "$log" | tail -1)
    if [ $# -eq 3 ]; then
        pass=$((pass + $2)) fail=$((fail + $3))
        [ "$r" != 0 ] && [ "$3" = 0 ] && fail=$((fail + 1))
    else
        echo "mpi: $n with $np ranks: no RESULT (exit $r); the log's end:"
        tail -20 "$log"
        fail=$((fail + 1))
    fi
    echo "mpi: $n, $np ranks x $th threads: exit $r"
}
# the builds first, the longest (the sanitizers') first: AddressSanitizer
# and UndefinedBehaviorSanitizer; C11; C++ (without the MPI libraries'
# deprecated C++ bindings, whose headers warn); the example
build asan mpicc -std=c11 -O1 -g1 -fsanitize=address,undefined -fno-omit-frame-pointer \
    -fno-sanitize-recover=undefined -march=native -fopenmp
build c11 mpicc -std=c11 -O2 -march=native -fopenmp
build cxx mpicxx -x c++ -DOMPI_SKIP_MPICXX -DMPICH_SKIP_MPICXX -O2 -march=native
rm -f "$B/mpi_nbody" "$B/mpi_nbody.ok"
while [ "$(jobs -rp | wc -l)" -ge 2 ]; do wait -n; done
{ mpicc -std=c99 -O2 -march=native -fopenmp $WARN ${EXTRA_CFLAGS:-} -I. examples/mpi_nbody.c \
    -o "$B/mpi_nbody" $LIBS > "$B/mpi_nbody.build.log" 2>&1 && touch "$B/mpi_nbody.ok"; } &
LIGHT=$([ "${CONFIGS:-}" = all ] || echo 1)
if built c11; then
    KIFMM_TEST_MPI_LIGHT=$LIGHT run c11 1 2
    KIFMM_TEST_MPI_ALL=$([ -z "$LIGHT" ] && echo 1) run c11 2 1
    if [ -z "$LIGHT" ]; then KIFMM_TEST_ALLOC_ALL=1 run c11 3 1; else KIFMM_TEST_MPI_LIGHT=1 run c11 3 1; fi
    KIFMM_TEST_MPI_LIGHT=$LIGHT run c11 4 1
fi
# the sanitizers, 2 ranks (leaks: the test counts the library's blocks
# itself; MPI's own are not its to check)
if built asan; then
    ASAN_OPTIONS=detect_leaks=0 KIFMM_TEST_MPI_LIGHT=${LIGHT:-1} run asan 2 1
fi
if built cxx; then
    KIFMM_TEST_MPI_LIGHT=1 run cxx 3 1
fi
# the example, 3 ranks: its own check against direct sums sets its exit status
if [ -e "$B/mpi_nbody.ok" ] &&
    OMP_NUM_THREADS=1 timeout "${MPI_TIMEOUT:-300}" "${RUN[@]}" -np 3 "$B/mpi_nbody" 20000 3 6 > "$B/mpi_nbody.log" 2>&1; then
    pass=$((pass + 1))
    tail -1 "$B/mpi_nbody.log"
else
    fail=$((fail + 1))
    echo "mpi: examples/mpi_nbody.c FAILED:"
    cat "$B/mpi_nbody.build.log" "$B/mpi_nbody.log" 2>/dev/null | tail -20
fi
echo "mpi: $pass passed, $fail failed"
[ "$fail" = 0 ]
