# kifmm.h: examples, test suite and build dependencies.
#
#   make run        build and run examples/laplace.c (1M points, order 6;
#                   other sizes: make run ARGS="200000 8")
#   make test       build and run the test suite (five configurations; CONFIGS=all for fifteen)
#                   (tests/run.sh: gcc and clang, C99 and C11, with and
#                   without OpenMP, sanitizer builds, a build without -march), the examples,
#                   tests/install.sh (make install into a temporary prefix,
#                   pkg-config and CMake hosts), tests/python.sh (the Python
#                   package in build/pyvenv, pytest) and tests/mpi.sh (MPI mode
#                   on 1 to 4 ranks; skipped without mpicc)
#   make custom     build and run examples/custom_kernel.c (a kernel written in
#                   the example file, checked against direct summation)
#   make timestep   build and run examples/timestep.c (a Plummer sphere stepped
#                   with leapfrog, update_points + evaluate per step; ARGS="N steps order")
#   make double_layer  build and run examples/double_layer.c (the Laplace
#                   double layer of a unit density on a sphere: -1 inside, -1/2 on, 0 outside;
#                   the single layer on the same tree: 1 inside, 1/|x| outside)
#   make mpi_nbody  build (mpicc) and run examples/mpi_nbody.c on NP ranks (default
#                   4, oversubscribed): the Plummer sphere stepped on MPI ranks
#                   (KIFMM_MPI, create_mpi); ARGS="N steps order"
#   make examples   build the examples into build/
#   make deps       check the compilers, OpenMP and BLAS/LAPACKE headers;
#                   installs the Debian packages when run as root
#   make lib        build/lib/libkifmm.a and libkifmm.so: every shipped kernel
#                   in double and float (kifmm_lib.h, src/kifmm_lib.c), for
#                   three instruction-set levels chosen at run time from the
#                   CPU (src/kifmm_dispatch.c; KIFMM_ISA; LIB_LEVELS below)
#   make wheel      build/wheelhouse/kifmm-*.whl: the Python package with that
#                   library and OpenBLAS, LAPACKE and OpenMP inside, for any
#                   x86-64 machine with the glibc its tag names
#                   (python/build_wheel.sh; tools from PyPI)
#   make lib-mpi    build/lib/libkifmm_mpi.so: the same instances with KIFMM_MPI,
#                   one level for this machine (LIB_MPI_CFLAGS; mpicc;
#                   create_mpi for every kernel), linked to MPI; the Python
#                   package's comm= loads it
#   make install    PREFIX=/usr/local (DESTDIR for staging): kifmm.h,
#                   kifmm_kernels.h, kifmm_lib.h, libkifmm, kifmm.pc and the
#                   CMake package (find_package(kifmm): kifmm::kifmm,
#                   kifmm::headers); the library runs on any x86-64 machine
#                   (LIB_LEVELS=base LIB_CFLAGS="-O2 -march=native -fopenmp":
#                   one level, for this machine only)
#   make uninstall  the same PREFIX and DESTDIR: removes what install put there
#   make fuzz       build tests/fuzz_create.c (clang libFuzzer, ASan, UBSan) and
#                   fuzz the API for FUZZ_TIME seconds (default 300; make test
#                   runs 60 from seed 1, so that a run repeats; make fuzz
#                   takes a fresh seed each time) from tests/fuzz_corpus/
#                   (tests/fuzz.sh)
#   make bench-tol  the errors of every output per order behind opts.tol's
#                   tables (bench/bench_tol.c; KERNELS="..." for some)
#   make clean      remove build/
#
# On machines where OpenBLAS misdetects the CPU, set OPENBLAS_CORETYPE
# (e.g. make run OPENBLAS_CORETYPE=Haswell).

CC ?= cc
BUILD := build
ARGS ?=
EXAMPLE_CFLAGS := -std=c99 -O2 -march=native -fopenmp -Wall -Wextra -pedantic
LDLIBS := -llapacke -lopenblas -lm

