#include "homing.h"

#include "config.h"
#include "hal.h"
#include "planner.h"
#include "settings.h"
#include "stepper.h"
#include "system.h"
#include "wc_codes.h"

enum : uint8_t {
    HOMING_OFF = 0,
    HOMING_SEEK,
    HOMING_PULLOFF,
};

struct homing_state {
    uint8_t phase;
    uint8_t axis;  // the axis being homed
};

static homing_state homing;

void homing_init() { homing = homing_state(); }
bool homing_active() { return homing.phase != HOMING_OFF; }
bool homing_seeking() { return homing.phase == HOMING_SEEK; }
void homing_abort() { homing.phase = HOMING_OFF; }

// Queues a move of distance_mm on the axis being homed.
static void homing_move(float distance_mm, float rate_mm_min, uint8_t kind) {
    int32_t target[AXIS_COUNT];
    stepper_position(target);
    target[homing.axis] += (int32_t)(distance_mm * settings.steps_per_mm[homing.axis]);
    planner_add_move(target, rate_mm_min, kind);
}

static void homing_seek() {
    float search_mm = HOMING_SEARCH_FACTOR * settings.travel_mm[homing.axis];
    homing.phase = HOMING_SEEK;
    homing_move(-search_mm, HOMING_SEEK_MM_MIN, BLOCK_HOMING);
}

uint8_t homing_start() {
    if (!settings.homing) return STAGE_ERROR_SETTING_DISABLED_HOMING;
    if (stepper_busy()) return STAGE_ERROR_IDLE_ERROR;
    system_stop_motion();
    stepper_take_limit_hits();  // hits from before the cycle say nothing about the switches now
    homing.axis = AXIS_X;
    homing_seek();
    return 0;
}

// The seek ends when the axis's switch closes (then pull off) or fails at the search distance.
static uint8_t homing_update_seek() {
    if (stepper_take_limit_hits() & (uint8_t)(1 << homing.axis)) {
        system_stop_motion();  // the rest of the search move is dropped
        homing.phase = HOMING_PULLOFF;
        homing_move(HOMING_PULLOFF_MM, HOMING_PULLOFF_MM_MIN, BLOCK_MOVE);
        return HOMING_RUNNING;
    }
    if (stepper_busy()) return HOMING_RUNNING;
    return STAGE_ALARM_HOMING_FAIL_APPROACH;  // the search distance ran out
}

static void homing_set_zero() {
    const int32_t zero[AXIS_COUNT] = {0, 0};
    stepper_set_position(zero);
    planner_set_position(zero);
    homing.phase = HOMING_OFF;
}

uint8_t homing_update() {
    if (homing.phase == HOMING_SEEK) return homing_update_seek();
    if (stepper_busy()) return HOMING_RUNNING;
    if (hal_limit_pressed(homing.axis)) return STAGE_ALARM_HOMING_FAIL_PULLOFF;
    if (++homing.axis < AXIS_COUNT) {
        homing_seek();
        return HOMING_RUNNING;
    }
    homing_set_zero();
    return HOMING_DONE;
}
