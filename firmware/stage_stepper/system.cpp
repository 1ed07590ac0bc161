#include "system.h"

#include "encoders.h"
#include "gcode.h"
#include "hal.h"
#include "planner.h"
#include "report.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"
#include "wc_codes.h"

enum : uint8_t {
    HOMING_OFF = 0,
    HOMING_SEEK,
    HOMING_PULLOFF,
};

struct system_status {
    bool locked;
    uint8_t homing_phase;
    uint8_t homing_axis;
    uint8_t encoder_fault;      // alarm already pushed for this encoder fault (latched)
    uint32_t last_encoder_poll_us;
};

static system_status sys;

void system_init() {
    sys = system_status();
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

// Forgets queued motion; the planner continues from where the steppers really are.
static void system_stop_motion() {
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
    sys.homing_phase = HOMING_OFF;
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
    uint8_t alarm = sys.homing_phase != HOMING_OFF ? STAGE_ALARM_HOMING_FAIL_RESET : moving ? STAGE_ALARM_ABORT_CYCLE : 0;
    system_stop_motion();
    sys.homing_phase = HOMING_OFF;
    serial_flush_rx();
    if (alarm) {
        report_alarm(alarm);
        sys.locked = true;
    }
    sys.encoder_fault = 0;
    system_boot(false, true);
}

bool system_locked() { return sys.locked; }
bool system_homing() { return sys.homing_phase != HOMING_OFF; }

const char* system_state_name() {
    if (sys.homing_phase != HOMING_OFF) return "Home";
    if (sys.locked) return "Alarm";
    if (stepper_holding()) return stepper_hold_complete() ? "Hold:1" : "Hold:0";
    return stepper_busy() ? "Run" : "Idle";
}

// Queues a homing move of distance_mm on the current axis.
static void system_homing_move(float distance_mm, float rate_mm_min, uint8_t kind) {
    int32_t target[AXIS_COUNT];
    stepper_position(target);
    target[sys.homing_axis] += (int32_t)(distance_mm * settings.steps_per_mm[sys.homing_axis]);
    planner_add_move(target, rate_mm_min, kind);
}

static void system_homing_seek() {
    float search_mm = HOMING_SEARCH_FACTOR * settings.travel_mm[sys.homing_axis];
    sys.homing_phase = HOMING_SEEK;
    system_homing_move(-search_mm, HOMING_SEEK_MM_MIN, BLOCK_HOMING);
}

static void system_homing_done() {
    const int32_t zero[AXIS_COUNT] = {0, 0};
    stepper_set_position(zero);
    planner_set_position(zero);
    sys.homing_phase = HOMING_OFF;
    sys.locked = false;
    system_resync_encoders();
    report_ok();  // the deferred answer to $H
}

// Advances the homing cycle once the current move has ended.
static void system_homing_step() {
    uint8_t bit = (uint8_t)(1 << sys.homing_axis);
    if (sys.homing_phase == HOMING_SEEK) {
        if (stepper_take_limit_hits() & bit) {
            system_stop_motion();  // the rest of the search move is dropped
            sys.homing_phase = HOMING_PULLOFF;
            system_homing_move(HOMING_PULLOFF_MM, HOMING_PULLOFF_MM_MIN, BLOCK_MOVE);
        } else if (!stepper_busy()) {
            system_alarm(STAGE_ALARM_HOMING_FAIL_APPROACH);
        }
        return;
    }
    if (stepper_busy()) return;
    if (hal_limit_pressed(sys.homing_axis)) return system_alarm(STAGE_ALARM_HOMING_FAIL_PULLOFF);
    if (++sys.homing_axis < AXIS_COUNT) return system_homing_seek();
    system_homing_done();
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
    if (sys.locked || sys.homing_phase != HOMING_OFF) return;  // position not trusted or moving off a switch
    float position[AXIS_COUNT];
    system_position_mm(position);
    uint8_t mismatch = encoders_check(position, settings.encoder_tolerance_mm);
    if (mismatch) system_alarm(mismatch);
}

void system_update(uint32_t now_us) {
    uint8_t hits = sys.homing_phase == HOMING_SEEK ? 0 : stepper_take_limit_hits();
    if (hits) system_alarm(STAGE_ALARM_HARD_LIMIT);
    if (sys.homing_phase != HOMING_OFF) system_homing_step();
    system_supervise_encoders(now_us);
}

static uint8_t system_start_homing() {
    if (!settings.homing) return STAGE_ERROR_SETTING_DISABLED_HOMING;
    if (stepper_busy()) return STAGE_ERROR_IDLE_ERROR;
    system_stop_motion();
    stepper_take_limit_hits();
    sys.homing_axis = AXIS_X;
    system_homing_seek();
    return SYSTEM_DEFERRED;
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

uint8_t system_execute(const char* line) {
    bool idle = !stepper_busy();
    if (line[1] == '\0') {
        serial_print_flash(FLASH_TEXT("[HLP:$$ $I $H $X $N=value ? ! ~ ctrl-x]\r\n"));
        return 0;
    }
    if (line[1] == 'I' && line[2] == '\0') {
        report_build_info();
        return 0;
    }
    if (line[1] == '$' && line[2] == '\0') {
        if (!idle) return STAGE_ERROR_IDLE_ERROR;
        report_settings();
        return 0;
    }
    if (line[1] == 'H' && line[2] == '\0') return system_start_homing();
    if (line[1] == 'X' && line[2] == '\0') {
        if (sys.locked) {
            sys.locked = false;
            system_resync_encoders();
            report_message(FLASH_TEXT("Caution: Unlocked"));
        }
        return 0;
    }
    if (line[1] >= '0' && line[1] <= '9') {
        if (!idle) return STAGE_ERROR_IDLE_ERROR;
        return system_set_setting(line);
    }
    return STAGE_ERROR_INVALID_STATEMENT;
}

void system_report_status() {
    float position[AXIS_COUNT];
    system_position_mm(position);
    serial_write('<');
    serial_print(system_state_name());
    serial_print_flash(FLASH_TEXT("|MPos:"));
    report_float(position[AXIS_X], 3);
    serial_write(',');
    report_float(position[AXIS_Y], 3);
    serial_print_flash(FLASH_TEXT(",0.000|FS:"));
    report_uint(stepper_speed_mm_min());
    serial_print_flash(FLASH_TEXT(",0"));
    if (settings.encoder_present && encoders_valid()) {
        serial_print_flash(FLASH_TEXT("|Enc:"));
        report_float(encoders_position_mm(AXIS_X), 3);
        serial_write(',');
        report_float(encoders_position_mm(AXIS_Y), 3);
    }
    if (hal_limit_pressed(AXIS_X) || hal_limit_pressed(AXIS_Y)) {
        serial_print_flash(FLASH_TEXT("|Pn:"));
        if (hal_limit_pressed(AXIS_X)) serial_write('X');
        if (hal_limit_pressed(AXIS_Y)) serial_write('Y');
    }
    serial_print_flash(FLASH_TEXT(">\r\n"));
}
