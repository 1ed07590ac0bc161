// Machine state of stage_stepper: alarms and the lock, encoder supervision, the '$' system
// commands and soft reset; the homing cycle itself is homing.cpp. The state reported is derived
// from these and from the stepper (Idle, Run, Hold:1 decelerating, Hold:0 held, Home, Alarm).
#ifndef STAGE_SYSTEM_H
#define STAGE_SYSTEM_H

#include <stdint.h>

#include "config.h"

void system_init();

// Power-up: banner, and the Alarm lock when homing is enabled (docs/protocol.md).
void system_start(bool settings_were_valid);

// Soft reset (0x18): stop at once, flush, push ALARM:3 (or 6 while homing) if moving, banner.
// The lock stays as it was, except that a reset during motion locks (position likely lost).
void system_reset();

// Stops all motion, flushes the queue, locks and pushes ALARM:code.
void system_alarm(uint8_t code);

// Forgets queued motion at once; the planner continues from where the steppers really are.
void system_stop_motion();

bool system_locked();        // in Alarm: G-code refused with error:9
const char* system_state_name();

// Runs the homing cycle, limit and encoder supervision; call from the main loop.
void system_update(uint32_t now_us);

// Executes a '$' line; returns 0 (answer printed by the caller as ok), a STAGE_ERROR code,
// or SYSTEM_DEFERRED when the answer comes later ($H answers once homing ends).
static const uint8_t SYSTEM_DEFERRED = 0xFF;
uint8_t system_execute(const char* line);

// Position in mm from the step counters, and the queued end of motion in mm.
void system_position_mm(float out[AXIS_COUNT]);
void system_planned_position_mm(float out[AXIS_COUNT]);

#endif
