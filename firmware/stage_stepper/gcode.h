// The G-code subset of docs/protocol.md: G0, G1, G4, G17, G21, G90, G91, G94 with X, Y, F, P
// (and N, ignored). Parses one normalized line (upper case, no spaces or comments) against the
// modal state and returns what to queue; the modal state changes only when the line is valid.
// Blocks follow grbl 1.1's rules: one command per modal group, G0/G1 without axis words only
// set the motion mode, and a G4 dwell may share its block with a move (dwell first).
#ifndef STAGE_GCODE_H
#define STAGE_GCODE_H

#include <stdint.h>

#include "config.h"

struct gcode_modal {
    uint8_t motion;        // 0: G0 rapid, 1: G1 linear at the feed rate
    bool incremental;      // G91
    float feed_mm_min;     // 0 until an F word was given
};

// What a line queues: bits of gcode_action.kind.
enum : uint8_t {
    GCODE_NOTHING = 0,
    GCODE_MOVE = 1,
    GCODE_DWELL = 2,
};

struct gcode_action {
    uint8_t kind;          // GCODE_MOVE | GCODE_DWELL bits
    float target_mm[AXIS_COUNT];
    float feed_mm_min;     // for G0 the axes' maximum rates apply
    float dwell_s;
};

void gcode_init(gcode_modal& modal);

// Parses line with the stage at position_mm (end of the queued motion); returns 0 or a
// STAGE_ERROR code. Soft limits ($20, $130, $131) are checked here.
uint8_t gcode_parse(const char* line, gcode_modal& modal, const float position_mm[AXIS_COUNT], gcode_action& action);

// Parses a decimal number ([+-]digits[.digits]) at *text, advancing it. False without digits.
bool gcode_read_number(const char** text, float* value);

#endif
