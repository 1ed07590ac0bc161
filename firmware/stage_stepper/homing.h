// The $H cycle: X, then Y, each seeks its limit switch at the zero end, pulls off it, and the
// point where both pull-offs end becomes machine zero. system.cpp starts the cycle, calls
// homing_update() from the main loop and turns its outcome into ok or an alarm.
#ifndef STAGE_HOMING_H
#define STAGE_HOMING_H

#include <stdint.h>

// What homing_update() returns besides a STAGE_ALARM code.
enum : uint8_t {
    HOMING_RUNNING = 0,
    HOMING_DONE = 0xFF,
};

void homing_init();

// Starts the cycle from rest; returns 0 or a STAGE_ERROR code ($22=0, or the stage moves).
uint8_t homing_start();

bool homing_active();
bool homing_seeking();  // limit hits now are the switch being found, not ALARM:1
void homing_abort();    // a reset or an alarm ends the cycle where it is

// Advances the cycle once its current move has ended: HOMING_RUNNING, HOMING_DONE (machine
// zero set) or the STAGE_ALARM code of a failed seek or pull-off.
uint8_t homing_update();

#endif
