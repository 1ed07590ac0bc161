// Host unit tests of the stage_stepper core: number formatting and parsing, the G-code subset,
// settings with checksum, the planner and the velocity profile, encoder turn counting, and the
// whole firmware against a simulated stage (homing, holds, resets, alarms, encoder faults).
#include <cmath>
#include <cstring>
#include <string>

#include "../../common/host_test.h"
#include "../encoders.h"
#include "../gcode.h"
#include "../planner.h"
#include "../report.h"
#include "../settings.h"
#include "../stage.h"
#include "../stepper.h"
#include "../system.h"
#include "fake_board.h"
#include "wc_codes.h"

static bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// Power-up of a fresh board with its carriages at start_mm from the switches; keep_eeprom
// carries settings over a power cycle.
static void power_up(bool keep_eeprom = false, double start_x_mm = 50.0, double start_y_mm = 50.0) {
    uint8_t eeprom[sizeof board.eeprom];
    std::memcpy(eeprom, board.eeprom, sizeof eeprom);
    board = fake_board();
    board.axes[0].start_mm = start_x_mm;
    board.axes[1].start_mm = start_y_mm;
    if (keep_eeprom) std::memcpy(board.eeprom, eeprom, sizeof eeprom);
    stage_init();
    fake_run(1000);
}

// Sends bytes, runs for run_ms of simulated time, returns what the board printed meanwhile.
static std::string exchange(const std::string& bytes, double run_ms = 5.0) {
    board.tx.clear();
    fake_receive(bytes);
    fake_run(run_ms * 1000.0);
    return board.tx;
}

static std::string state() {
    std::string report = exchange("?", 1.0);
    size_t start = report.find('<');
    size_t end = report.find_first_of("|>", start);
    return start == std::string::npos ? "<none>" : report.substr(start + 1, end - start - 1);
}

// Field "Name:a,b" of a status report as two numbers.
static bool field(const std::string& report, const char* name, double* a, double* b) {
    size_t at = report.find(std::string("|") + name + ":");
    if (at == std::string::npos) return false;
    return std::sscanf(report.c_str() + at + std::strlen(name) + 2, "%lf,%lf", a, b) == 2;
}

static void unlocked(double start_x_mm = 50.0) {
    power_up(false, start_x_mm);
    exchange("$X\n");
}

TEST(float_formatting_rounds_to_three_decimals) {
    char text[16];
    CHECK_STR(report_format_float(12.0f, 3, text), "12.000");
    CHECK_STR(report_format_float(-3.0f, 3, text), "-3.000");
    CHECK_STR(report_format_float(-0.0004f, 3, text), "0.000");
    CHECK_STR(report_format_float(0.0006f, 3, text), "0.001");
    CHECK_STR(report_format_float(123.4567f, 3, text), "123.457");
    CHECK_STR(report_format_float(80.0f, 0, text), "80");
}

TEST(numbers_parse_or_refuse) {
    float value = 0.0f;
    const char* text = "12.5X";
    CHECK(gcode_read_number(&text, &value));
    CHECK_NEAR(value, 12.5, 1e-6);
    CHECK(*text == 'X');
    text = "-0.25";
    CHECK(gcode_read_number(&text, &value) && std::fabs(value + 0.25f) < 1e-7f);
    text = "+3";
    CHECK(gcode_read_number(&text, &value) && value == 3.0f);
    text = ".";
    CHECK(!gcode_read_number(&text, &value));
    text = "-";
    CHECK(!gcode_read_number(&text, &value));
}

TEST(gcode_moves_follow_modal_rules) {
    settings_defaults(settings);
    gcode_modal modal;
    gcode_init(modal);
    gcode_action action;
    float at[2] = {10.0f, 20.0f};
    CHECK_EQ(gcode_parse("G0X15", modal, at, action), 0);
    CHECK(action.kind == GCODE_MOVE && action.target_mm[0] == 15.0f && action.target_mm[1] == 20.0f);
    CHECK_EQ(gcode_parse("G91G0X-5Y2.5", modal, at, action), 0);
    CHECK(action.target_mm[0] == 5.0f && action.target_mm[1] == 22.5f);
    CHECK(modal.incremental);
    CHECK_EQ(gcode_parse("G90", modal, at, action), 0);
    CHECK(action.kind == GCODE_NOTHING && !modal.incremental);
    CHECK_EQ(gcode_parse("G1X1", modal, at, action), STAGE_ERROR_UNDEFINED_FEED_RATE);
    CHECK_EQ(modal.motion, 0);  // unchanged by the refused line
    CHECK_EQ(gcode_parse("G1X1F600", modal, at, action), 0);
    CHECK(action.feed_mm_min == 600.0f && modal.motion == 1);
    CHECK_EQ(gcode_parse("X2", modal, at, action), 0);  // modal G1 and feed carry on
    CHECK(action.kind == GCODE_MOVE && action.feed_mm_min == 600.0f);
    CHECK_EQ(gcode_parse("N10G0X3", modal, at, action), 0);
}

