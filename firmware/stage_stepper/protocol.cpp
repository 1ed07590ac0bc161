#include "protocol.h"

#include "config.h"
#include "gcode.h"
#include "homing.h"
#include "planner.h"
#include "report.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"
#include "system.h"
#include "wc_codes.h"

struct protocol_line {
    char text[LINE_MAX + 1];
    uint8_t length;      // normalized characters kept
    uint8_t received;    // characters received on this line, to enforce LINE_MAX
    bool in_comment;     // inside ( ... )
    bool rest_ignored;   // after ';'
    bool ready;          // a complete line waits to be executed
    bool overflowed;
};

static protocol_line protocol_buffer;
static const uint8_t PROTOCOL_WAIT = 0xFE;  // not an error code: the line waits for the planner
static gcode_modal protocol_modal;

static void protocol_clear_line() {
    protocol_line& line = protocol_buffer;
    line.length = line.received = 0;
    line.in_comment = line.rest_ignored = line.ready = line.overflowed = false;
}

void protocol_init() {
    protocol_clear_line();
    gcode_init(protocol_modal);
}

void protocol_realtime() {
    uint8_t requests = serial_take_realtime();
    if (requests & REALTIME_RESET) {
        system_reset();
        protocol_init();
        return;
    }
    // Hold and resume before the report, so that "!?" reports the hold it asked for.
    if ((requests & REALTIME_HOLD) && !homing_active() && stepper_busy()) stepper_hold();
    if ((requests & REALTIME_RESUME) && stepper_holding()) stepper_resume();
    if (requests & REALTIME_STATUS) report_status();
}

// Adds one received character to the line being assembled.
static void protocol_take_char(char c) {
    protocol_line& line = protocol_buffer;
    if (c == '\n') {
        line.text[line.length] = '\0';
        line.ready = true;
        return;
    }
    if (c == '\r' || line.rest_ignored) return;
    if (++line.received > LINE_MAX) line.overflowed = true;
    if (line.overflowed) return;
    if (line.in_comment) {
        line.in_comment = c != ')';
    } else if (c == '(') {
        line.in_comment = true;
    } else if (c == ';') {
        line.rest_ignored = true;
    } else if (c != ' ' && c != '\t') {
        line.text[line.length++] = (c >= 'a' && c <= 'z') ? (char)(c - 'a' + 'A') : c;
    }
}

// Queues what a valid line asks for; grbl dwells before it moves when a block has both.
static void protocol_queue(const gcode_action& action) {
    if (action.kind & GCODE_DWELL) planner_add_dwell(action.dwell_s);
    if (!(action.kind & GCODE_MOVE)) return;
    int32_t target[AXIS_COUNT];
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        float steps = action.target_mm[axis] * settings.steps_per_mm[axis];
        target[axis] = (int32_t)(steps < 0.0f ? steps - 0.5f : steps + 0.5f);
    }
    planner_add_move(target, action.feed_mm_min, BLOCK_MOVE);
}

static uint8_t protocol_execute_gcode(const char* text) {
    if (system_locked()) return STAGE_ERROR_SYSTEM_GC_LOCK;
    float position[AXIS_COUNT];
    system_planned_position_mm(position);
    gcode_modal next = protocol_modal;
    gcode_action action;
    uint8_t error = gcode_parse(text, next, position, action);
    if (error) return error;
    // A dwell with a move takes two planner blocks: the line waits until both fit (rare: it is
    // parsed again on each pass while exactly one block is free).
    if (action.kind == (GCODE_DWELL | GCODE_MOVE) && planner_free() < 2) return PROTOCOL_WAIT;
    protocol_modal = next;
    protocol_queue(action);
    return 0;
}

// Executes the complete line and answers it; false when it has to wait for the planner.
static bool protocol_execute_line() {
    protocol_line& line = protocol_buffer;
    uint8_t result = 0;
    if (line.overflowed) {
        result = STAGE_ERROR_OVERFLOW;
    } else if (line.text[0] == '$') {
        result = system_execute(line.text);
    } else if (line.length > 0) {
        result = protocol_execute_gcode(line.text);
    }
    if (result == PROTOCOL_WAIT) return false;
    protocol_clear_line();
    if (result == SYSTEM_DEFERRED) return true;
    if (result) {
        report_error(result);
    } else {
        report_ok();
    }
    return true;
}

void protocol_lines() {
    for (;;) {
        protocol_line& line = protocol_buffer;
        if (line.ready) {
            // NOTE: a full queue or a homing cycle holds the line, and with it the host's next
            // "ok": that is the flow control of the protocol.
            if (planner_full() || homing_active() || !protocol_execute_line()) return;
            continue;
        }
        int16_t c = serial_read();
        if (c < 0) return;
        protocol_take_char((char)c);
    }
}
