#!/usr/bin/env bash
# bench/run.sh - build bench/bench.c and run the benchmark table of kifmm.h,
# with a comparison against FMM3D (fmm3dpy) when it can be imported or installed.
#
#   bash bench/run.sh            cube, sphere, clustered x N = 1e4, 1e5, 1e6 x p = 4, 6, 8, then
#                                float and evaluate_many, kernels side by side, high
#                                accuracy (orders 4 to 12, 1M points), periodic
#                                boundaries, time stepping (update_points), the compiled
#                                library's levels (make lib), MPI mode
#   bash bench/run.sh --quick    cube x N = 1e4, 1e5 x p = 6
#
# Environment (all optional; `make bench BIG=1 P=10` passes them through):
#   BIG=1          add N = 1e7
#   P="10 12"      add these expansion orders
#   THREADS=2      threads for kifmm, the direct sums and FMM3D (OMP_NUM_THREADS is set
#                  to it unless already set; OPENBLAS_NUM_THREADS, unless set, to 1 on
#                  AVX2 machines, where evaluate calls no BLAS, and to THREADS elsewhere)
#   FMM3D=0        skip the FMM3D comparison
#   QUIET_WAIT=300 seconds to wait for the machine to be quiet before the run
#                  (1-minute load average < 0.7) and up to a tenth of that before
#                  each case (other processes using < 20% of the CPUs); a case run
#                  anyway is marked in the bg% column (CPU used by other processes
#                  during the case, in % of all CPUs)
#   CC, EXTRA_CFLAGS  compiler and extra flags (an -I for cblas.h, say)
#   BENCH_DISTS, BENCH_NS, BENCH_ORDERS   replace the lists above (e.g. BENCH_NS="2e5")
#
# Outputs in build/bench/: bench (the program), results.txt (this output),
# case_*.txt (one key=value line per case), data_*.bin (points, charges and
# direct sums for FMM3D), venv/ (fmm3dpy if it had to be installed).
set -u
cd "$(dirname "$0")/.." || exit 1

OUT=build/bench
mkdir -p "$OUT"
QUICK=0
[ "${1:-}" = "--quick" ] && QUICK=1
THREADS=${THREADS:-2}
QUIET_WAIT=${QUIET_WAIT:-300}
CC=${CC:-cc}
NCPU=$(getconf _NPROCESSORS_ONLN)

if [ "$QUICK" = 1 ]; then
    DISTS="cube"; NS="1e4 1e5"; ORDERS="6"
else
    DISTS="cube sphere clustered"; NS="1e4 1e5 1e6"; ORDERS="4 6 8"
    [ "${BIG:-0}" = 1 ] && NS="$NS 1e7"
fi
DISTS=${BENCH_DISTS:-$DISTS}; NS=${BENCH_NS:-$NS}; ORDERS=${BENCH_ORDERS:-$ORDERS}
for p in ${P:-}; do
    case " $ORDERS " in *" $p "*) ;; *) ORDERS="$ORDERS $p" ;; esac
done

exec > >(tee "$OUT/results.txt") 2>&1

# ---------------------------------------------------------------- settings
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-$THREADS}
# With AVX2 evaluate makes no BLAS call and create's are small: one OpenBLAS
# thread, so that no idle OpenBLAS thread spins (about 0.1 s after process
# start and after each call) on a core the library's own threads need
# (docs/api.md, "Threads and BLAS").
if [ -z "${OPENBLAS_NUM_THREADS:-}" ]; then
    if grep -qw avx2 /proc/cpuinfo 2>/dev/null; then
        export OPENBLAS_NUM_THREADS=1
        BLASNOTE="OPENBLAS_NUM_THREADS was unset: this benchmark set 1 (AVX2: evaluate calls no BLAS; see docs/api.md)"
    else
        export OPENBLAS_NUM_THREADS=$THREADS
        BLASNOTE="OPENBLAS_NUM_THREADS was unset: this benchmark set $THREADS (no AVX2: the level passes call BLAS)"
    fi
else
    BLASNOTE="OPENBLAS_NUM_THREADS=$OPENBLAS_NUM_THREADS was set by the caller"
