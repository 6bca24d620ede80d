/* core/version.c — the run-time version (volux/version.h). */
#include "volux/version.h"

const char *volux_version(void) { return VOLUX_VERSION; }

int volux_version_number(void) { return VOLUX_VERSION_NUMBER; }
