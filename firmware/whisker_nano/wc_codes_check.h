// Compile-time checks that the shared code table holds the numbers this firmware relies on.
#ifndef WN_CODES_CHECK_H
#define WN_CODES_CHECK_H

#include "wc_codes.h"

static_assert(SENSOR_STATUS_MLX_ERROR == 1 && SENSOR_STATUS_NO_SENSOR == 2, "status bits");
static_assert(SENSOR_ERROR_UNKNOWN_COMMAND == 1 && SENSOR_ERROR_LINE_TOO_LONG == 6, "sensor errors");

#endif
