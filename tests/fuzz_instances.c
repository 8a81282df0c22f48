/* fuzz_instances.c - one half of the fuzz target's instances (FUZZ_PART 1 or
 * 2, tests/fuzz_instances.h); tests/fuzz.sh compiles it twice. */
#ifndef FUZZ_PART
#error "fuzz_instances.c: compile with -DFUZZ_PART=1 or -DFUZZ_PART=2"
#endif
#include "fuzz_instances.h"
