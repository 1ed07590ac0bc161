// Cycles of stage_stepper's step interrupt and segment preparation on the ATmega328P, with
// stub pins (the real ones add a 3 µs pulse). Built by `make -C firmware bench`, run under simavr.
#include "../stage_stepper/config.h"
#include "../stage_stepper/hal.h"
#include "../stage_stepper/planner.h"
#include "../stage_stepper/settings.h"
#include "../stage_stepper/stepper.h"
#include "avr_bench.h"

void hal_init() {}
uint32_t hal_micros() { return 0; }
void hal_serial_kick_tx() {}
void hal_step_timer_start(uint16_t) {}
void hal_step_timer_set(uint16_t) {}
void hal_step_timer_stop() {}
void hal_step_pulse(uint8_t, uint8_t) {}
bool hal_limit_pressed(uint8_t) { return false; }
bool hal_encoder_read(uint8_t, uint8_t*, uint16_t*) { return false; }
void hal_eeprom_read(uint16_t, uint8_t* data, uint16_t n) {
    for (uint16_t i = 0; i < n; ++i) data[i] = 0xFF;
}
void hal_eeprom_write(uint16_t, const uint8_t*, uint16_t) {}
void hal_interrupts_off() {}
void hal_interrupts_on() {}

int main() {
    bench_uart_init();
    settings_load();
    planner_init();
    stepper_init();
    int32_t target[AXIS_COUNT] = {8000, 6000};  // 100 mm x 75 mm diagonal
    bench_timer_start();
    planner_add_move(target, 3000.0f, BLOCK_MOVE);
    bench_report("planner_add_move", bench_timer_read());
    bench_timer_start();
    stepper_prep();  // fills the segment buffer: 5 segments
    bench_report("stepper_prep_5_segments", bench_timer_read());
    uint16_t longest = 0, first = 0;
    for (uint16_t i = 0; i < 200; ++i) {
        bench_timer_start();
        stepper_isr();
        uint16_t cycles = bench_timer_read();
        if (i == 0) first = cycles;
        if (cycles > longest && i > 0) longest = cycles;
    }
    bench_report("stepper_isr_segment_load", first);
    bench_report("stepper_isr_step_max", longest);
    bench_end();
}
