/*
 * techniques/ambient/builtin.c — the preintegration table built into the
 * library (volux_ambient_table_desc_builtin: 64 × 64 × 10 entries for the
 * albedo set), so that the technique's default never waits for a build.
 *
 * The bytes are the file src/techniques/ambient/builtin_table.vxat, made by
 * `volux ambient-table --builtin -o builtin_table.vxat` (the exact command
 * and the file's SHA-256 are in builtin_table.txt beside it), assembled
 * into read-only data as they are (.incbin): the reader checks them like
 * any table file (magic, version, sizes, values, FNV-1a checksum), and
 * tests/physics/test_ambient_table.c checks that they describe the
 * built-in table.
 */
#include "table.h"

#ifdef VOLUX_AMBIENT_BUILTIN_TABLE /* the file's path, from CMakeLists.txt */
__asm__(".section .rodata\n"
        ".balign 16\n"
        ".globl volux_ambient_builtin_bytes\n"
        ".hidden volux_ambient_builtin_bytes\n"
        "volux_ambient_builtin_bytes:\n"
        ".incbin \"" VOLUX_AMBIENT_BUILTIN_TABLE "\"\n"
        ".globl volux_ambient_builtin_end\n"
        ".hidden volux_ambient_builtin_end\n"
        "volux_ambient_builtin_end:\n"
        ".previous\n");
extern const unsigned char volux_ambient_builtin_bytes[], volux_ambient_builtin_end[];

const unsigned char *volux_ambient_builtin_table(size_t *size) {
    *size = (size_t)(volux_ambient_builtin_end - volux_ambient_builtin_bytes);
    return volux_ambient_builtin_bytes;
}
#else
const unsigned char *volux_ambient_builtin_table(size_t *size) {
    *size = 0;
    return NULL;
}
#endif
