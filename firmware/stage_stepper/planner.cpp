#include "planner.h"

#include <math.h>

#include "settings.h"

static planner_block planner_blocks[PLANNER_BLOCKS];
static uint8_t planner_head;  // next free
static uint8_t planner_tail;  // oldest queued
static int32_t planner_end_steps[AXIS_COUNT];

static uint8_t planner_next(uint8_t index) { return (uint8_t)((index + 1) % PLANNER_BLOCKS); }

void planner_init() {
    planner_head = planner_tail = 0;
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) planner_end_steps[axis] = 0;
}

bool planner_full() { return planner_next(planner_head) == planner_tail; }
uint8_t planner_free() {
    return (uint8_t)((planner_tail + PLANNER_BLOCKS - planner_head - 1) % PLANNER_BLOCKS);  // one slot stays empty
}
bool planner_empty() { return planner_head == planner_tail; }

planner_block* planner_current() { return planner_empty() ? 0 : &planner_blocks[planner_tail]; }

void planner_discard() {
    if (!planner_empty()) planner_tail = planner_next(planner_tail);
}

const int32_t* planner_position() { return planner_end_steps; }

void planner_set_position(const int32_t position_steps[AXIS_COUNT]) {
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) planner_end_steps[axis] = position_steps[axis];
}

// Speed and acceleration along the path such that no axis exceeds its own limits.
static void planner_limit_by_axes(planner_block& block, const float delta_mm[AXIS_COUNT], float feed_mm_min) {
    float speed = feed_mm_min / 60.0f;
    float accel = 1.0e9f;
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        float share = fabsf(delta_mm[axis]) / block.millimeters;  // this axis's part of the path
        if (share <= 0.0f) continue;
        float axis_speed = settings.max_rate_mm_min[axis] / 60.0f / share;
        float axis_accel = settings.accel_mm_s2[axis] / share;
        if (axis_speed < speed) speed = axis_speed;
        if (axis_accel < accel) accel = axis_accel;
    }
    block.nominal_speed_mm_s = speed;
    block.accel_mm_s2 = accel;
}

bool planner_add_move(const int32_t target_steps[AXIS_COUNT], float feed_mm_min, uint8_t kind) {
    if (planner_full()) return false;
    planner_block& block = planner_blocks[planner_head];
    float delta_mm[AXIS_COUNT];
    float squared = 0.0f;
    block.kind = kind;
    block.direction_bits = 0;
    block.step_event_count = 0;
    block.dwell_s = 0.0f;
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        int32_t delta = target_steps[axis] - planner_end_steps[axis];
        if (delta < 0) block.direction_bits |= (uint8_t)(1 << axis);
        block.steps[axis] = (uint32_t)(delta < 0 ? -delta : delta);
        if (block.steps[axis] > block.step_event_count) block.step_event_count = block.steps[axis];
        delta_mm[axis] = (float)delta / settings.steps_per_mm[axis];
        squared += delta_mm[axis] * delta_mm[axis];
    }
    if (block.step_event_count == 0) return true;  // nothing to move: accepted, like grbl
    block.millimeters = sqrtf(squared);
    planner_limit_by_axes(block, delta_mm, feed_mm_min);
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) planner_end_steps[axis] = target_steps[axis];
    planner_head = planner_next(planner_head);
    return true;
}

bool planner_add_dwell(float seconds) {
    if (planner_full()) return false;
    if (seconds <= 0.0f) return true;
    planner_block& block = planner_blocks[planner_head];
    block.kind = BLOCK_DWELL;
    block.direction_bits = 0;
    block.step_event_count = 0;
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) block.steps[axis] = 0;
    block.millimeters = 0.0f;
    block.nominal_speed_mm_s = 0.0f;
    block.accel_mm_s2 = 0.0f;
    block.dwell_s = seconds;
    planner_head = planner_next(planner_head);
    return true;
}