fi
CORENOTE="OPENBLAS_CORETYPE=${OPENBLAS_CORETYPE:-} was set by the caller"
if [ -z "${OPENBLAS_CORETYPE:-}" ]; then
    if grep -qw avx2 /proc/cpuinfo 2>/dev/null; then
        export OPENBLAS_CORETYPE=Haswell
        CORENOTE="OPENBLAS_CORETYPE was unset: this benchmark set OPENBLAS_CORETYPE=Haswell (the CPU has AVX2)"
    else
        CORENOTE="OPENBLAS_CORETYPE unset and no AVX2: OpenBLAS picks the core itself"
    fi
fi

echo "== kifmm.h benchmark ($(date -u '+%Y-%m-%d %H:%M UTC'), $(uname -n))"
echo "cases:       dist {$DISTS} x N {$NS} x p {$ORDERS}, kernel laplace_grad, sources = targets,"
echo "             charges uniform in [-1, 1], each case in its own process"
echo "build:       $CC -std=c99 -O3 -march=native -fopenmp ${EXTRA_CFLAGS:-} bench/bench.c -llapacke -lopenblas -lm"
# shellcheck disable=SC2086
if ! $CC -std=c99 -O3 -march=native -fopenmp -Wall -Wextra ${EXTRA_CFLAGS:-} -I. bench/bench.c \
        -o "$OUT/bench" -llapacke -lopenblas -lm; then
    echo "bench: build failed"
    exit 1
fi
echo "note:        $CORENOTE"
echo "note:        $BLASNOTE"
OPENBLAS_VERBOSE=2 "$OUT/bench" --info 2>&1 | sed 's/^Core: /OpenBLAS verbose: Core: /'

# ---------------------------------------------------------------- FMM3D
PY=""
if [ "${FMM3D:-1}" = 0 ]; then
    FMM3D_NOTE="FMM3D comparison skipped (FMM3D=0)"
elif python3 -c "import fmm3dpy, numpy" >/dev/null 2>&1; then
    PY=python3
elif [ -x "$OUT/venv/bin/python" ] && "$OUT/venv/bin/python" -c "import fmm3dpy, numpy" >/dev/null 2>&1; then
    PY="$OUT/venv/bin/python"
else
    echo "fmm3d:       python3 cannot import fmm3dpy: pip install fmm3dpy numpy into $OUT/venv"
    if { [ -x "$OUT/venv/bin/python" ] || python3 -m venv "$OUT/venv"; } &&
       "$OUT/venv/bin/python" -m pip install -q fmm3dpy numpy &&
       "$OUT/venv/bin/python" -c "import fmm3dpy, numpy" >/dev/null 2>&1; then
        PY="$OUT/venv/bin/python"
    else
        FMM3D_NOTE="FMM3D comparison skipped: fmm3dpy could not be installed (pip install fmm3dpy failed)"
        echo "fmm3d:       $FMM3D_NOTE"
    fi
fi
if [ -n "$PY" ]; then
    FMM3D_NOTE=""
    echo "fmm3d:       $("$PY" bench/fmm3d_run.py --version)"
fi

# ---------------------------------------------------------------- quiet machine
# CPU time (jiffies) used by everything since boot: busy, total
cpu_jiffies() { awk '/^cpu /{print $2+$3+$4+$7+$8+$9, $2+$3+$4+$5+$6+$7+$8+$9; exit}' /proc/stat; }
# % of all CPUs busy during one second
busy_pct() {
    local b0 t0 b1 t1
    read -r b0 t0 < <(cpu_jiffies); sleep 1; read -r b1 t1 < <(cpu_jiffies)
    echo $(( (b1 - b0) * 100 / (t1 - t0 > 0 ? t1 - t0 : 1) ))
}
load1() { cut -d' ' -f1 /proc/loadavg; }

waited=0
while awk -v l="$(load1)" 'BEGIN{exit !(l >= 0.7)}'; do
    if [ "$waited" -ge "$QUIET_WAIT" ]; then
        echo "WARNING:     load average $(load1) >= 0.7 after waiting ${QUIET_WAIT} s: timings may be disturbed (see bg%)"
        break
    fi
    [ "$waited" = 0 ] && echo "waiting:     load average $(load1) >= 0.7, waiting up to ${QUIET_WAIT} s for a quiet machine"
    sleep 10; waited=$((waited + 10))
