/* Force-included (.cargo/config.toml: CXXFLAGS) into the C++ that the `lsl` crate builds: the
 * liblsl 1.13 inside lsl-sys 0.1 bundles a Boost.Thread that tests `#if PTHREAD_STACK_MIN > 0`,
 * and glibc 2.34 and newer (Debian 12) define PTHREAD_STACK_MIN as a sysconf() call, which the
 * preprocessor cannot evaluate. Here it is the constant glibc had before (16 KiB), the least
 * stack a thread may ask for; no other C++ in the build tests it. */
#ifndef VLF_LSL_GLIBC_COMPAT_H
#define VLF_LSL_GLIBC_COMPAT_H
#include <limits.h>
#ifdef PTHREAD_STACK_MIN
#undef PTHREAD_STACK_MIN
#define PTHREAD_STACK_MIN 16384
#endif
#endif
