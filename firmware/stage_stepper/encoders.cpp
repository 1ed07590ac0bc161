#include "encoders.h"

#include <math.h>

#include "hal.h"
#include "settings.h"
#include "wc_codes.h"

struct encoder_axis {
    int32_t count;        // 4096 per turn since power-up
    uint16_t last_raw;
    int32_t zero_count;   // count at the last sync
    float zero_mm;        // position at the last sync
};

static encoder_axis encoders_axes[AXIS_COUNT];
static bool encoders_have_reading;
static bool encoders_synced;

void encoders_init() {
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) encoders_axes[axis] = encoder_axis();
    encoders_have_reading = false;
    encoders_synced = false;
}

int32_t encoders_unwrap(int32_t count, uint16_t previous_raw, uint16_t raw) {
    const int32_t turn = 1L << AS5600_COUNTS_PER_TURN_LOG2;
    int32_t delta = (int32_t)raw - (int32_t)previous_raw;
    // NOTE: correct only while the shaft turns less than half a turn between polls.
    if (delta >= turn / 2) delta -= turn;
    if (delta < -turn / 2) delta += turn;
    return count + delta;
}

uint8_t encoders_poll() {
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        uint8_t status = 0;
        uint16_t raw = 0;
        if (!hal_encoder_read(axis, &status, &raw)) return STAGE_ALARM_ENCODER_BUS;
        if (!(status & AS5600_STATUS_MD) || (status & (AS5600_STATUS_ML | AS5600_STATUS_MH))) {
            return STAGE_ALARM_ENCODER_MAGNET;
        }
        raw &= 0x0FFF;
        encoder_axis& e = encoders_axes[axis];
        e.count = encoders_have_reading ? encoders_unwrap(e.count, e.last_raw, raw) : (int32_t)raw;
        e.last_raw = raw;
    }
    encoders_have_reading = true;
    return 0;
}

void encoders_sync(const float position_mm[AXIS_COUNT]) {
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        encoders_axes[axis].zero_count = encoders_axes[axis].count;
        encoders_axes[axis].zero_mm = position_mm[axis];
    }
    encoders_synced = encoders_have_reading;
}

bool encoders_valid() { return encoders_synced; }

float encoders_position_mm(uint8_t axis) {
    const encoder_axis& e = encoders_axes[axis];
    float turns = (float)(e.count - e.zero_count) / (float)(1L << AS5600_COUNTS_PER_TURN_LOG2);
    return e.zero_mm + turns * settings.encoder_mm_per_turn;
}

uint8_t encoders_check(const float commanded_mm[AXIS_COUNT], float tolerance_mm) {
    if (!encoders_synced) return 0;
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        if (fabsf(encoders_position_mm(axis) - commanded_mm[axis]) > tolerance_mm) return STAGE_ALARM_ENCODER_MISMATCH;
    }
    return 0;
}
