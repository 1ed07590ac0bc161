// The two AS5600 magnetic encoders (one per motor shaft, both at I2C address 0x36 behind a
// TCA9548A multiplexer): turn counting from the 12-bit angle, magnet and bus checks, and the
// comparison of measured and commanded position that raises ALARM:100.
#ifndef STAGE_ENCODERS_H
#define STAGE_ENCODERS_H

#include <stdint.h>

#include "config.h"

enum : uint8_t {
    AS5600_STATUS_MH = 0x08,  // magnet too strong
    AS5600_STATUS_ML = 0x10,  // magnet too weak
    AS5600_STATUS_MD = 0x20,  // magnet detected
    AS5600_COUNTS_PER_TURN_LOG2 = 12,
};

void encoders_init();

// Reads both encoders once and updates the turn counts. Returns 0, or ALARM:101 / ALARM:102.
uint8_t encoders_poll();

// Makes the encoder positions equal to position_mm from now on (power-up, homing, unlock).
void encoders_sync(const float position_mm[AXIS_COUNT]);

// Measured position, mm; valid after a successful poll and a sync.
float encoders_position_mm(uint8_t axis);
bool encoders_valid();

// Adds a raw angle reading to a running count, taking the shorter way round the wrap.
int32_t encoders_unwrap(int32_t count, uint16_t previous_raw, uint16_t raw);

// ALARM:100 when |measured - commanded| exceeds tolerance_mm on any axis, else 0.
uint8_t encoders_check(const float commanded_mm[AXIS_COUNT], float tolerance_mm);

#endif