TEST(gcode_errors_use_the_code_table) {
    settings_defaults(settings);
    gcode_modal modal;
    gcode_init(modal);
    gcode_action action;
    float at[2] = {0.0f, 0.0f};
    CHECK_EQ(gcode_parse("G1X1F-5", modal, at, action), STAGE_ERROR_NEGATIVE_VALUE);
    CHECK_EQ(gcode_parse("X10X5", modal, at, action), STAGE_ERROR_WORD_REPEATED);
    CHECK_EQ(gcode_parse("G0G1X1", modal, at, action), STAGE_ERROR_AXIS_WORDS_CONFLICT);
    CHECK_EQ(gcode_parse("M3", modal, at, action), STAGE_ERROR_UNSUPPORTED_COMMAND);
    CHECK_EQ(gcode_parse("G38.2X1", modal, at, action), STAGE_ERROR_UNSUPPORTED_COMMAND);
    CHECK_EQ(gcode_parse("Z1", modal, at, action), STAGE_ERROR_UNSUPPORTED_COMMAND);
    CHECK_EQ(gcode_parse("10", modal, at, action), STAGE_ERROR_EXPECTED_COMMAND_LETTER);
    CHECK_EQ(gcode_parse("GX", modal, at, action), STAGE_ERROR_BAD_NUMBER_FORMAT);
    CHECK_EQ(gcode_parse("G4", modal, at, action), STAGE_ERROR_VALUE_WORD_MISSING);
    CHECK_EQ(gcode_parse("G4G4P1", modal, at, action), STAGE_ERROR_MODAL_GROUP_VIOLATION);
    CHECK_EQ(gcode_parse("G90G91", modal, at, action), STAGE_ERROR_MODAL_GROUP_VIOLATION);
    CHECK_EQ(gcode_parse("G17G17", modal, at, action), STAGE_ERROR_MODAL_GROUP_VIOLATION);
    CHECK_EQ(gcode_parse("G1", modal, at, action), STAGE_ERROR_UNDEFINED_FEED_RATE);
    CHECK_EQ(gcode_parse("G4P0.5", modal, at, action), 0);
    CHECK(action.kind == GCODE_DWELL && action.dwell_s == 0.5f);
}

TEST(gcode_blocks_follow_grbl) {
    settings_defaults(settings);
    gcode_modal modal;
    gcode_init(modal);
    gcode_action action;
    float at[2] = {10.0f, 20.0f};
    CHECK_EQ(gcode_parse("G17", modal, at, action), 0);
    CHECK_EQ(gcode_parse("G94", modal, at, action), 0);
    CHECK_EQ(gcode_parse("G17G21G90G94", modal, at, action), 0);
    CHECK(action.kind == GCODE_NOTHING);
    CHECK_EQ(gcode_parse("G1F300", modal, at, action), 0);  // no axis words: the mode only
    CHECK(action.kind == GCODE_NOTHING && modal.motion == 1 && modal.feed_mm_min == 300.0f);
    CHECK_EQ(gcode_parse("G0G4P0.1", modal, at, action), 0);  // groups 1 and 0: no conflict
    CHECK(action.kind == GCODE_DWELL && action.dwell_s == 0.1f && modal.motion == 0);
    CHECK_EQ(gcode_parse("G4P0.2X5", modal, at, action), 0);  // dwell, then a move in the mode
    CHECK(action.kind == (GCODE_DWELL | GCODE_MOVE) && action.target_mm[0] == 5.0f && action.target_mm[1] == 20.0f);
    CHECK_EQ(gcode_parse("G4P0.2X500", modal, at, action), STAGE_ERROR_TRAVEL_EXCEEDED);
}