done
echo "load:        $(cut -d' ' -f1-3 /proc/loadavg) (1, 5, 15 min) at start"

wait_quiet() {
    local w=0 b
    while :; do
        b=$(busy_pct)
        [ "$b" -lt 20 ] && return 0
        [ "$w" -ge $((QUIET_WAIT / 10)) ] && return 0
        sleep 4; w=$((w + 5))
    done
}

# run CMD...; sets BG to the CPU used by other processes meanwhile (% of all CPUs)
# (children's CPU time from the shell's `times`, second line: "0m1.20s 0m0.30s")
children_cs() { times > "$OUT/.times"; awk 'NR == 2 {
    n = split($1 " " $2, a, " "); s = 0
    for (i = 1; i <= n; i++) { split(a[i], b, "m"); s += b[1] * 60 + b[2] }
    printf "%d", s * 100 }' "$OUT/.times"; }
run_measured() {
    local b0 t0 b1 t1 rc us c0
    children_cs > "$OUT/.c0"
    read -r b0 t0 < <(cpu_jiffies)
    "$@"
    rc=$?
    read -r b1 t1 < <(cpu_jiffies)
    children_cs > "$OUT/.c1"
    us=$(( $(cat "$OUT/.c1") - $(cat "$OUT/.c0") ))
    BG=$(awk -v b=$((b1 - b0)) -v t=$((t1 - t0)) -v u="$us" \
        'BEGIN{x = t > 0 ? (b - u) * 100 / t : 0; if (x < 0) x = 0; printf "%d", x}')
    return $rc
}

# build_for ISA SRC OUT TAG: SRC built for the machine (ISA avx2: with
# -mno-avx512f) into OUT; on failure a message, and TAG among the failures
build_for() {
    local kflags=""
    [ "$1" = avx2 ] && kflags="-mno-avx512f"
    echo "build:       $CC -std=c99 -O3 -march=native $kflags -fopenmp $2 -> $(basename "$3")"
    # shellcheck disable=SC2086
    if $CC -std=c99 -O3 -march=native $kflags -fopenmp -Wall -Wextra ${EXTRA_CFLAGS:-} -I. "$2" \
            -o "$3" -llapacke -lopenblas -lm; then
        return 0
    fi
    echo "$(basename "$2") ($1): build failed"
    FAILED="$FAILED $4"
    return 1
}

# ---------------------------------------------------------------- kifmm table
echo
echo "== kifmm laplace_grad: potential and gradient, ${OMP_NUM_THREADS} threads"
"$OUT/bench" --header -v | sed '1s/$/    bg%/' | { read -r h; cat; echo "$h"; }
rm -f "$OUT/fmm3d_rows.txt"
FAILED=""
for dist in $DISTS; do
    for n in $NS; do
        # FMM3D: cube and sphere up to N = 1e6, on the data the first order dumps
        want_fmm3d=0
        if [ -n "$PY" ] && [ "$dist" != clustered ] && awk -v n="$n" 'BEGIN{exit !(n <= 1e6)}'; then
            want_fmm3d=1
        fi
        results=""
        data="$OUT/data_${dist}_${n}.bin"
        for p in $ORDERS; do
            res="$OUT/case_${dist}_${n}_p${p}.txt"
            args=("$dist" "$n" "$p" --result "$res")
            [ "$want_fmm3d" = 1 ] && [ -z "$results" ] && args+=(--dump "$data")
            wait_quiet
            rm -f "$res"
            if run_measured "$OUT/bench" "${args[@]}" > "$OUT/.row"; then
                echo "$(cat "$OUT/.row")    $BG"
                results="$results $res"
            else
                echo "$dist $n $p: FAILED (exit status $?)"
                FAILED="$FAILED $dist/$n/p$p"
            fi
        done
        if [ "$want_fmm3d" = 1 ] && [ -n "$results" ]; then
            wait_quiet
            # shellcheck disable=SC2086
            if run_measured "$PY" bench/fmm3d_run.py "$data" $results > "$OUT/.fmm3d"; then
                sed "/^#/!s/\$/    $BG/" "$OUT/.fmm3d" >> "$OUT/fmm3d_rows.txt"
            else
                echo "fmm3d: $dist $n: FAILED"
            fi
        fi
    done