APT_INSTALL := apt-get update && apt-get install -y libopenblas-dev liblapacke-dev clang libclang-rt-dev libomp-dev cmake pkg-config python3-venv

# cblas.h is found by the compiler's default search path on Debian (it sits in
# /usr/include/<multiarch>/ or /usr/include/); only if it is not, look for it
# under the multiarch directory and add that directory to the include path.
CBLAS_CFLAGS := $(shell \
  if printf '\043include <cblas.h>\n' | $(CC) -E -x c - >/dev/null 2>&1; then :; else \
    d=$$(ls -d /usr/include/$$($(CC) -print-multiarch 2>/dev/null)/cblas.h \
               /usr/include/$$($(CC) -print-multiarch 2>/dev/null)/*/cblas.h 2>/dev/null \
         | head -n 1); \
    [ -n "$$d" ] && echo "-I$$(dirname $$d)"; \
  fi)

.PHONY: all run custom double_layer timestep mpi_nbody test examples deps clean lib install uninstall

all: examples

# The dependency check.  Each item is checked by asking the compiler itself,
# so the multiarch include directory is never hard-coded.
define DEPS_CHECK
missing=""; \
for c in gcc clang cmake pkg-config; do \
  command -v $$c >/dev/null 2>&1 || missing="$$missing $$c"; \
done; \
if command -v gcc >/dev/null 2>&1; then \
  for h in cblas.h lapacke.h; do \
    p=$$(printf '\043include <%s>\n' $$h | gcc $(CBLAS_CFLAGS) -M -x c - 2>/dev/null \
         | tr ' \\' '\n\n' | grep "/$$h\$$" | head -n 1); \
    if [ -n "$$p" ]; then echo "deps: $$h: $$p"; else missing="$$missing $$h"; fi; \
  done; \
  printf 'int main(void){return 0;}\n' | gcc -x c - -o /dev/null $(LDLIBS) >/dev/null 2>&1 \
    || missing="$$missing libopenblas/liblapacke"; \
  printf '\043include <omp.h>\nint main(void){return omp_get_max_threads() < 1;}\n' \
    | gcc -fopenmp -x c - -o /dev/null >/dev/null 2>&1 || missing="$$missing omp.h(gcc)"; \
fi; \
if command -v clang >/dev/null 2>&1; then \
  printf '\043include <omp.h>\nint main(void){return omp_get_max_threads() < 1;}\n' \
    | clang -fopenmp -x c - -o /dev/null >/dev/null 2>&1 || missing="$$missing omp.h(clang)"; \
  printf 'int LLVMFuzzerTestOneInput(const unsigned char *d, unsigned long n){(void)d;(void)n;return 0;}\n' \
    | clang -fsanitize=fuzzer -x c - -o /dev/null >/dev/null 2>&1 || missing="$$missing libclang_rt.fuzzer"; \
fi
endef

deps:
	@$(DEPS_CHECK); \
	if [ -z "$$missing" ]; then echo "deps: ok"; exit 0; fi; \
	echo "deps: missing:$$missing"; \
	if [ "$$(id -u)" != 0 ]; then \
	  echo "deps: install them as root with:"; \
	  echo "$(APT_INSTALL)"; \
	  exit 1; \
	fi; \
	echo "deps: $(APT_INSTALL)"; \
	$(APT_INSTALL) || exit 1; \
	$(DEPS_CHECK); \
	if [ -n "$$missing" ]; then echo "deps: still missing:$$missing"; exit 1; fi; \
	echo "deps: ok"

$(BUILD)/laplace: examples/laplace.c kifmm.h kifmm_kernels.h | $(BUILD)
	$(CC) $(EXAMPLE_CFLAGS) $(CBLAS_CFLAGS) -I. $< -o $@ $(LDLIBS)

$(BUILD):
	mkdir -p $@

$(BUILD)/custom_kernel: examples/custom_kernel.c kifmm.h kifmm_kernels.h | $(BUILD)
	$(CC) $(EXAMPLE_CFLAGS) $(CBLAS_CFLAGS) -I. $< -o $@ $(LDLIBS)

$(BUILD)/double_layer: examples/double_layer.c kifmm.h kifmm_kernels.h | $(BUILD)
	$(CC) $(EXAMPLE_CFLAGS) $(CBLAS_CFLAGS) -I. $< -o $@ $(LDLIBS)

$(BUILD)/timestep: examples/timestep.c kifmm.h kifmm_kernels.h | $(BUILD)
	$(CC) $(EXAMPLE_CFLAGS) $(CBLAS_CFLAGS) -I. $< -o $@ $(LDLIBS)

examples: $(BUILD)/laplace $(BUILD)/custom_kernel $(BUILD)/double_layer $(BUILD)/timestep

# MPI mode (KIFMM_MPI): built with mpicc, run with mpirun (as root
# --allow-run-as-root); NP ranks, oversubscribed where the cores are fewer
MPICC ?= mpicc
NP ?= 4
MPIRUN := mpirun --oversubscribe --bind-to none $(if $(filter 0,$(shell id -u)),--allow-run-as-root,)
$(BUILD)/mpi_nbody: examples/mpi_nbody.c kifmm.h kifmm_kernels.h | $(BUILD)
	$(MPICC) $(EXAMPLE_CFLAGS) $(CBLAS_CFLAGS) -I. $< -o $@ $(LDLIBS)

mpi_nbody: deps $(BUILD)/mpi_nbody
	$(MPIRUN) -np $(NP) ./$(BUILD)/mpi_nbody $(ARGS)

# a user-defined kernel (examples/custom_kernel.c), checked against direct sums
custom: deps
	@$(MAKE) --no-print-directory examples
	./$(BUILD)/custom_kernel $(ARGS)

# the double- and single-layer identities on a sphere (laplace_dipole, and
# laplace_grad on its tree)
double_layer: deps
	@$(MAKE) --no-print-directory examples
	./$(BUILD)/double_layer $(ARGS)

# a Plummer sphere stepped with leapfrog: update_points + evaluate per step
timestep: deps
	@$(MAKE) --no-print-directory examples
	./$(BUILD)/timestep $(ARGS)

run: deps
	@$(MAKE) --no-print-directory examples
	./$(BUILD)/laplace $(ARGS)

test: deps
	EXTRA_CFLAGS="$(CBLAS_CFLAGS)" CONFIGS="$(CONFIGS)" bash tests/run.sh
	@$(MAKE) --no-print-directory examples
	./$(BUILD)/custom_kernel 20000 6
	./$(BUILD)/double_layer 64 6
	./$(BUILD)/timestep 20000 3 6
	bash tests/install.sh
	bash tests/python.sh
	EXTRA_CFLAGS="$(CBLAS_CFLAGS)" CONFIGS="$(CONFIGS)" bash tests/mpi.sh
	FUZZ_TIME=60 FUZZ_SEED=1 EXTRA_CFLAGS="$(CBLAS_CFLAGS)" bash tests/fuzz.sh

# the libFuzzer target (tests/fuzz.sh: build, corpus copy in build/fuzz/)
FUZZ_TIME ?= 300
.PHONY: fuzz
fuzz:
	FUZZ_TIME=$(FUZZ_TIME) FUZZ_KEEP=$(FUZZ_KEEP) EXTRA_CFLAGS="$(CBLAS_CFLAGS)" bash tests/fuzz.sh

# ---- the compiled library and its installation
PREFIX ?= /usr/local
DESTDIR ?=
LIB_CFLAGS ?= -fopenmp
LIB_MPI_CFLAGS ?= -O2 -march=native -fopenmp
VERSION := $(shell awk '/define KIFMM_VERSION_MAJOR/{a=$$3} /define KIFMM_VERSION_MINOR/{b=$$3} \
                        /define KIFMM_VERSION_PATCH/{c=$$3} END{print a "." b "." c}' kifmm.h)
MAJOR := $(firstword $(subst ., ,$(VERSION)))
LIBDIR := $(PREFIX)/lib
INCDIR := $(PREFIX)/include
SONAME := libkifmm.so.$(MAJOR)
NM ?= nm
OBJCOPY ?= objcopy

# The instruction-set levels libkifmm holds (src/kifmm_dispatch.c picks one
# at the first call): avx512 (x86-64-v4), avx2 (x86-64-v3) and base (the
# compiler's default target: SSE2 with Debian's gcc, more where a
# distribution sets a newer default); LIB_LEVELS=base and -march=native in
# LIB_CFLAGS for one level built for this machine only.
ifneq ($(filter x86_64-%,$(shell $(CC) -dumpmachine 2>/dev/null)),)
LIB_LEVELS ?= avx512 avx2 base
else
LIB_LEVELS ?= base
endif
ifneq ($(filter-out avx512 avx2 base,$(LIB_LEVELS)),)
$(error LIB_LEVELS: $(filter-out avx512 avx2 base,$(LIB_LEVELS)) is not a level (avx512, avx2, base))
endif
# each level's own flags, before LIB_CFLAGS (which may override them): -O3
# is 7-18 % faster than -O2 at 1M points (bench/bench_dispatch.c) and takes
# 1.45x as long to compile; the base level, a fallback, keeps -O2
LIB_OPT_avx512 := -O3 -march=x86-64-v4
LIB_OPT_avx2 := -O3 -march=x86-64-v3
LIB_OPT_base := -O2

# Each level's double and float halves are two objects (make -j2 builds two
# at once: kifmm_lib.h, KIFMM_LIB_PART) whose public symbols kifmm_<name>
# are renamed kifmm__<level>_kifmm_<name>; kifmm_dispatch.o defines the
# public ones.
LIB_LV_OBJS := $(foreach l,$(LIB_LEVELS),$(BUILD)/lib/lv_$(l)_1.o $(BUILD)/lib/lv_$(l)_2.o)
LIB_OBJS := $(LIB_LV_OBJS) $(BUILD)/lib/kifmm_dispatch.o
# build/lib/flags holds the compiler, levels and flags of the objects there
# and changes (so that they are compiled again) only when these do
LIB_FLAGS_NOW := $(CC) | $(LIB_LEVELS) | $(foreach l,$(LIB_LEVELS),$(LIB_OPT_$(l)) |) $(LIB_CFLAGS) | $(CBLAS_CFLAGS)
$(BUILD)/lib/flags: FORCE
	@mkdir -p $(@D)
	@if [ "$$(cat $@ 2>/dev/null)" != '$(LIB_FLAGS_NOW)' ]; then echo '$(LIB_FLAGS_NOW)' > $@; fi
.PHONY: FORCE
FORCE:

$(BUILD)/lib/lv_%.o: src/kifmm_lib.c kifmm_lib.h kifmm.h kifmm_kernels.h $(BUILD)/lib/flags
	$(CC) -std=c99 $(LIB_OPT_$(firstword $(subst _, ,$*))) $(LIB_CFLAGS) -fPIC -Wall -Wextra \
	    -pedantic $(CBLAS_CFLAGS) -I. -DKIFMM_LIB_PART=$(lastword $(subst _, ,$*)) -c $< -o $@.tmp
	$(NM) -g --defined-only $@.tmp > $@.nm
	awk '$$3 ~ /^kifmm_/ {print $$3, "kifmm__$(firstword $(subst _, ,$*))_" $$3}' $@.nm > $@.syms
	$(OBJCOPY) --redefine-syms=$@.syms $@.tmp $@
	rm -f $@.tmp $@.nm $@.syms

$(BUILD)/lib/kifmm_dispatch.o: src/kifmm_dispatch.c kifmm_lib.h kifmm.h kifmm_kernels.h $(BUILD)/lib/flags
	$(CC) -std=c99 -O2 $(LIB_CFLAGS) -pthread -fPIC -Wall -Wextra -pedantic -I. \
	    $(foreach l,$(LIB_LEVELS),-DKIFMM_LIB_HAS_$(shell echo $(l) | tr a-z A-Z)) -c $< -o $@

$(BUILD)/lib/libkifmm.a: $(LIB_OBJS)
	rm -f $@
	ar rcs $@ $^

# the shared library exports kifmm_<name> only (src/kifmm.map), and each
# level's every symbol must have its public wrapper (the check below)
$(BUILD)/lib/libkifmm.so.$(VERSION): $(LIB_OBJS) src/kifmm.map
	$(CC) -shared -Wl,-soname,$(SONAME) -Wl,--version-script=src/kifmm.map $(LIB_CFLAGS) -pthread \
	    $(LIB_OBJS) -o $@ $(LDLIBS)
	@$(NM) -g --defined-only $(LIB_LV_OBJS) | awk '$$3 ~ /^kifmm__/ {sub(/^kifmm__[a-z0-9]*_/, "", $$3); print $$3}' \
	    | sort -u > $@.want; \
	$(NM) -D --defined-only $@ | awk '$$3 ~ /^kifmm/ {print $$3}' | sort -u > $@.have; \
	if ! cmp -s $@.want $@.have; then echo "libkifmm: the levels' symbols and the exported ones differ:"; \
	    diff $@.want $@.have | head; rm -f $@ $@.want $@.have; exit 1; fi; rm -f $@.want $@.have

# (and the soname's link, for programs linked to build/lib/libkifmm.so.* that
# run from there: bench/run.sh)
lib: $(BUILD)/lib/libkifmm.a $(BUILD)/lib/libkifmm.so.$(VERSION)
	@ln -sf libkifmm.so.$(VERSION) $(BUILD)/lib/$(SONAME)

MPICC ?= mpicc
LIB_MPI_OBJS := $(BUILD)/lib/kifmm_mpi_1.o $(BUILD)/lib/kifmm_mpi_2.o
$(BUILD)/lib/kifmm_mpi_%.o: src/kifmm_lib.c kifmm_lib.h kifmm.h kifmm_kernels.h
	mkdir -p $(BUILD)/lib
	$(MPICC) -std=c99 -DKIFMM_MPI $(LIB_MPI_CFLAGS) -fPIC -Wall -Wextra -pedantic $(CBLAS_CFLAGS) -I. \
	    -DKIFMM_LIB_PART=$* -c $< -o $@

$(BUILD)/lib/libkifmm_mpi.so: $(LIB_MPI_OBJS)
	$(MPICC) -shared $(LIB_MPI_CFLAGS) $^ -o $@ $(LDLIBS)

.PHONY: lib-mpi
lib-mpi: $(BUILD)/lib/libkifmm_mpi.so

.PHONY: wheel
wheel:
	bash python/build_wheel.sh

install: lib
	install -d $(DESTDIR)$(INCDIR) $(DESTDIR)$(LIBDIR)/pkgconfig $(DESTDIR)$(LIBDIR)/cmake/kifmm
	install -m 644 kifmm.h kifmm_kernels.h kifmm_lib.h $(DESTDIR)$(INCDIR)/
	install -m 644 $(BUILD)/lib/libkifmm.a $(DESTDIR)$(LIBDIR)/
	install -m 755 $(BUILD)/lib/libkifmm.so.$(VERSION) $(DESTDIR)$(LIBDIR)/
	ln -sf libkifmm.so.$(VERSION) $(DESTDIR)$(LIBDIR)/$(SONAME)
	ln -sf $(SONAME) $(DESTDIR)$(LIBDIR)/libkifmm.so
	sed -e 's|@PREFIX@|$(PREFIX)|' -e 's|@VERSION@|$(VERSION)|' cmake/kifmm.pc.in \
	    > $(DESTDIR)$(LIBDIR)/pkgconfig/kifmm.pc
	install -m 644 cmake/kifmmConfig.cmake $(DESTDIR)$(LIBDIR)/cmake/kifmm/
	sed -e 's|@VERSION@|$(VERSION)|' -e 's|@MAJOR@|$(MAJOR)|' cmake/kifmmConfigVersion.cmake.in \
	    > $(DESTDIR)$(LIBDIR)/cmake/kifmm/kifmmConfigVersion.cmake
	@if [ -z "$(DESTDIR)" ] && [ "$$(id -u)" = 0 ] && command -v ldconfig >/dev/null 2>&1; then \
	    ldconfig; fi

uninstall:
	rm -f $(addprefix $(DESTDIR)$(INCDIR)/,kifmm.h kifmm_kernels.h kifmm_lib.h)
	rm -f $(addprefix $(DESTDIR)$(LIBDIR)/,libkifmm.a libkifmm.so $(SONAME) libkifmm.so.$(VERSION))
	rm -f $(DESTDIR)$(LIBDIR)/pkgconfig/kifmm.pc
	rm -f $(addprefix $(DESTDIR)$(LIBDIR)/cmake/kifmm/,kifmmConfig.cmake kifmmConfigVersion.cmake)
	-rmdir $(DESTDIR)$(LIBDIR)/cmake/kifmm 2>/dev/null

clean:
	rm -rf $(BUILD)

# Benchmark (bench/run.sh; outputs in build/bench/): cube, sphere and clustered
# points x N = 1e4, 1e5, 1e6 x order 4, 6, 8, with FMM3D (fmm3dpy) beside it.
#   make bench BIG=1     adds N = 1e7
#   make bench P="10"    adds orders
#   make bench-quick     cube, N = 1e4 and 1e5, order 6
.PHONY: bench bench-quick
bench:
	BIG="$(BIG)" P="$(P)" CC="$(CC)" EXTRA_CFLAGS="$(CBLAS_CFLAGS)" bash bench/run.sh

bench-quick:
	CC="$(CC)" EXTRA_CFLAGS="$(CBLAS_CFLAGS)" bash bench/run.sh --quick

# estimate_bytes against the memory handles hold: docs/api.md's "Memory"
# table (about 6 minutes on 2 cores; bench-memory Q=1: --quick)
.PHONY: bench-memory
bench-memory:
	@mkdir -p $(BUILD)/bench
	$(CC) $(EXAMPLE_CFLAGS) $(CBLAS_CFLAGS) -I. bench/bench_memory.c -o $(BUILD)/bench/bench_memory $(LDLIBS)
	$(BUILD)/bench/bench_memory $(if $(Q),--quick,)

# opts.tol's tables (bench/bench_tol.c): every output's error per order at
# 20,000 points (two seeds) and 200,000 (one), cube, sphere and clustered,
# and the Helmholtz kernels' per order and width; KERNELS="laplace_hess
# stokes_grad" for some (about 90 minutes for all but the Helmholtz kernels;
# theirs at 20,000 points took 33 minutes for helmholtz_grad, two seeds, and
# 10 for helmholtz_cd_grad, one seed; at 200,000 points helmholtz_grad's
# orders 3 to 10 took over an hour)
.PHONY: bench-tol
bench-tol:
	@mkdir -p $(BUILD)/bench
	$(CC) $(EXAMPLE_CFLAGS) $(CBLAS_CFLAGS) -I. bench/bench_tol.c -o $(BUILD)/bench/bench_tol $(LDLIBS)
	$(BUILD)/bench/bench_tol -n 20000 -s 2 $(foreach k,$(KERNELS),-k $(k))
	$(BUILD)/bench/bench_tol -n 200000 -s 1 -p 3 12 $(foreach k,$(KERNELS),-k $(k))