TEST(soft_limits_refuse_targets_outside_travel) {
    settings_defaults(settings);
    gcode_modal modal;
    gcode_init(modal);
    gcode_action action;
    float at[2] = {0.0f, 0.0f};
    CHECK_EQ(gcode_parse("G0X200Y0", modal, at, action), 0);
    CHECK_EQ(gcode_parse("G0X200.1", modal, at, action), STAGE_ERROR_TRAVEL_EXCEEDED);
    CHECK_EQ(gcode_parse("G0Y-0.5", modal, at, action), STAGE_ERROR_TRAVEL_EXCEEDED);
    settings.soft_limits = 0;
    CHECK_EQ(gcode_parse("G0Y-0.5", modal, at, action), 0);
}

TEST(fletcher16_check_values) {
    // Published Fletcher-16 values: "abcde" -> 0xC8F0, "abcdef" -> 0x2057.
    CHECK_EQ(settings_checksum((const uint8_t*)"abcde", 5), 0xC8F0);
    CHECK_EQ(settings_checksum((const uint8_t*)"abcdef", 6), 0x2057);
}

TEST(settings_fall_back_to_defaults_on_bad_eeprom) {
    board = fake_board();                  // erased EEPROM
    CHECK(!settings_load());
    CHECK_EQ((int)settings.steps_per_mm[0], 80);
    CHECK(settings_load());                // the defaults were stored
    CHECK_EQ(settings_set(100, 100.0f), 0);
    settings_defaults(settings);
    CHECK(settings_load());
    CHECK_NEAR(settings.steps_per_mm[0], 100.0, 1e-6);
    board.eeprom[7] ^= 0x01;               // one flipped bit in a value
    CHECK(!settings_load());
    CHECK_NEAR(settings.steps_per_mm[0], 80.0, 1e-6);
    board.eeprom[0] = SETTINGS_VERSION + 1;  // a record of another layout
    CHECK(!settings_load());
}

TEST(settings_are_validated) {
    board = fake_board();
    settings_load();
    CHECK_EQ(settings_set(20, 2.0f), STAGE_ERROR_COMMAND_VALUE_NOT_INTEGER);
    CHECK_EQ(settings_set(100, -1.0f), STAGE_ERROR_NEGATIVE_VALUE);
    CHECK_EQ(settings_set(100, 0.0f), STAGE_ERROR_BAD_NUMBER_FORMAT);
    CHECK_EQ(settings_set(999, 1.0f), STAGE_ERROR_INVALID_STATEMENT);
    CHECK_EQ(settings_set(102, 1.0f), STAGE_ERROR_INVALID_STATEMENT);   // there is no Z axis
    CHECK_EQ(settings_set(110, 7600.0f), STAGE_ERROR_BAD_NUMBER_FORMAT);  // 10.1 kHz of steps
    CHECK_EQ(settings_set(110, 7400.0f), 0);                              // 9.9 kHz
    CHECK_EQ(settings_set(202, 0.25f), 0);
    CHECK_NEAR(settings_get(202), 0.25, 1e-7);
}

TEST(planner_limits_speed_and_acceleration_per_axis) {
    board = fake_board();
    settings_load();
    planner_init();
    int32_t target[2] = {30 * 80, 40 * 80};  // 30 mm, 40 mm: 50 mm long, Y has 80% of it
    CHECK(planner_add_move(target, 1.0e9f, BLOCK_MOVE));
    planner_block* block = planner_current();
    CHECK(block != 0);
    CHECK_NEAR(block->millimeters, 50.0, 1e-4);
    CHECK_NEAR(block->nominal_speed_mm_s, 50.0 / 0.8, 1e-3);
    CHECK_NEAR(block->accel_mm_s2, 200.0 / 0.8, 1e-3);
    CHECK_EQ(block->step_event_count, 3200);
    CHECK(planner_add_move(target, 600.0f, BLOCK_MOVE));  // zero length: nothing queued
    planner_discard();
    CHECK(planner_empty());
    CHECK_EQ(planner_free(), PLANNER_BLOCKS - 1);
    for (int i = 0; i < PLANNER_BLOCKS - 1; ++i) CHECK(planner_add_dwell(0.1f));
    CHECK(planner_full() && planner_free() == 0 && !planner_add_dwell(0.1f));
}

// Integrates a whole block segment by segment; returns the duration, s.
static double integrate_block(float length, float nominal, float accel, double* max_speed, double* max_accel) {
    float v = 0.0f, left = length;
    double t = 0.0;
    *max_speed = *max_accel = 0.0;
    for (int i = 0; i < 100000; ++i) {
        stepper_segment_plan plan = stepper_plan_segment(v, left, nominal, accel, false);
        left -= plan.mm;
        t += plan.seconds;
        if (!plan.block_done) *max_accel = std::fmax(*max_accel, std::fabs(plan.speed_end_mm_s - v) / plan.seconds);
        *max_speed = std::fmax(*max_speed, plan.speed_end_mm_s);
        v = plan.speed_end_mm_s;
        if (plan.block_done) return t;
    }
    return -1.0;
}

