/* What every tiltload C file needs to build the same FMU on any platform with any compiler's default
   flags (`cc -shared *.c -lm` included): included first, before the system headers, by every source.

   Floating point: no contraction of a * b + c into a fused multiply-add. GCC fuses by default
   (-ffp-contract=fast outside the ISO modes) wherever the target has FMA: always on aarch64, in an
   x86-64-v3 function clone, with -march=native. Fused and unfused results differ in the last bits,
   and an estimator fed constant measurements amplifies that (the UAV-alone controller drifted by
   0.08 in 2 s on aarch64). With contraction off, the arithmetic is IEEE double operations in source
   order on every target. GCC ignores (and warns about) the standard pragma and has its own; clang
   honours the standard one unless -ffp-contract=fast is given on its command line (do not).

   Symbols: an FMU exports the fmi2 functions only (fmi2Functions.h marks them). Everything shared
   between our files is TL_INTERNAL: hidden on ELF and Mach-O, so a build without -fvisibility=hidden
   or an export map exports nothing else; on Windows a DLL exports only what is marked dllexport.
   An importer that loads FMUs into the global symbol scope (RTLD_GLOBAL) would otherwise bind one
   tiltload FMU's hooks to another's. -DTL_INTERNAL= exports them (tests driving tl_zse.c through
   ctypes).

   Language: C99. TL_STATIC_ASSERT is C11's _Static_assert where there is one. */
#ifndef TL_PLATFORM_H
#define TL_PLATFORM_H

#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#elif defined(_MSC_VER)
#pragma fp_contract(off)
#else
#pragma STDC FP_CONTRACT OFF
#endif

#ifndef TL_INTERNAL
#if defined(__GNUC__) && !defined(_WIN32) && !defined(__CYGWIN__)
#define TL_INTERNAL __attribute__((visibility("hidden")))
#else
#define TL_INTERNAL
#endif
#endif

#if defined(__STDC_VERSION__) && __STDC_VERSION__ >= 201112L
#define TL_STATIC_ASSERT(condition, why) _Static_assert(condition, why)
#else /* a negative array size stops the build; repeating an extern declaration is allowed */
#define TL_STATIC_ASSERT(condition, why) extern char tl_static_assertion[(condition) ? 1 : -1]
#endif

#endif
