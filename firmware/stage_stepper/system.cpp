#include "system.h"

#include "encoders.h"
#include "gcode.h"
#include "homing.h"
#include "planner.h"
#include "report.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"
#include "wc_codes.h"

struct system_status {
    bool locked;
    uint8_t encoder_fault;      // alarm already pushed for this encoder fault (latched)
    uint32_t last_encoder_poll_us;
};

static system_status sys;

void system_init() {
    sys = system_status();
    homing_init();
}

void system_position_mm(float out[AXIS_COUNT]) {
    int32_t steps[AXIS_COUNT];
    stepper_position(steps);
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) out[axis] = (float)steps[axis] / settings.steps_per_mm[axis];
}

void system_planned_position_mm(float out[AXIS_COUNT]) {
    const int32_t* steps = planner_position();
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) out[axis] = (float)steps[axis] / settings.steps_per_mm[axis];
}

void system_stop_motion() {
    stepper_reset();
    planner_init();
    int32_t steps[AXIS_COUNT];
    stepper_position(steps);
    planner_set_position(steps);
}

static void system_resync_encoders() {
    float position[AXIS_COUNT];
    system_position_mm(position);
    encoders_sync(position);
    sys.encoder_fault = 0;  // a fault that persists raises its alarm again
}

void system_alarm(uint8_t code) {
    system_stop_motion();
    homing_abort();
    sys.locked = true;
    report_alarm(code);
}

// The banner; the lock after power-up (homing enabled) or after an alarm, as grbl does.
static void system_boot(bool power_up, bool settings_were_valid) {
    report_banner();
    if (!settings_were_valid) report_message(FLASH_TEXT("EEPROM settings invalid, defaults restored"));
    if (power_up && settings.homing) sys.locked = true;
    if (sys.locked) report_message(FLASH_TEXT("'$H'|'$X' to unlock"));
}

void system_start(bool settings_were_valid) { system_boot(true, settings_were_valid); }

void system_reset() {
    bool moving = stepper_busy() && !stepper_hold_complete();
    uint8_t alarm = homing_active() ? STAGE_ALARM_HOMING_FAIL_RESET : moving ? STAGE_ALARM_ABORT_CYCLE : 0;
    system_stop_motion();
    homing_abort();
    serial_flush_rx();
    if (alarm) {
        report_alarm(alarm);
        sys.locked = true;
    }
    sys.encoder_fault = 0;
    system_boot(false, true);
}

bool system_locked() { return sys.locked; }

const char* system_state_name() {
    if (homing_active()) return "Home";
    if (sys.locked) return "Alarm";
    if (stepper_holding()) return stepper_hold_complete() ? "Hold:0" : "Hold:1";  // as GRBL 1.1: 0 complete, 1 decelerating
    return stepper_busy() ? "Run" : "Idle";
}

// A finished cycle unlocks and answers the $H line; a failed one alarms.
static void system_update_homing() {
    uint8_t outcome = homing_update();
    if (outcome == HOMING_RUNNING) return;
    if (outcome != HOMING_DONE) return system_alarm(outcome);
    sys.locked = false;
    system_resync_encoders();
    report_ok();  // the deferred answer to $H
}

static void system_supervise_encoders(uint32_t now_us) {
    if (!settings.encoder_present || now_us - sys.last_encoder_poll_us < ENCODER_POLL_US) return;
    sys.last_encoder_poll_us = now_us;
    uint8_t fault = encoders_poll();
    if (fault) {
        if (fault != sys.encoder_fault) system_alarm(fault);
        sys.encoder_fault = fault;
        return;
    }
    if (sys.encoder_fault) sys.encoder_fault = 0;
    if (!encoders_valid()) system_resync_encoders();
    if (sys.locked || homing_active()) return;  // position not trusted or moving off a switch
    float position[AXIS_COUNT];
    system_position_mm(position);
    uint8_t mismatch = encoders_check(position, settings.encoder_tolerance_mm);
    if (mismatch) system_alarm(mismatch);
}

void system_update(uint32_t now_us) {
    uint8_t hits = homing_seeking() ? 0 : stepper_take_limit_hits();
    if (hits) system_alarm(STAGE_ALARM_HARD_LIMIT);
    if (homing_active()) system_update_homing();
    system_supervise_encoders(now_us);
}

static uint8_t system_set_setting(const char* line) {
    const char* p = line + 1;
    float number = 0.0f, value = 0.0f;
    if (!gcode_read_number(&p, &number) || *p != '=') return STAGE_ERROR_INVALID_STATEMENT;
    ++p;
    if (!gcode_read_number(&p, &value) || *p != '\0') return STAGE_ERROR_BAD_NUMBER_FORMAT;
    if (number < 0.0f || number > 999.0f || number != (float)(uint16_t)number) return STAGE_ERROR_INVALID_STATEMENT;
    return settings_set((uint16_t)number, value);
}

static uint8_t system_unlock() {
    if (sys.locked) {
        sys.locked = false;
        system_resync_encoders();
        report_message(FLASH_TEXT("Caution: Unlocked"));
    }
    return 0;
}

// The commands that read or change settings, or home, wait for rest (error:8), as in grbl.
static uint8_t system_execute_at_rest(const char* line) {
    if (stepper_busy()) return STAGE_ERROR_IDLE_ERROR;
    if (line[1] >= '0' && line[1] <= '9') return system_set_setting(line);
    if (line[2] != '\0') return STAGE_ERROR_INVALID_STATEMENT;
    if (line[1] == '$') {
        report_settings();
    } else if (line[1] == 'I') {
        report_build_info();
    } else if (line[1] == 'H') {
        uint8_t error = homing_start();
        return error ? error : SYSTEM_DEFERRED;
    } else {
        return STAGE_ERROR_INVALID_STATEMENT;
    }
    return 0;
}

uint8_t system_execute(const char* line) {
    if (line[1] == '\0') {
        report_help();
        return 0;
    }
    if (line[1] == 'X' && line[2] == '\0') return system_unlock();
    return system_execute_at_rest(line);
}
