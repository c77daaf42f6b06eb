/* ch_version: the linked library's version (see ch_version.h). */
#include "ch_version.h"

const char *ch_version(void) { return CH_VERSION_STRING; }
