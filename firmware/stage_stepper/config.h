// Build-time constants of stage_stepper: pins, buffer sizes, timing. Settings that a lab
// changes at run time live in settings.h ($N), not here.
#ifndef STAGE_CONFIG_H
#define STAGE_CONFIG_H

#include <stdint.h>

#define STAGE_FIRMWARE_VERSION "0.1.0"
#define STAGE_FIRMWARE_NAME "stage_stepper"
#define STAGE_PROTOCOL "whiskercal-stage-1"
#define STAGE_BANNER "Grbl 1.1h ['$' for help]"

enum : uint8_t {
    AXIS_X = 0,
    AXIS_Y = 1,
    AXIS_COUNT = 2,
};

enum : uint8_t {
    LINE_MAX = 80,            // docs/protocol.md: at most 80 characters a line
    RX_BUFFER_SIZE = 128,     // power of two
    TX_BUFFER_SIZE = 128,     // power of two
    PLANNER_BLOCKS = 8,
    SEGMENT_BUFFER_SIZE = 6,  // ~60 ms of motion prepared ahead
};

// Step timer: Timer1 at F_CPU / 8 = 2 MHz, so one tick is 0.5 µs.
static const uint32_t STEP_TIMER_HZ = 2000000UL;
// NOTE: the ISR takes up to 551 cycles (34 µs, simavr) plus the 3 µs pulse; at most 10 kHz keeps
// it under 40% of the CPU, leaving the rest to the protocol, the planner and the encoders.
static const uint16_t STEP_PERIOD_MIN_TICKS = 200;
// Segments of 10 ms: velocity is updated 100 times a second (acceleration resolution).
static const float SEGMENT_S = 0.010f;

// Homing: seek the switch at 600 mm/min for up to 1.2 x travel, back off 1 mm at 300 mm/min.
static const float HOMING_SEEK_MM_MIN = 600.0f;
static const float HOMING_PULLOFF_MM_MIN = 300.0f;
static const float HOMING_PULLOFF_MM = 1.0f;
static const float HOMING_SEARCH_FACTOR = 1.2f;

// Encoders: polled every 5 ms (200 Hz); at the 3000 mm/min default that is 160 polls a turn
// of 40 mm, far above the 3-4 a turn that turn counting needs.
static const uint32_t ENCODER_POLL_US = 5000UL;

// Upper bound on the step rate that $100..$111 may ask for, steps/s.
static const float STEP_RATE_MAX_HZ = 10000.0f;

#endif
