#include "fake_board.h"

#include <cmath>
#include <cstring>

#include "../config.h"
#include "../hal.h"
#include "../serial.h"
#include "../stage.h"
#include "../stepper.h"

fake_board board;

fake_board::fake_board() { std::memset(eeprom, 0xFF, sizeof eeprom); }  // erased EEPROM

double fake_position_mm(int axis) {
    return board.axes[axis].start_mm + (double)board.axes[axis].motor_steps / board.steps_per_mm;
}

void hal_init() {}

uint32_t hal_micros() { return (uint32_t)board.now_us; }

void hal_serial_kick_tx() {
    for (int16_t c = serial_next_tx(); c >= 0; c = serial_next_tx()) board.tx.push_back((char)c);
}

static uint64_t fake_period_ns() { return (uint64_t)board.timer_period_ticks * 1000000000ULL / STEP_TIMER_HZ; }

void hal_step_timer_start(uint16_t period_ticks) {
    board.timer_running = true;
    board.timer_period_ticks = period_ticks;
    board.next_tick_ns = board.now_us * 1000ULL + fake_period_ns();
}

void hal_step_timer_set(uint16_t period_ticks) { board.timer_period_ticks = period_ticks; }

void hal_step_timer_stop() { board.timer_running = false; }

void hal_step_pulse(uint8_t step_bits, uint8_t direction_bits) {
    for (int axis = 0; axis < 2; ++axis) {
        if (!(step_bits & (1 << axis))) continue;
        int step = (direction_bits & (1 << axis)) ? -1 : 1;
        fake_axis& a = board.axes[axis];
        a.commanded_steps += step;
        bool stalled = fake_position_mm(axis) >= a.stall_beyond_mm && step > 0;
        if (!stalled) a.motor_steps += step;
    }
}

bool hal_limit_pressed(uint8_t axis) { return fake_position_mm(axis) <= 0.0; }

bool hal_encoder_read(uint8_t axis, uint8_t* status, uint16_t* raw_angle) {
    const fake_axis& a = board.axes[axis];
    if (a.encoder_silent) return false;
    *status = a.magnet_missing ? 0x10 : 0x20;  // ML (too weak) without MD, or MD
    double turns = fake_position_mm(axis) / board.mm_per_turn;
    long counts = (long)std::floor(turns * 4096.0) + a.angle_offset;
    *raw_angle = (uint16_t)(((counts % 4096) + 4096) % 4096);
    return true;
}

void hal_eeprom_read(uint16_t address, uint8_t* data, uint16_t n) { std::memcpy(data, board.eeprom + address, n); }

void hal_eeprom_write(uint16_t address, const uint8_t* data, uint16_t n) { std::memcpy(board.eeprom + address, data, n); }

void hal_interrupts_off() {}
void hal_interrupts_on() {}

void fake_receive(const std::string& bytes) {
    for (char c : bytes) serial_receive_byte((uint8_t)c);
}

void fake_run(double dt_us, double loop_us) {
    uint64_t end_ns = board.now_us * 1000ULL + (uint64_t)(dt_us * 1000.0);
    uint64_t next_loop_ns = board.now_us * 1000ULL;
    for (;;) {
        uint64_t next_ns = next_loop_ns;
        bool tick = board.timer_running && board.next_tick_ns <= next_ns;
        if (tick) next_ns = board.next_tick_ns;
        if (next_ns > end_ns) break;
        board.now_us = next_ns / 1000ULL;
        if (tick) {
            stepper_isr();  // the period set inside applies to the next tick, as in CTC mode
            board.next_tick_ns += fake_period_ns();
        } else {
            stage_loop();
            next_loop_ns += (uint64_t)(loop_us * 1000.0);
        }
    }
    board.now_us = end_ns / 1000ULL;
}
