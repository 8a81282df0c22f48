#!/usr/bin/env bash
# tests/mpi.sh - MPI mode (KIFMM_MPI, <prefix>_create_mpi): tests/mpi/test_mpi.c
# built with mpicc (C11, -O2 -march=native, OpenMP, -Werror) and with mpicxx (as
# C++, without OpenMP), run under mpirun with 1, 2, 3 and 4 ranks (the C build;
# the C++ one with 3), oversubscribed (--oversubscribe; as root also
# --allow-run-as-root), one OpenMP thread a rank except the 2-rank run's 2.
# Without mpicc it prints why and passes: MPI is optional. The last line is
# "mpi: N passed, N failed"; the exit status is nonzero on failure.
# Environment: EXTRA_CFLAGS (added to the compiles), MPI_TIMEOUT (seconds per
# run, default 600).
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
build() { # name compiler flags...
    local n=$1 cc=$2
    shift 2
    if ! "$cc" "$@" $WARN ${EXTRA_CFLAGS:-} -I. tests/mpi/test_mpi.c -o "$B/$n" $LIBS > "$B/$n.build.log" 2>&1; then
        echo "mpi: $n: build FAILED"
        cat "$B/$n.build.log"
        fail=$((fail + 1))
        return 1
    fi
}
run() { # name ranks threads
    local n=$1 np=$2 th=$3 log="$B/$1.np$2.log" r
    OMP_NUM_THREADS=$th timeout "${MPI_TIMEOUT:-600}" "${RUN[@]}" -np "$np" "$B/$n" > "$log" 2>&1
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
if build c11 mpicc -std=c11 -O2 -march=native -fopenmp; then
    run c11 1 1
    run c11 2 2
    run c11 3 1
    run c11 4 1
fi
# (C++: without the MPI libraries' deprecated C++ bindings, whose headers warn)
if build cxx mpicxx -x c++ -DOMPI_SKIP_MPICXX -DMPICH_SKIP_MPICXX -O2 -march=native; then
    run cxx 3 1
fi
echo "mpi: $pass passed, $fail failed"
[ "$fail" = 0 ]
