// Settings ($N) kept in EEPROM as one record with a version and a Fletcher-16 checksum; a
// record with a wrong version or checksum is replaced by the defaults of docs/protocol.md.
#ifndef STAGE_SETTINGS_H
#define STAGE_SETTINGS_H

#include <stdint.h>

#include "config.h"

// Bump when the layout of settings_values changes: old records then load as defaults.
static const uint8_t SETTINGS_VERSION = 1;
static const uint16_t SETTINGS_EEPROM_ADDRESS = 0;

struct settings_values {
    uint8_t soft_limits;               // $20
    uint8_t homing;                    // $22
    float steps_per_mm[AXIS_COUNT];    // $100, $101
    float max_rate_mm_min[AXIS_COUNT]; // $110, $111
    float accel_mm_s2[AXIS_COUNT];     // $120, $121
    float travel_mm[AXIS_COUNT];       // $130, $131
    uint8_t encoder_present;           // $200
    float encoder_mm_per_turn;         // $201
    float encoder_tolerance_mm;        // $202
};

extern settings_values settings;

void settings_defaults(settings_values& values);

// Loads the EEPROM record; on a bad version or checksum stores the defaults and returns false.
bool settings_load();

void settings_store();

// Sets $number to value (validated) and stores it. Returns 0 or a STAGE_ERROR code.
uint8_t settings_set(uint16_t number, float value);

// Number of settings and the i-th one's number and value, for "$$".
uint8_t settings_count();
uint16_t settings_number(uint8_t index);
float settings_get(uint16_t number);
bool settings_is_integer(uint16_t number);

uint16_t settings_checksum(const uint8_t* data, uint16_t n);

#endif