done

# ---------------------------------------------------------------- float, evaluate_many
# Single precision (KIFMM_REAL float) and 8 density vectors per evaluate_many
# call, next to the double single-vector case, on the same points.
if [ "$QUICK" = 1 ]; then VNS="1e5"; VORDERS="4"; else VNS="1e5 1e6"; VORDERS="4 6"; fi
VNS=${BENCH_VNS:-$VNS}; VORDERS=${BENCH_VORDERS:-$VORDERS}
echo
echo "== precision and density vectors: cube, laplace_grad, ${OMP_NUM_THREADS} threads"
echo "   (/f32: float instance; /x8: evaluate_many with 8 vectors, times for all 8)"
"$OUT/bench" --header | sed '1s/$/    bg%/'
RATIOS=""
for n in $VNS; do
    for p in $VORDERS; do
        for v in "d1:" "f1:--float" "d8:--nrhs 8" "f8:--float --nrhs 8"; do
            tag=${v%%:*}; opt=${v#*:}
            res="$OUT/var_${n}_p${p}_${tag}.txt"
            wait_quiet
            rm -f "$res"
            # shellcheck disable=SC2086
            if run_measured "$OUT/bench" cube "$n" "$p" --sample 500 --repeat 3 --result "$res" $opt > "$OUT/.row"; then
                echo "$(cat "$OUT/.row")    $BG"
            else
                echo "cube $n $p $opt: FAILED"
                FAILED="$FAILED cube/$n/p$p/$tag"
            fi
        done
        ev() { sed -n 's/.* evaluate=\([0-9.e+-]*\) .*/\1/p' "$OUT/var_${n}_p${p}_$1.txt" 2>/dev/null; }
        d1=$(ev d1); f1=$(ev f1); d8=$(ev d8); f8=$(ev f8)
        if [ -n "$d1" ] && [ -n "$f1" ] && [ -n "$d8" ] && [ -n "$f8" ]; then
            RATIOS="$RATIOS$(awk -v n="$n" -v p="$p" -v d1="$d1" -v f1="$f1" -v d8="$d8" -v f8="$f8" 'BEGIN{
                printf "N=%s p=%s: float is %.2fx faster than double (evaluate); 8 vectors cost %.2f single evaluations (double), %.2f (float)\n",
                       n, p, d1 / f1, d8 / d1, f8 / f1 }')
"
        fi
    done
done
[ -n "$RATIOS" ] && printf '%s' "$RATIOS"

# ---------------------------------------------------------------- kernels side by side
# laplace_grad, yukawa_grad, stokes, laplace_cd_grad and biot_savart on the same points
# (bench/bench_kernels.c), built for the machine and, where it has AVX-512, also with
# -mno-avx512f (the AVX2 + FMA hooks an AVX2-only machine runs); FMM3D's stfmm3d and
# lfmm3d (charges and dipoles) on the Stokes and laplace_cd_grad cases of the cube at
# matching error (bench/fmm3d_kernels.py).
# KNS: the later sections' points (1e6; quick 1e5); the kernels' rows also at 2e5
if [ "$QUICK" = 1 ]; then KNS="1e5"; KKNS="1e5"; else KNS="1e6"; KKNS="2e5 1e6"; fi
KNS=${BENCH_KNS:-$KNS}; KKNS=${BENCH_KNS:-$KKNS}
echo
echo "== kernels side by side, p = 6, ${OMP_NUM_THREADS} threads (create + evaluate, x laplace_grad)"
KISAS="native"
grep -qw avx512f /proc/cpuinfo 2>/dev/null && KISAS="native avx2"
kbuilt=""
for isa in $KISAS; do
    build_for "$isa" bench/bench_kernels.c "$OUT/bench_kernels_$isa" "kernels/build-$isa" && kbuilt="$kbuilt $isa"
