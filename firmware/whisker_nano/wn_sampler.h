// The 300 Hz sampling loop as a state machine polled from loop(): start a single
// measurement when a sample is due, read it once its conversion time has passed on the clock,
// frame it and queue it for the UART. Nothing here waits.
#ifndef WN_SAMPLER_H
#define WN_SAMPLER_H

#include <stdint.h>

#include "wn_mlx.h"

enum : uint16_t {
    SAMPLER_RATE_DEFAULT_HZ = 300,
    SAMPLER_RATE_MIN_HZ = 1,
    SAMPLER_RATE_MAX_HZ = 500,
    // SM and RM transactions at 400 kHz (4 + 10 bytes with addresses, ~325 µs on the wire) plus
    // the Wire library's own time: the part of a period that is not conversion (docs/firmware.md).
    SAMPLER_I2C_OVERHEAD_US = 360,
};

struct sampler_state {
    mlx_settings mlx;
    uint16_t rate_hz;
    bool streaming;
    bool converting;
    bool sensor_configured;  // false after power-up and after any I2C failure: reconfigure
    uint16_t seq;
    uint32_t period_us;
    uint32_t next_due_us;     // when the next conversion should start
    uint32_t started_us;      // when the current conversion was due (the frame's timestamp)
    uint32_t commanded_us;    // when the SM command had reached the chip: the wait counts from here
    uint8_t carried_status;   // status bits that belong to the next frame sent (TX_OVERFLOW, LATE)
    uint32_t frames_dropped;  // frames not sent because the transmit buffer was full
};

// Defaults of docs/protocol.md: 300 Hz, gain 5, resolution 2, OSR 0, DIG_FILT 2 (docs/firmware.md
// says why: every axis stays inside its output range over the whole working range).
void sampler_init(sampler_state& s);

// True when the conversion time of (osr, filt) plus the I2C transactions fit the period of rate_hz.
bool sampler_fits(uint16_t rate_hz, uint8_t osr, uint8_t filt);

void sampler_start(sampler_state& s, uint32_t now_us);
void sampler_stop(sampler_state& s);

// Advances the state machine; call as often as possible.
void sampler_poll(sampler_state& s, uint32_t now_us);

#endif