TEST(velocity_profile_is_trapezoidal) {
    double vmax, amax;
    double t = integrate_block(100.0f, 50.0f, 200.0f, &vmax, &amax);
    CHECK(t >= 100.0 / 50.0 + 50.0 / 200.0 - 1e-3 && t <= 100.0 / 50.0 + 50.0 / 200.0 + 2 * SEGMENT_S);  // s/v + v/a
    CHECK_NEAR(vmax, 50.0, 1e-3);
    CHECK(amax <= 200.0 * 1.001);
    t = integrate_block(1.0f, 50.0f, 200.0f, &vmax, &amax);  // too short to cruise: a triangle
    CHECK_NEAR(t, 2.0 * std::sqrt(1.0 / 200.0), 0.01);
    CHECK(vmax <= std::sqrt(200.0 * 1.0));
    // Over many lengths and limits: never above the acceleration, within two segments of the
    // ideal profile (the last segment may end up to 1 ms early: a stop from below 0.2 mm/s).
    for (float length = 0.05f; length < 150.0f; length *= 1.37f) {
        for (float accel = 50.0f; accel <= 800.0f; accel *= 2.0f) {
            t = integrate_block(length, 50.0f, accel, &vmax, &amax);
            double cruise_mm = length - 50.0 * 50.0 / accel;
            double ideal = cruise_mm > 0 ? length / 50.0 + 50.0 / accel : 2.0 * std::sqrt(length / accel);
            CHECK(amax <= accel * 1.0001);
            CHECK(t >= ideal - 1e-3 && t <= ideal + 2 * SEGMENT_S);
        }
    }
}

TEST(feed_hold_stops_within_the_braking_distance) {
    float v = 50.0f, travelled = 0.0f;
    bool stopped = false;
    for (int i = 0; i < 1000 && !stopped; ++i) {
        stepper_segment_plan plan = stepper_plan_segment(v, 1000.0f, 50.0f, 200.0f, true);
        travelled += plan.mm;
        v = plan.speed_end_mm_s;
        stopped = plan.stopped;
    }
    CHECK(stopped);
    CHECK_NEAR(travelled, 50.0 * 50.0 / (2.0 * 200.0), 0.01);
}

TEST(encoder_turns_are_counted_across_the_wrap) {
    CHECK_EQ(encoders_unwrap(0, 4090, 5), 11);
    CHECK_EQ(encoders_unwrap(100, 5, 4090), 89);
    CHECK_EQ(encoders_unwrap(0, 0, 2047), 2047);
    CHECK_EQ(encoders_unwrap(0, 0, 2048), -2048);
}

TEST(power_up_prints_banner_and_locks) {
    board = fake_board();
    stage_init();
    CHECK(contains(board.tx, "Grbl 1.1h ['$' for help]"));
    CHECK(contains(board.tx, "[MSG:EEPROM settings invalid, defaults restored]"));
    fake_run(1000);
    CHECK_STR(state(), "Alarm");
    CHECK(contains(exchange("G0X1\n"), "error:9"));
    CHECK(contains(exchange("$X\n"), "ok"));
    CHECK_STR(state(), "Idle");
    power_up(true);
    CHECK(!contains(board.tx, "EEPROM settings invalid"));  // stored on the first power-up
}

TEST(move_reaches_target_and_encoders_agree) {
    unlocked();
    CHECK(contains(exchange("G0X10Y5\n"), "ok"));
    CHECK_STR(state(), "Run");
    fake_run(2e6);
    std::string report = exchange("?", 1.0);
    CHECK(contains(report, "<Idle|MPos:10.000,5.000,0.000|FS:0,0|Enc:"));
    double ex = 0, ey = 0;
    CHECK(field(report, "Enc", &ex, &ey));
    CHECK_NEAR(ex, 10.0, 40.0 / 4096.0 + 1e-3);  // one encoder count is 0.0098 mm
    CHECK_NEAR(ey, 5.0, 40.0 / 4096.0 + 1e-3);
    CHECK_NEAR(fake_position_mm(0) - board.axes[0].start_mm, 10.0, 1e-9);
    CHECK_NEAR(fake_position_mm(1) - board.axes[1].start_mm, 5.0, 1e-9);
}