done
if [ -n "$kbuilt" ]; then
    echo "dist             N  p isa     kernel           create    eval   total  x lapg     MiB  x lapg  err(pot/u)  err(grad)    bg%"
    for dist in $DISTS; do
        for n in $KKNS; do
            for isa in $kbuilt; do
                kargs=("$dist" "$n" 6 --sample 300 --repeat 2)
                [ -n "$PY" ] && [ "$dist" = cube ] && [ "$isa" = native ] && kargs+=(--dump "$OUT/stokes_${n}.bin")
                wait_quiet
                if run_measured "$OUT/bench_kernels_$isa" "${kargs[@]}" > "$OUT/.krows"; then
                    sed "/^ /!s/\$/    $BG/" "$OUT/.krows"
                else
                    echo "kernels $dist $n $isa: FAILED"
                    FAILED="$FAILED kernels/$dist/$n/$isa"
                fi
            done
        done
    done
    if [ -n "$PY" ]; then
        for n in $KKNS; do
            [ -f "$OUT/stokes_${n}.bin" ] || continue
            wait_quiet
            if run_measured "$PY" bench/fmm3d_kernels.py "$OUT/stokes_${n}.bin" "$OUT/stokes_${n}.bin.cd" > "$OUT/.fst"; then
                sed "/^#/!s/\$/    $BG/" "$OUT/.fst"
            else
                echo "fmm3d stokes $n: FAILED"
            fi
        done
    fi
fi

# ---------------------------------------------------------------- high accuracy
# laplace_grad at orders 4 to 12 (errors about 1e-4 to 1e-11) on 1M points of
# the cube, a sphere and Plummer's sphere and on 100,000 of the cube, built for
# the machine and, where it has AVX-512, with -mno-avx512f (what an AVX2 machine
# runs); FMM3D (bench/fmm3d_run.py) beside the first build's rows at the
# largest eps whose error is not worse. At 1e5 points, where the operators
# are a fifth of the time at p = 12, a second row per order (isa "+c") reads
# them from opts.operator_cache, written by an unprinted run before it (the
# way a program run again finds them: ExaFMM-T reads its own from a file).
if [ "$QUICK" = 1 ]; then HCASES="cube:1e5"; HORDERS="8 12"; else
    HCASES="cube:1e6 sphere:1e6 plummer:1e6 cube:1e5"; HORDERS="4 6 8 10 12"; fi
HCASES=${BENCH_HCASES:-$HCASES}; HORDERS=${BENCH_HORDERS:-$HORDERS}
echo
echo "== high accuracy: laplace_grad, orders $HORDERS, ${OMP_NUM_THREADS} threads (create + evaluate)"
hbuilt=""
rm -rf "$OUT"/opcache_* # (files of this build only)
for isa in $KISAS; do
    if [ "$isa" = native ]; then hbuilt="$hbuilt native"; continue; fi
    build_for "$isa" bench/bench.c "$OUT/bench_$isa" "high/build-$isa" && hbuilt="$hbuilt $isa"
