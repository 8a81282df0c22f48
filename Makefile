# kifmm.h: examples, test suite and build dependencies.
#
#   make run        build and run examples/laplace.c (1M points, order 6;
#                   other sizes: make run ARGS="200000 8")
#   make test       build and run the test suite (seven configurations; CONFIGS=all for fourteen)
#                   (tests/run.sh: gcc and clang, C99 and C11, with and
#                   without OpenMP, a sanitizer build and a build without -march)
#   make custom     build and run examples/custom_kernel.c (a kernel written in
#                   the example file, checked against direct summation)
#   make double_layer  build and run examples/double_layer.c (the Laplace
#                   double layer of a unit density on a sphere: -1 inside, -1/2 on, 0 outside)
#   make examples   build the examples into build/
#   make deps       check the compilers, OpenMP and BLAS/LAPACKE headers;
#                   installs the Debian packages when run as root
#   make clean      remove build/
#
# On machines where OpenBLAS misdetects the CPU, set OPENBLAS_CORETYPE
# (e.g. make run OPENBLAS_CORETYPE=Haswell).

CC ?= cc
BUILD := build
ARGS ?=
EXAMPLE_CFLAGS := -std=c99 -O2 -march=native -fopenmp -Wall -Wextra -pedantic
LDLIBS := -llapacke -lopenblas -lm

APT_INSTALL := apt-get update && apt-get install -y libopenblas-dev liblapacke-dev clang libomp-dev

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

.PHONY: all run custom double_layer test examples deps clean

all: examples

# The dependency check.  Each item is checked by asking the compiler itself,
# so the multiarch include directory is never hard-coded.
define DEPS_CHECK
missing=""; \
for c in gcc clang; do \
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

examples: $(BUILD)/laplace $(BUILD)/custom_kernel $(BUILD)/double_layer

# a user-defined kernel (examples/custom_kernel.c), checked against direct sums
custom: deps
	@$(MAKE) --no-print-directory examples
	./$(BUILD)/custom_kernel $(ARGS)

# the double-layer identity on a sphere with the laplace_dipole kernel
double_layer: deps
	@$(MAKE) --no-print-directory examples
	./$(BUILD)/double_layer $(ARGS)

run: deps
	@$(MAKE) --no-print-directory examples
	./$(BUILD)/laplace $(ARGS)

test: deps
	EXTRA_CFLAGS="$(CBLAS_CFLAGS)" CONFIGS="$(CONFIGS)" bash tests/run.sh
	@$(MAKE) --no-print-directory examples
	./$(BUILD)/custom_kernel 20000 6
	./$(BUILD)/double_layer 64 6

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