TEST(move_duration_follows_the_trapezoid) {
    unlocked();
    exchange("G1X100F3000\n", 0.0);
    fake_run(2.10e6);
    CHECK_STR(state(), "Run");
    fake_run(0.25e6);  // 2.25 s in theory, plus up to a segment of start-up latency
    CHECK_STR(state(), "Idle");
}

TEST(status_is_answered_while_moving) {
    unlocked();
    exchange("G1X50F3000\n", 500.0);
    std::string report = exchange("?", 0.2);
    CHECK(contains(report, "<Run|"));
    double x = 0, y = 0, feed = 0, spindle = 0;
    CHECK(field(report, "MPos", &x, &y));
    CHECK(x > 5.0 && x < 45.0);
    CHECK(field(report, "FS", &feed, &spindle));
    CHECK(feed > 1000.0 && feed <= 3000.0);
}

TEST(feed_hold_and_resume) {
    unlocked();
    exchange("G1X100F3000\n", 500.0);
    CHECK_STR(exchange("!", 1.0).empty() ? state() : "<printed>", "Hold:1");
    fake_run(0.5e6);
    CHECK_STR(state(), "Hold:0");
    double x1 = 0, y1 = 0, x2 = 0, y2 = 0;
    field(exchange("?", 1.0), "MPos", &x1, &y1);
    fake_run(0.5e6);
    field(exchange("?", 1.0), "MPos", &x2, &y2);
    CHECK(x1 > 10.0 && x1 == x2);
    exchange("~", 3000.0);
    CHECK(contains(exchange("?", 1.0), "<Idle|MPos:100.000,0.000"));
}

TEST(soft_reset_stops_and_alarms) {
    unlocked();
    exchange("G1X100F3000\n", 500.0);
    std::string output = exchange("\x18", 5.0);
    CHECK(contains(output, "ALARM:3"));
    CHECK(contains(output, "Grbl 1.1h"));
    CHECK_STR(state(), "Alarm");
    double x1 = 0, y1 = 0, x2 = 0, y2 = 0;
    field(exchange("?", 1.0), "MPos", &x1, &y1);
    fake_run(0.5e6);
    field(exchange("?", 1.0), "MPos", &x2, &y2);
    CHECK(x1 == x2);
}

TEST(soft_reset_at_rest_keeps_the_unlock_and_forgets_modal_state) {
    unlocked();
    exchange("G91G1X1F600\n", 500.0);
    std::string output = exchange("\x18", 5.0);
    CHECK(contains(output, "Grbl 1.1h") && !contains(output, "ALARM"));
    CHECK_STR(state(), "Idle");
    CHECK(contains(exchange("G1X2\n"), "error:22"));  // feed rate and G91 were reset
    exchange("G0X2\n", 500.0);
    CHECK(contains(exchange("?", 1.0), "MPos:2.000,0.000"));
}

TEST(homing_finds_the_switches_and_sets_zero) {
    power_up(false, 37.3, 12.9);
    std::string output = exchange("$H\n", 100.0);
    CHECK(!contains(output, "ok"));      // answered once homing is done
    CHECK_STR(state(), "Home");
    output = exchange("", 15000.0);
    CHECK(contains(output, "ok"));
    CHECK(contains(exchange("?", 1.0), "<Idle|MPos:0.000,0.000,0.000"));
    CHECK_NEAR(fake_position_mm(0), HOMING_PULLOFF_MM, 1.0 / 80.0 + 1e-9);
    CHECK_NEAR(fake_position_mm(1), HOMING_PULLOFF_MM, 1.0 / 80.0 + 1e-9);
    exchange("G0X20Y30\n", 3000.0);
    CHECK_NEAR(fake_position_mm(0), 20.0 + HOMING_PULLOFF_MM, 1.0 / 80.0 + 1e-9);
}

TEST(homing_without_a_switch_fails) {
    power_up(false, 50.0, 500.0);  // Y beyond the search distance
    std::string output = exchange("$H\n", 60000.0);
    CHECK(contains(output, "ALARM:9"));
    CHECK_STR(state(), "Alarm");
    exchange("$22=0\n");
    CHECK(contains(exchange("$H\n"), "error:5"));
}