done
"$OUT/bench" --header | sed '1s/^/isa    /; 1s/$/    bg%/'
[ -n "$PY" ] && "$PY" bench/fmm3d_run.py --header | sed '1s/^/fmm3d  /; 1s/$/    bg%/'
for hc in $HCASES; do
    dist=${hc%%:*}; n=${hc#*:}
    for isa in $hbuilt; do
        prog="$OUT/bench"; [ "$isa" = native ] || prog="$OUT/bench_$isa"
        results=""; data="$OUT/high_${dist}_${n}.bin"
        for p in $HORDERS; do
            res="$OUT/high_${dist}_${n}_p${p}_$isa.txt"
            args=("$dist" "$n" "$p" --sample 500 --result "$res")
            [ "$isa" = native ] && [ -n "$PY" ] && [ -z "$results" ] && args+=(--dump "$data")
            wait_quiet
            rm -f "$res"
            if run_measured "$prog" "${args[@]}" > "$OUT/.row"; then
                printf '%-6s %s    %s\n' "$isa" "$(cat "$OUT/.row")" "$BG"
                results="$results $res"
            else
                echo "$isa $dist $n $p: FAILED"
                FAILED="$FAILED high/$isa/$dist/$n/p$p"
            fi
            if [ "$n" = 1e5 ]; then
                cdir="$OUT/opcache_$isa"; mkdir -p "$cdir"
                "$prog" "$dist" "$n" "$p" --sample 100 --cache "$cdir" > /dev/null
                wait_quiet
                if run_measured "$prog" "$dist" "$n" "$p" --sample 500 --cache "$cdir" > "$OUT/.row"; then
                    printf '%-6s %s    %s\n' "$isa+c" "$(cat "$OUT/.row")" "$BG"
                else
                    echo "$isa+c $dist $n $p: FAILED"
                    FAILED="$FAILED high/$isa+c/$dist/$n/p$p"
                fi
            fi
        done
        if [ "$isa" = native ] && [ -n "$PY" ] && [ -n "$results" ]; then
            wait_quiet
            # shellcheck disable=SC2086
            if run_measured "$PY" bench/fmm3d_run.py "$data" $results > "$OUT/.fmm3d"; then
                grep -v '^#' "$OUT/.fmm3d" | sed "s/^/fmm3d  /; s/\$/    $BG/"
            else
                echo "fmm3d: $dist $n: FAILED"
            fi
        fi
    done
done

# ---------------------------------------------------------------- Helmholtz
# helmholtz_grad against laplace_grad on the same uniform points, a root of 2
# wavelengths (bench/bench_helmholtz.c), and FMM3D's hfmm3d (charges, potential and
# gradient) on them at matching error (bench/fmm3d_kernels.py)
echo
echo "== Helmholtz: helmholtz_grad against laplace_grad, 2 wavelengths across the cube, ${OMP_NUM_THREADS} threads"
# shellcheck disable=SC2086
if $CC -std=c99 -O3 -march=native -fopenmp -Wall -Wextra ${EXTRA_CFLAGS:-} -I. bench/bench_helmholtz.c \
        -o "$OUT/bench_helmholtz" -llapacke -lopenblas -lm; then
    for n in $KNS; do
        for p in 6 8; do
            hargs=("$n" "$p" 2 --sample 300 --repeat 2)
            [ -n "$PY" ] && hargs+=(--dump "$OUT/helmholtz_${n}_${p}.bin")
            wait_quiet
            if run_measured "$OUT/bench_helmholtz" "${hargs[@]}" > "$OUT/.hrows"; then
                sed "/^helm/s/\$/    $BG/" "$OUT/.hrows"
            else
                echo "helmholtz $n p $p: FAILED"
                FAILED="$FAILED helmholtz/$n/$p"
            fi
            if [ -n "$PY" ] && [ -f "$OUT/helmholtz_${n}_${p}.bin" ]; then
                wait_quiet
                if run_measured "$PY" bench/fmm3d_kernels.py "$OUT/helmholtz_${n}_${p}.bin" > "$OUT/.fh"; then
                    sed "/^#/!s/\$/    $BG/" "$OUT/.fh"
                else
                    echo "fmm3d helmholtz $n p $p: FAILED"
                fi
            fi
        done
    done
else
    echo "bench_helmholtz: build failed"
    FAILED="$FAILED helmholtz/build"
fi

# ---------------------------------------------------------------- periodic boundaries
# the same uniform points in the unit cell, free space and periodic (bench/bench_periodic.c)
echo
echo "== periodic boundaries against free space, uniform points, p = 6, ${OMP_NUM_THREADS} threads"
# shellcheck disable=SC2086
if $CC -std=c99 -O3 -march=native -fopenmp -Wall -Wextra ${EXTRA_CFLAGS:-} -I. bench/bench_periodic.c \
        -o "$OUT/bench_periodic" -llapacke -lopenblas -lm; then
    for n in $KNS; do
        wait_quiet
        echo "N = $n"
        if run_measured "$OUT/bench_periodic" "$n" 6 --repeat 3 > "$OUT/.prows"; then
            sed "/^kernel/!s/\$/    $BG/" "$OUT/.prows"
        else
            echo "periodic $n: FAILED"
            FAILED="$FAILED periodic/$n"
        fi
    done
else
    echo "bench_periodic: build failed"
    FAILED="$FAILED periodic/build"
fi

# ---------------------------------------------------------------- time stepping
# update_points against create, handles on one plan, a handle on another's
# tree (bench/bench_update.c), and a step of
# examples/timestep.c (a Plummer sphere, leapfrog) against create + evaluate
if [ "$QUICK" = 1 ]; then UNS="2e5"; TSN="2e5"; TSP=6; else UNS="2e5 1e6"; TSN="1e6"; TSP=8; fi
UNS=${BENCH_UNS:-$UNS}
echo
echo "== time stepping: update_points + evaluate against create + evaluate; shared plans and trees, ${OMP_NUM_THREADS} threads"
# shellcheck disable=SC2086
if $CC -std=c99 -O3 -march=native -fopenmp -Wall -Wextra ${EXTRA_CFLAGS:-} -I. bench/bench_update.c \
        -o "$OUT/bench_update" -llapacke -lopenblas -lm &&
   $CC -std=c99 -O3 -march=native -fopenmp -Wall -Wextra ${EXTRA_CFLAGS:-} -I. examples/timestep.c \
        -o "$OUT/timestep" -llapacke -lopenblas -lm; then
    for n in $UNS; do
        wait_quiet
        if run_measured "$OUT/bench_update" "$n" --repeat 3 > "$OUT/.urows"; then
            sed "/points (the unit cube)\|^kernel /!s/\$/    $BG/" "$OUT/.urows"
        else
            echo "update $n: FAILED"
            FAILED="$FAILED update/$n"
        fi
    done
    wait_quiet
    if run_measured "$OUT/timestep" "$TSN" 3 "$TSP" > "$OUT/.ts"; then
        sed "1s/\$/    $BG/" "$OUT/.ts"
    else
        echo "timestep $TSN: FAILED"
        FAILED="$FAILED timestep/$TSN"
    fi
else
    echo "bench_update or timestep: build failed"
    FAILED="$FAILED update/build"
fi

# ---------------------------------------------------------------- near-field hooks
# bench/bench_p2p.c: each hook's pairs per second against the generic loop, one
# thread, built for the machine and, where it has AVX-512, with -mno-avx512f
echo
echo "== near-field hooks, one thread (bench/bench_p2p.c)"
for isa in $KISAS; do
    kflags=""
    [ "$isa" = avx2 ] && kflags="-mno-avx512f"
    echo "build:       $CC -std=c99 -O2 -march=native $kflags bench/bench_p2p.c -> bench_p2p_$isa"
    # shellcheck disable=SC2086
    if $CC -std=c99 -O2 -march=native $kflags -Wall -Wextra -I. bench/bench_p2p.c \
            -o "$OUT/bench_p2p_$isa" -lm; then
        wait_quiet
        if ! run_measured "$OUT/bench_p2p_$isa" "$([ "$QUICK" = 1 ] && echo 0.05 || echo 0.2)"; then
            FAILED="$FAILED p2p/$isa"
        fi
    else
        echo "bench_p2p ($isa): build failed"
        FAILED="$FAILED p2p/build-$isa"
    fi
done

# ---------------------------------------------------------------- the compiled library
# libkifmm (make lib: every level, src/kifmm_dispatch.c) against the same kernels
# compiled here from the headers, in one process on the same points
# (bench/bench_dispatch.c): the level the CPU gets against -march=native and, on an
# AVX-512 machine, KIFMM_ISA=avx2 against -mno-avx512f (what an AVX2 machine runs).
echo
echo "== the compiled library's levels against header builds, N = $KNS, p = 6, ${OMP_NUM_THREADS} threads"
if make --no-print-directory -j2 lib > "$OUT/.lib.log" 2>&1; then
    LIBSO=$(ls -t build/lib/libkifmm.so.*.*.* | head -1)
    for isa in $KISAS; do
        kflags=""; envs=()
        [ "$isa" = avx2 ] && kflags="-mno-avx512f" && envs=(KIFMM_ISA=avx2)
        echo "build:       $CC -std=c99 -O3 -march=native $kflags -fopenmp bench/bench_dispatch.c $LIBSO; run with ${envs[*]:-no KIFMM_ISA}"
        # shellcheck disable=SC2086
        if $CC -std=c99 -O3 -march=native $kflags -fopenmp -Wall -Wextra ${EXTRA_CFLAGS:-} -I. \
                bench/bench_dispatch.c -o "$OUT/bench_dispatch_$isa" "$LIBSO" -Wl,-rpath,"$(pwd)/build/lib" \
                -llapacke -lopenblas -lm; then
            wait_quiet
            if run_measured env ${envs[@]+"${envs[@]}"} "$OUT/bench_dispatch_$isa" "$KNS" 6; then
                echo "(bg% $BG)"
            else
                FAILED="$FAILED dispatch/$isa"
            fi
        else
            echo "bench_dispatch ($isa): build failed"
            FAILED="$FAILED dispatch/build-$isa"
        fi
    done
else
    echo "make lib failed:"; tail -5 "$OUT/.lib.log"
    FAILED="$FAILED dispatch/lib"
fi

# ---------------------------------------------------------------- MPI
# MPI mode (bench/bench_mpi.c): balance and bytes a rank on 1M points (4
# ranks Plummer, clustered and hotspot (uniform sources, targets in a small
# cube); 2, 4, 8 ranks uniform), and weak scaling (1M uniform
# points a rank, 1 to 16 ranks, as many as MPI_RANKS lists), one thread a
# rank, oversubscribed where the cores are fewer; skipped without mpicc.
echo
echo "== MPI mode: balance, bytes a rank, weak scaling (laplace_grad, p = 6, one thread a rank)"
if command -v mpicc > /dev/null 2>&1 && command -v mpirun > /dev/null 2>&1; then
    MPIRUN=(mpirun --oversubscribe --bind-to none)
    [ "$(id -u)" = 0 ] && MPIRUN+=(--allow-run-as-root)
    if [ "$QUICK" = 1 ]; then MPN=200000; MR="1 2 4"; elif [ "$NCPU" -ge 16 ]; then MPN=1000000; MR="1 2 4 8 16"; else MPN=1000000; MR="1 2 4 8"; fi
    MRANKS=${MPI_RANKS:-$MR}
    # shellcheck disable=SC2086
    if mpicc -std=c99 -O3 -march=native -fopenmp -Wall -Wextra ${EXTRA_CFLAGS:-} -I. bench/bench_mpi.c \
            -o "$OUT/bench_mpi" -llapacke -lopenblas -lm; then
        export OMPI_MCA_mpi_yield_when_idle=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
        wait_quiet
        for d in plummer clustered hotspot; do
            OMP_NUM_THREADS=1 "${MPIRUN[@]}" -np 4 "$OUT/bench_mpi" fixed "$MPN" "$d" || FAILED="$FAILED mpi/$d"
        done
        for np in 2 4 8; do
            OMP_NUM_THREADS=1 "${MPIRUN[@]}" -np "$np" "$OUT/bench_mpi" fixed "$MPN" cube | head -1 ||
                FAILED="$FAILED mpi/cube$np"
        done
        for np in $MRANKS; do
            OMP_NUM_THREADS=1 "${MPIRUN[@]}" -np "$np" "$OUT/bench_mpi" weak "$MPN" || FAILED="$FAILED mpi/weak$np"
        done
    else
        echo "bench_mpi: build failed"
        FAILED="$FAILED mpi/build"
    fi
else
    echo "skipped: no mpicc or mpirun (apt-get install libopenmpi-dev openmpi-bin)"
fi

# ---------------------------------------------------------------- FMM3D table
if [ -n "$PY" ]; then
    echo
    echo "== FMM3D (fmm3dpy.lfmm3d, pg=2, sources = targets, OMP_NUM_THREADS=${OMP_NUM_THREADS}) on the same points and charges"
    "$PY" bench/fmm3d_run.py --header | sed '1s/$/    bg%/' | { read -r h; cat; echo "$h"; }
    [ -f "$OUT/fmm3d_rows.txt" ] && grep -v '^#' "$OUT/fmm3d_rows.txt"
    grep '^#' "$OUT/fmm3d_rows.txt" 2>/dev/null | sort -u
else
    echo
    echo "== FMM3D: ${FMM3D_NOTE}"
fi
echo
echo "load:        $(cut -d' ' -f1-3 /proc/loadavg) (1, 5, 15 min) at the end"
if [ -n "$FAILED" ]; then
    echo "failed cases:$FAILED"
    exit 1
fi
