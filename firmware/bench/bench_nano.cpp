// Cycles of the whisker_nano core's CPU work per sample, I2C excluded (the bus time is computed
// from the 400 kHz clock in docs/firmware.md): frame encoding with its CRC, the sampler's read
// path, the command parser. Built by `make -C firmware bench`, run under simavr.
#include "../whisker_nano/wn_command.h"
#include "../whisker_nano/wn_frame.h"
#include "../whisker_nano/wn_hal.h"
#include "../whisker_nano/wn_mlx.h"
#include "../whisker_nano/wn_sampler.h"
#include "avr_bench.h"

static uint32_t bench_now_us;

// Stub board: an MLX90393 that answers at once with fixed data, a UART that takes everything.
uint32_t hal_micros() { return bench_now_us; }
bool hal_i2c_transfer(uint8_t, const uint8_t*, uint8_t, uint8_t* rx, uint8_t nrx) {
    for (uint8_t i = 0; i < nrx; ++i) rx[i] = (uint8_t)(0x80 + i);
    return true;
}
uint16_t hal_tx_free() { return 64; }
void hal_tx_write(const uint8_t*, uint8_t) {}

int main() {
    bench_uart_init();
    frame_sample sample = {1234, 5678901UL, {-1200, 14600, 300}, 0};
    uint8_t frame[FRAME_SAMPLE_SIZE];
    bench_timer_start();
    frame_encode_sample(sample, frame);
    bench_report("frame_encode_sample", bench_timer_read());

    sampler_state sampler;
    sampler_init(sampler);
    sampler_start(sampler, 0);
    bench_now_us = 3334;       // the first conversion is due one period after START
    sampler_poll(sampler, bench_now_us);  // configures the sensor and starts the first conversion
    bench_now_us = 3334 + 2000;           // conversion done (1.84 ms)
    bench_timer_start();
    sampler_poll(sampler, bench_now_us);  // read, convert, frame, queue
    bench_report("sampler_read_and_send", bench_timer_read());
    bench_now_us = 2 * 3334;
    bench_timer_start();
    sampler_poll(sampler, bench_now_us);  // start the next conversion
    bench_report("sampler_start_conversion", bench_timer_read());
    bench_timer_start();
    sampler_poll(sampler, bench_now_us + 10);  // nothing due: the idle loop's cost
    bench_report("sampler_idle_poll", bench_timer_read());

    char answer[FRAME_TEXT_MAX + 1];
    sampler_stop(sampler);
    bench_timer_start();
    command_execute("CFG?", sampler, 0, answer);
    bench_report("command_cfg", bench_timer_read());
    bench_end();
}
