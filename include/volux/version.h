/*
 * volux/version.h — the library's version, at compile time (the macros) and
 * at run time (volux_version()), and what the numbers promise.
 *
 * This header is the one source of the version: CMakeLists.txt reads the
 * three numbers below for the project version, the shared library's file
 * name and its SONAME, volux.pc and the CMake package's version file.
 *
 * Compatibility (docs/API.md, "Stability and deprecation"):
 *   - 0.MINOR.PATCH (today): the API is still settling. A PATCH release keeps
 *     the ABI; a MINOR release may change it, so the SONAME carries both
 *     numbers (libvolux.so.0.1) and a program linked against 0.1 never loads
 *     0.2 by accident.
 *   - From 1.0 on: the SONAME is libvolux.so.MAJOR; MINOR releases only add.
 *   - A function to be removed is first marked VOLUX_DEPRECATED for at least
 *     one MINOR release; abi/volux.symbols (checked by ctest) lists every
 *     exported symbol, so an accidental export or removal fails the tests.
 *
 * DOES NOT: gate features by version; every exported function exists in
 * every build of this version.
 *
 * STEP BY STEP
 *     if (volux_version_number() / 100 != VOLUX_VERSION_NUMBER / 100)
 *         fprintf(stderr, "built against volux %s, running %s\n",
 *                 VOLUX_VERSION, volux_version());
 */
#ifndef VOLUX_VERSION_H
#define VOLUX_VERSION_H

#include "base.h"

#define VOLUX_VERSION_MAJOR 0
#define VOLUX_VERSION_MINOR 2
#define VOLUX_VERSION_PATCH 0
#define VOLUX_VERSION "0.2.0"
/* MAJOR·10000 + MINOR·100 + PATCH, for #if tests. */
#define VOLUX_VERSION_NUMBER (VOLUX_VERSION_MAJOR * 10000 + VOLUX_VERSION_MINOR * 100 + VOLUX_VERSION_PATCH)

#if defined(__GNUC__)
#define VOLUX_DEPRECATED(msg) __attribute__((deprecated(msg)))
#else
#define VOLUX_DEPRECATED(msg)
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* The version of the library actually loaded ("0.2.0"), which may differ
 * from VOLUX_VERSION (the headers a program was compiled with) when a
 * shared library was upgraded. Static string; never NULL; thread-safe. */
VOLUX_API const char *volux_version(void);
/* The same as a number: MAJOR·10000 + MINOR·100 + PATCH. */
VOLUX_API int volux_version_number(void);

#ifdef __cplusplus
}
#endif
#endif