TEST(hard_limit_stops_with_alarm_1) {
    unlocked(3.0);
    exchange("$20=0\n");
    std::string output = exchange("G0X-10\n", 2000.0);
    CHECK(contains(output, "ALARM:1"));
    CHECK(fake_position_mm(0) > -0.02 && fake_position_mm(0) <= 0.0);
}

TEST(stall_raises_alarm_10) {
    unlocked();
    board.axes[0].stall_beyond_mm = board.axes[0].start_mm + 20.0;
    std::string output = exchange("G0X40\n", 3000.0);
    CHECK(contains(output, "ALARM:100"));
    CHECK_STR(state(), "Alarm");
    CHECK(board.axes[0].commanded_steps < 40 * 80);  // stopped before finishing the move
}

TEST(encoder_magnet_and_bus_faults_raise_alarms) {
    unlocked();
    board.axes[1].magnet_missing = true;
    CHECK(contains(exchange("", 20.0), "ALARM:101"));
    CHECK_EQ(std::string(exchange("", 50.0)).find("ALARM"), std::string::npos);  // pushed once
    unlocked();
    board.axes[0].encoder_silent = true;
    CHECK(contains(exchange("", 20.0), "ALARM:102"));
    exchange("$200=0\n");
    exchange("$X\n");
    std::string report = exchange("?", 20.0);
    CHECK(contains(report, "<Idle|") && !contains(report, "Enc:"));
}

TEST(dwell_is_queued_with_motion) {
    unlocked();
    exchange("G4P0.5\n", 300.0);
    CHECK_STR(state(), "Run");
    fake_run(0.3e6);
    CHECK_STR(state(), "Idle");
}

TEST(dwell_comes_before_the_move_of_its_block) {
    unlocked();
    exchange("G4P0.3X5\n", 200.0);
    CHECK_STR(state(), "Run");
    CHECK(fake_position_mm(0) == 50.0);  // still dwelling
    exchange("", 2000.0);
    CHECK(contains(exchange("?", 1.0), "<Idle|MPos:5.000,0.000"));
}

TEST(dwell_with_a_move_waits_for_two_planner_blocks) {
    unlocked();
    std::string lines;
    for (int i = 0; i < PLANNER_BLOCKS - 2; ++i) lines += "G4P1\n";
    exchange(lines, 50.0);
    CHECK_EQ(planner_free(), 1);
    CHECK(!contains(exchange("G4P0.1X5\n", 50.0), "ok"));  // held: only one block is free
    CHECK(contains(exchange("", 1000.0), "ok"));              // the first dwell ended
    exchange("", 8000.0);
    CHECK(contains(exchange("?", 1.0), "<Idle|MPos:5.000,0.000"));
}

TEST(help_anytime_settings_and_info_at_rest) {
    unlocked();
    CHECK_STR(exchange("$\n").c_str(), "[HLP:$$ $I $x=val $X $H ~ ! ? ctrl-x]\r\nok\r\n");
    exchange("G1X40F3000\n", 100.0);
    CHECK_STR(state(), "Run");
    CHECK(contains(exchange("$\n"), "[HLP:"));
    CHECK(contains(exchange("$I\n"), "error:8"));
    CHECK(contains(exchange("$$\n"), "error:8"));
    CHECK(contains(exchange("$Q\n"), "error:8"));  // as in grbl: the rest check comes first
}

TEST(system_commands_answer) {
    unlocked();
    std::string info = exchange("$I\n");
    CHECK(contains(info, "[VER:1.1h." STAGE_FIRMWARE_VERSION ":" STAGE_FIRMWARE_NAME "]"));
    CHECK(contains(info, "[PROTO:whiskercal-stage-1]"));
    CHECK(contains(info, "ok"));
    std::string list = exchange("$$\n");
    CHECK(contains(list, "$20=1\r\n") && contains(list, "$100=80.000\r\n") && contains(list, "$202=0.500\r\n"));
    CHECK(contains(exchange("$101=100\n"), "ok"));
    power_up(true);
    CHECK(contains(exchange("$$\n"), "$101=100.000"));
    CHECK(contains(exchange("$Q\n"), "error:3"));
    CHECK(contains(exchange(std::string(90, 'X') + "\n"), "error:11"));
    CHECK(contains(exchange("g0 x1 (comment) ; rest\n"), "error:9"));  // parsed, but locked
    exchange("$X\n");
    CHECK(contains(exchange("g0 x1 (comment) y2 ; rest\n", 500.0), "ok"));
    CHECK(contains(exchange("?", 1.0), "MPos:1.000,2.000"));
}

int main() { return run_all_tests(); }
