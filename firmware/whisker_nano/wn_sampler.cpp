#include "wn_sampler.h"

#include "wc_codes.h"
#include "wn_frame.h"
#include "wn_hal.h"

void sampler_init(sampler_state& s) {
    s.mlx.gain = 5;
    s.mlx.res = 2;
    s.mlx.osr = 0;
    s.mlx.filt = 2;
    s.rate_hz = SAMPLER_RATE_DEFAULT_HZ;
    s.streaming = false;
    s.converting = false;
    s.sensor_configured = false;
    s.seq = 0;
    s.period_us = 1000000UL / SAMPLER_RATE_DEFAULT_HZ;
    s.next_due_us = 0;
    s.started_us = 0;
    s.commanded_us = 0;
    s.carried_status = 0;
    s.frames_dropped = 0;
}

bool sampler_fits(uint16_t rate_hz, uint8_t osr, uint8_t filt) {
    uint32_t busy_us = (uint32_t)mlx_conversion_time_us(osr, filt) + SAMPLER_I2C_OVERHEAD_US;
    return busy_us <= 1000000UL / rate_hz;
}

void sampler_start(sampler_state& s, uint32_t now_us) {
    s.period_us = 1000000UL / s.rate_hz;
    // The first conversion one period after START, as every later one: the START answer is
    // framed before the loop polls again, so starting "now" made the first period short.
    s.next_due_us = now_us + s.period_us;
    s.converting = false;
    s.sensor_configured = false;  // settings may have changed while stopped
    s.carried_status = 0;
    s.streaming = true;
}

void sampler_stop(sampler_state& s) {
    s.streaming = false;
    s.converting = false;
}

static void sampler_emit(sampler_state& s, uint32_t t_us, const int16_t counts[3], uint8_t status) {
    frame_sample sample;
    sample.seq = s.seq++;  // counted even when dropped, so the host sees the gap
    sample.t_us = t_us;
    for (uint8_t axis = 0; axis < 3; ++axis) sample.counts[axis] = counts[axis];
    sample.status = (uint8_t)(status | s.carried_status);
    if (hal_tx_free() < FRAME_SAMPLE_SIZE) {
        // NOTE: never block on the UART here: a blocked loop would delay the next conversion.
        s.carried_status |= SENSOR_STATUS_TX_OVERFLOW;
        ++s.frames_dropped;
        return;
    }
    s.carried_status = 0;
    uint8_t frame[FRAME_SAMPLE_SIZE];
    hal_tx_write(frame, frame_encode_sample(sample, frame));
}

static void sampler_emit_missing(sampler_state& s, uint32_t t_us) {
    static const int16_t no_counts[3] = {0, 0, 0};
    s.sensor_configured = false;
    sampler_emit(s, t_us, no_counts, SENSOR_STATUS_NO_SENSOR);
}

static void sampler_begin_conversion(sampler_state& s, uint32_t now_us) {
    s.next_due_us += s.period_us;
    if ((int32_t)(now_us - s.next_due_us) >= 0) {
        // More than a period behind (a long stall): restart the schedule instead of bursting.
        s.next_due_us = now_us + s.period_us;
        s.carried_status |= SENSOR_STATUS_LATE;
    }
    if (!s.sensor_configured) s.sensor_configured = mlx_configure(s.mlx);
    int16_t status = s.sensor_configured ? mlx_start_measurement() : -1;
    if (status < 0) {
        sampler_emit_missing(s, now_us);
        return;
    }
    s.started_us = now_us;
    // NOTE: the chip converts from the SM command on, which comes after the configuration
    // writes and the command's own bytes: counting from now_us read it early (status ERROR).
    s.commanded_us = hal_micros();
    s.converting = true;
}

static void sampler_finish_conversion(sampler_state& s, uint32_t now_us) {
    s.converting = false;
    uint16_t raw[3];
    int16_t mlx_status = mlx_read_measurement(raw);
    if (mlx_status < 0) {
        sampler_emit_missing(s, s.started_us);
        return;
    }
    uint8_t status = 0;
    if (mlx_status & MLX_STATUS_ERROR) status |= SENSOR_STATUS_MLX_ERROR;
    if ((int32_t)(now_us - s.next_due_us) > 0) status |= SENSOR_STATUS_LATE;
    bool saturated = false;
    int16_t counts[3];
    for (uint8_t axis = 0; axis < 3; ++axis) counts[axis] = mlx_signed_counts(raw[axis], s.mlx.res, &saturated);
    if (saturated) status |= SENSOR_STATUS_SATURATED;
    sampler_emit(s, s.started_us, counts, status);
}

void sampler_poll(sampler_state& s, uint32_t now_us) {
    if (!s.streaming) return;
    if (s.converting) {
        uint32_t conversion_us = mlx_conversion_time_us(s.mlx.osr, s.mlx.filt);
        if (now_us - s.commanded_us >= conversion_us) sampler_finish_conversion(s, now_us);
        return;
    }
    if ((int32_t)(now_us - s.next_due_us) >= 0) sampler_begin_conversion(s, now_us);
}
