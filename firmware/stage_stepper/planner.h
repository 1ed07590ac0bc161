// Motion planner: a ring of blocks (moves and dwells) between the G-code interpreter and the
// segment generator. Every move starts and ends at rest: the stage goes point to point to
// touch a whisker, so junction speeds would add risk and no value.
#ifndef STAGE_PLANNER_H
#define STAGE_PLANNER_H

#include <stdint.h>

#include "config.h"

enum : uint8_t {
    BLOCK_MOVE = 0,
    BLOCK_DWELL = 1,
    BLOCK_HOMING = 2,  // a move that ends early when the switch of the axis it heads to closes
};

struct planner_block {
    uint8_t kind;
    uint8_t direction_bits;         // bit per axis: 1 = negative
    uint32_t steps[AXIS_COUNT];     // absolute step counts of the move
    uint32_t step_event_count;      // the largest of steps[]: Bresenham's major axis
    float millimeters;              // length of the move, mm
    float nominal_speed_mm_s;       // cruise speed, mm/s
    float accel_mm_s2;              // acceleration along the path, limited per axis
    float dwell_s;                  // BLOCK_DWELL only
};

void planner_init();

// Queues a straight move to target_steps (absolute step position) at feed mm/min, the speed
// and acceleration limited per axis by the settings. A zero-length move queues nothing.
// Returns false when the queue is full.
bool planner_add_move(const int32_t target_steps[AXIS_COUNT], float feed_mm_min, uint8_t kind);
bool planner_add_dwell(float seconds);

bool planner_full();
uint8_t planner_free();  // blocks that can still be queued
bool planner_empty();

// Oldest block, or 0; planner_discard() frees it once the segment generator is done with it.
planner_block* planner_current();
void planner_discard();

// Where the last queued move ends, steps; planner_set_position() after homing or a stop.
const int32_t* planner_position();
void planner_set_position(const int32_t position_steps[AXIS_COUNT]);

#endif
