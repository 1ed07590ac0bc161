// Step generation in two halves. The main loop (stepper_prep) cuts the oldest planner block
// into 10 ms segments of constant step rate along a trapezoidal velocity profile; the timer
// interrupt (stepper_isr) pops segments and emits steps with Bresenham's line algorithm.
#ifndef STAGE_STEPPER_H
#define STAGE_STEPPER_H

#include <stdint.h>

#include "config.h"

// One segment of a velocity profile: pure arithmetic, exposed for the host tests.
struct stepper_segment_plan {
    float speed_end_mm_s;
    float mm;         // distance covered
    float seconds;    // duration
    bool block_done;  // the segment reaches the end of the block
    bool stopped;     // a feed hold reached standstill
};

// Next segment from speed v0 with mm_remaining to go, cruising at nominal, accelerating at accel;
// with hold set it decelerates to a stop instead.
stepper_segment_plan stepper_plan_segment(float v0_mm_s, float mm_remaining, float nominal_mm_s,
                                          float accel_mm_s2, bool hold);

void stepper_init();

// Stops at once and forgets all queued segments (soft reset, alarm).
void stepper_reset();

// Main loop: prepares segments from the planner and starts the timer when they are waiting.
void stepper_prep();

// Timer interrupt body.
void stepper_isr();

// Feed hold: decelerate to a stop; resume continues the same block.
void stepper_hold();
void stepper_resume();
bool stepper_holding();       // a hold was requested and not resumed
bool stepper_hold_complete(); // ... and the stage stands still

// True while steps are still being generated or segments are waiting.
bool stepper_busy();

// Step position (copied with interrupts off), speed of the executing segment, mm/min.
void stepper_position(int32_t out[AXIS_COUNT]);
void stepper_set_position(const int32_t position[AXIS_COUNT]);
uint16_t stepper_speed_mm_min();

// Axes whose limit switch stopped the motion (bit per axis); reading clears them.
uint8_t stepper_take_limit_hits();

#endif
