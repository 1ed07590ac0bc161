#include "settings.h"

#include <stddef.h>

#include "hal.h"
#include "wc_codes.h"

settings_values settings;

static const uint16_t SETTINGS_NUMBERS[] = {20, 22, 100, 101, 110, 111, 120, 121, 130, 131, 200, 201, 202};

void settings_defaults(settings_values& v) {
    v.soft_limits = 1;
    v.homing = 1;
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        v.steps_per_mm[axis] = 80.0f;  // GT2 belt, 20-tooth pulley, 200 steps x 1/16 microstep
        v.max_rate_mm_min[axis] = 3000.0f;
        v.accel_mm_s2[axis] = 200.0f;
        v.travel_mm[axis] = 200.0f;
    }
    v.encoder_present = 1;
    v.encoder_mm_per_turn = 40.0f;  // the pulley's circumference: encoder on the motor shaft
    v.encoder_tolerance_mm = 0.5f;
}

uint16_t settings_checksum(const uint8_t* data, uint16_t n) {
    // Fletcher-16: catches the erased (0xFF) EEPROM and single-byte corruption.
    uint16_t sum1 = 0, sum2 = 0;
    for (uint16_t i = 0; i < n; ++i) {
        sum1 = (uint16_t)((sum1 + data[i]) % 255);
        sum2 = (uint16_t)((sum2 + sum1) % 255);
    }
    return (uint16_t)((sum2 << 8) | sum1);
}

struct settings_record {
    uint8_t version;
    settings_values values;
    uint16_t checksum;
};

static uint16_t settings_record_checksum(const settings_record& record) {
    return settings_checksum((const uint8_t*)&record, (uint16_t)offsetof(settings_record, checksum));
}

bool settings_load() {
    settings_record record;
    hal_eeprom_read(SETTINGS_EEPROM_ADDRESS, (uint8_t*)&record, sizeof record);
    if (record.version == SETTINGS_VERSION && record.checksum == settings_record_checksum(record)) {
        settings = record.values;
        return true;
    }
    settings_defaults(settings);
    settings_store();
    return false;
}

void settings_store() {
    settings_record record;
    // Zero the padding too, so the checksum only depends on the values.
    for (uint16_t i = 0; i < sizeof record; ++i) ((uint8_t*)&record)[i] = 0;
    record.version = SETTINGS_VERSION;
    // Field by field: a struct assignment may copy the source's padding bytes.
    record.values.soft_limits = settings.soft_limits;
    record.values.homing = settings.homing;
    record.values.encoder_present = settings.encoder_present;
    record.values.encoder_mm_per_turn = settings.encoder_mm_per_turn;
    record.values.encoder_tolerance_mm = settings.encoder_tolerance_mm;
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        record.values.steps_per_mm[axis] = settings.steps_per_mm[axis];
        record.values.max_rate_mm_min[axis] = settings.max_rate_mm_min[axis];
        record.values.accel_mm_s2[axis] = settings.accel_mm_s2[axis];
        record.values.travel_mm[axis] = settings.travel_mm[axis];
    }
    record.checksum = settings_record_checksum(record);
    hal_eeprom_write(SETTINGS_EEPROM_ADDRESS, (const uint8_t*)&record, sizeof record);
}

uint8_t settings_count() { return (uint8_t)(sizeof SETTINGS_NUMBERS / sizeof SETTINGS_NUMBERS[0]); }

uint16_t settings_number(uint8_t index) { return SETTINGS_NUMBERS[index]; }

bool settings_is_integer(uint16_t number) { return number == 20 || number == 22 || number == 200; }

// Address of the float behind $number, or 0 for flags and unknown numbers.
static float* settings_float(settings_values& v, uint16_t number) {
    uint8_t axis = (uint8_t)(number % 10);
    if (number >= 100 && number < 140 && axis < AXIS_COUNT) {
        switch (number / 10) {
            case 10: return &v.steps_per_mm[axis];
            case 11: return &v.max_rate_mm_min[axis];
            case 12: return &v.accel_mm_s2[axis];
            case 13: return &v.travel_mm[axis];
        }
    }
    if (number == 201) return &v.encoder_mm_per_turn;
    if (number == 202) return &v.encoder_tolerance_mm;
    return 0;
}

static uint8_t* settings_flag(settings_values& v, uint16_t number) {
    if (number == 20) return &v.soft_limits;
    if (number == 22) return &v.homing;
    if (number == 200) return &v.encoder_present;
    return 0;
}

float settings_get(uint16_t number) {
    uint8_t* flag = settings_flag(settings, number);
    if (flag) return *flag;
    float* value = settings_float(settings, number);
    return value ? *value : 0.0f;
}

static bool settings_step_rate_ok(const settings_values& v) {
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        if (v.max_rate_mm_min[axis] / 60.0f * v.steps_per_mm[axis] > STEP_RATE_MAX_HZ) return false;
    }
    return true;
}

uint8_t settings_set(uint16_t number, float value) {
    settings_values next = settings;
    uint8_t* flag = settings_flag(next, number);
    float* target = settings_float(next, number);
    if (!flag && !target) return STAGE_ERROR_INVALID_STATEMENT;
    if (value < 0.0f) return STAGE_ERROR_NEGATIVE_VALUE;
    if (flag) {
        if (value != 0.0f && value != 1.0f) return STAGE_ERROR_COMMAND_VALUE_NOT_INTEGER;
        *flag = (uint8_t)value;
    } else {
        if (!(value > 0.0f) || value > 1.0e6f) return STAGE_ERROR_BAD_NUMBER_FORMAT;  // also NaN
        *target = value;
        if (!settings_step_rate_ok(next)) return STAGE_ERROR_BAD_NUMBER_FORMAT;
    }
    settings = next;
    settings_store();
    return 0;
}
