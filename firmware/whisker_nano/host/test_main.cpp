// Host unit tests of the whisker_nano core: frames and CRC, the MLX90393 driver, the command
// parser and the sampling state machine against a simulated sensor and clock.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "../../common/host_test.h"
#include "wc_codes.h"
#include "../wn_command.h"
#include "../wn_frame.h"
#include "../wn_mlx.h"
#include "../wn_sampler.h"
#include "fake_board.h"

struct decoded_frame {
    uint8_t type;
    std::vector<uint8_t> payload;
};

// Independent decoder: walks the byte stream, checks sync, length and CRC of every frame.
static std::vector<decoded_frame> decode_all(const std::vector<uint8_t>& bytes, int* bad) {
    std::vector<decoded_frame> frames;
    size_t i = 0;
    *bad = 0;
    while (i + 6 <= bytes.size()) {
        if (bytes[i] != 0xA5 || bytes[i + 1] != 0x5A) { ++*bad; ++i; continue; }
        uint8_t n = bytes[i + 3];
        if (i + 6 + n > bytes.size()) break;
        uint16_t crc = (uint16_t)(bytes[i + 4 + n] | (bytes[i + 5 + n] << 8));
        if (crc != frame_crc16(&bytes[i + 2], (uint8_t)(n + 2), 0xFFFF)) { ++*bad; ++i; continue; }
        frames.push_back({bytes[i + 2], std::vector<uint8_t>(bytes.begin() + i + 4, bytes.begin() + i + 4 + n)});
        i += 6 + n;
    }
    return frames;
}

static uint16_t u16(const std::vector<uint8_t>& p, size_t at) { return (uint16_t)(p[at] | (p[at + 1] << 8)); }

static std::string send(sampler_state& s, command_reader& r, const char* line) {
    board.tx.clear();
    for (const char* c = line; *c; ++c) command_receive(r, *c, s, board.now_us);
    command_receive(r, '\n', s, board.now_us);
    int bad = 0;
    std::vector<decoded_frame> frames = decode_all(board.tx, &bad);
    if (frames.size() != 1 || frames[0].type != FRAME_TYPE_TEXT || bad) return "<no single text frame>";
    return std::string(frames[0].payload.begin(), frames[0].payload.end());
}

static void reset_board() {
    board = fake_board();
}

// Runs the sampler for duration_us of simulated time, polling every step_us.
static void run_for(sampler_state& s, uint32_t duration_us, uint32_t step_us) {
    uint32_t end = board.now_us + duration_us;
    while ((int32_t)(board.now_us - end) < 0) {
        sampler_poll(s, board.now_us);
        board.now_us += step_us;
    }
}

TEST(crc16_ccitt_false_check_value) {
    // The catalogue check value of CRC-16/CCITT-FALSE for "123456789" is 0x29B1.
    const char* text = "123456789";
    CHECK_EQ(frame_crc16((const uint8_t*)text, 9, 0xFFFF), 0x29B1);
    CHECK_EQ(frame_crc16((const uint8_t*)text, 0, 0xFFFF), 0xFFFF);
}

TEST(sample_frame_layout_is_little_endian) {
    frame_sample sample = {0x1234, 0xA1B2C3D4UL, {-2, 300, -32768}, 0x05};
    uint8_t out[32];
    CHECK_EQ(frame_encode_sample(sample, out), 19);
    const uint8_t expected[17] = {0xA5, 0x5A, 0x01, 13, 0x34, 0x12, 0xD4, 0xC3, 0xB2, 0xA1,
                                  0xFE, 0xFF, 0x2C, 0x01, 0x00, 0x80, 0x05};
    CHECK(std::memcmp(out, expected, 17) == 0);
    uint16_t crc = frame_crc16(out + 2, 15, 0xFFFF);
    CHECK_EQ(out[17], crc & 0xFF);
    CHECK_EQ(out[18], crc >> 8);
}

TEST(text_frame_is_cut_at_its_maximum) {
    std::string longer(80, 'x');
    uint8_t out[FRAME_TEXT_MAX + FRAME_OVERHEAD];
    CHECK_EQ(frame_encode_text(longer.c_str(), out), FRAME_TEXT_MAX + FRAME_OVERHEAD);
    CHECK_EQ(out[3], FRAME_TEXT_MAX);
}

TEST(conversion_time_follows_the_datasheet) {
    CHECK_EQ(mlx_conversion_time_us(0, 2), 1840);   // the default: fits 3333 µs at 300 Hz
    CHECK_EQ(mlx_conversion_time_us(3, 3), 16050);
    // The formula used beyond DIG_FILT 3 reproduces the datasheet table within 10 µs.
    for (uint8_t filt = 0; filt <= 3; ++filt) {
        for (uint8_t osr = 0; osr <= 3; ++osr) {
            double formula = 3.0 * (67 + 64 * (1 << osr) * (2 + (1 << filt))) + 490;
            CHECK_NEAR(formula, mlx_conversion_time_us(osr, filt), 10);
        }
    }
    // Beyond the table the same formula, up to 200 ms (no 16-bit overflow).
    CHECK_NEAR(mlx_conversion_time_us(0, 4), 4150, 10);
    CHECK_NEAR(mlx_conversion_time_us(3, 7), 200370, 10);
    CHECK(sampler_fits(4, 3, 7) && !sampler_fits(5, 3, 7));
}

TEST(rate_limit_includes_the_i2c_exchange) {
    // DF2/OSR0: 1.84 ms + 0.36 ms = 2.20 ms, so 454 Hz fits and 455 Hz does not.
    CHECK(sampler_fits(454, 0, 2));
    CHECK(!sampler_fits(455, 0, 2));
}

TEST(which_settings_fit_300_hz) {
    // reference/README.md: DF0/OSR0-1, DF1/OSR0-1, DF2/OSR0, DF3/OSR0 fit 300 Hz.
    bool fits[4][4] = {{true, true, false, false}, {true, true, false, false},
                       {true, false, false, false}, {true, false, false, false}};
    for (uint8_t filt = 0; filt <= 3; ++filt)
        for (uint8_t osr = 0; osr <= 3; ++osr)
            CHECK_EQ(sampler_fits(300, osr, filt), fits[filt][osr]);
}

TEST(register_fields_are_placed_per_datasheet) {
    mlx_settings s = {7, 2, 0, 2};
    CHECK_EQ(mlx_register0(s), 0x7C);
    CHECK_EQ(mlx_register2(s), (2 << 9) | (2 << 7) | (2 << 5) | (2 << 2));
    mlx_settings t = {0, 1, 3, 7};
    CHECK_EQ(mlx_register0(t), 0x0C);
    CHECK_EQ(mlx_register2(t), (1 << 9) | (1 << 7) | (1 << 5) | (7 << 2) | 3);
}

TEST(signed_counts_remove_resolution_offsets) {
    bool sat = false;
    CHECK_EQ(mlx_signed_counts(0x8000, 2, &sat), 0);
    CHECK_EQ(mlx_signed_counts(0x7000, 2, &sat), -4096);
    CHECK_EQ(mlx_signed_counts(0x4000, 3, &sat), 0);
    CHECK_EQ(mlx_signed_counts(0xFFFE, 0, &sat), -2);
    CHECK(!sat);
    CHECK_EQ(mlx_signed_counts(0xFFFF, 2, &sat), 32767);
    CHECK(sat);
    bool sat3 = false;
    mlx_signed_counts(0x0000, 3, &sat3);
    CHECK(sat3);
}

TEST(early_read_sets_the_error_bit) {
    reset_board();
    uint16_t raw[3];
    CHECK(mlx_configure({7, 2, 0, 2}));
    CHECK(mlx_start_measurement() >= 0);
    board.now_us += 1000;  // conversion takes 1840 µs
    int16_t status = mlx_read_measurement(raw);
    CHECK(status >= 0 && (status & MLX_STATUS_ERROR));
    board.now_us += 1000;
    status = mlx_read_measurement(raw);
    CHECK(status >= 0 && !(status & MLX_STATUS_ERROR));
}

TEST(identify_and_default_configuration) {
    reset_board();
    sampler_state s; command_reader r;
    sampler_init(s); command_reader_init(r);
    CHECK_STR(send(s, r, "ID"), "OK whisker_nano fw=" WN_FIRMWARE_VERSION " proto=1");
    CHECK_STR(send(s, r, "CFG?"), "OK rate=300 gain=5 res=2 osr=0 filt=2");
}

TEST(commands_validate_their_values) {
    reset_board();
    sampler_state s; command_reader r;
    sampler_init(s); command_reader_init(r);
    CHECK_STR(send(s, r, "GAIN 8"), "ERR:2");
    CHECK_STR(send(s, r, "GAIN"), "ERR:2");
    CHECK_STR(send(s, r, "GAIN x"), "ERR:2");
    CHECK_STR(send(s, r, "RATE 0"), "ERR:2");
    CHECK_STR(send(s, r, "RATE 501"), "ERR:2");
    CHECK_STR(send(s, r, "OSR 3"), "ERR:4");
    CHECK_STR(send(s, r, "FILT 7"), "ERR:4");
    CHECK_STR(send(s, r, "RATE 100"), "OK");
    CHECK_STR(send(s, r, "OSR 3"), "ERR:4");   // DF2/OSR3: 9.91 ms + I2C > 10 ms
    CHECK_STR(send(s, r, "FILT 1"), "OK");
    CHECK_STR(send(s, r, "OSR 3"), "OK");
    CHECK_STR(send(s, r, "RATE 300"), "ERR:4");
    CHECK_STR(send(s, r, "GAINS 1"), "ERR:1");
    CHECK_STR(send(s, r, "HELLO"), "ERR:1");
    CHECK_STR(send(s, r, "CFG?"), "OK rate=100 gain=5 res=2 osr=3 filt=1");
}

TEST(long_line_is_refused_and_empty_line_ignored) {
    reset_board();
    sampler_state s; command_reader r;
    sampler_init(s); command_reader_init(r);
    CHECK_STR(send(s, r, std::string(100, 'A').c_str()), "ERR:6");
    board.tx.clear();
    command_receive(r, '\r', s, 0);
    command_receive(r, '\n', s, 0);
    CHECK(board.tx.empty());
    CHECK_STR(send(s, r, "ID\r"), "OK whisker_nano fw=" WN_FIRMWARE_VERSION " proto=1");
    CHECK_STR(send(s, r, " id "), "OK whisker_nano fw=" WN_FIRMWARE_VERSION " proto=1");
    CHECK_STR(send(s, r, "gain  6"), "OK");
    CHECK_STR(send(s, r, "GAIN 5 6"), "ERR:2");
    CHECK_STR(send(s, r, "GAINS"), "ERR:1");
    CHECK_STR(send(s, r, "cfg?"), "OK rate=300 gain=6 res=2 osr=0 filt=2");
}

TEST(settings_are_refused_while_streaming) {
    reset_board();
    sampler_state s; command_reader r;
    sampler_init(s); command_reader_init(r);
    CHECK_STR(send(s, r, "START"), "OK");
    CHECK_STR(send(s, r, "GAIN 3"), "ERR:3");
    CHECK_STR(send(s, r, "RATE 100"), "ERR:3");
    CHECK_STR(send(s, r, "STOP"), "OK");
    CHECK_STR(send(s, r, "GAIN 3"), "OK");
}

// A host's STOP arrives one byte at a time while the board streams at 300 Hz (115200 baud: one
// byte every 87 us, the loop polling in between): the line must be read whole and answered.
TEST(stop_is_answered_while_streaming) {
    reset_board();
    sampler_state s; command_reader r;
    sampler_init(s); command_reader_init(r);
    CHECK_STR(send(s, r, "START"), "OK");
    run_for(s, 500000UL, 7);
    board.tx.clear();
    for (const char* c = "STOP\n"; *c; ++c) {
        run_for(s, 87, 7);
        command_receive(r, *c, s, board.now_us);
    }
    run_for(s, 100000UL, 7);
    int bad = 0;
    std::vector<decoded_frame> frames = decode_all(board.tx, &bad);
    CHECK_EQ(bad, 0);
    CHECK(!frames.empty());
    const decoded_frame& last = frames.back();
    CHECK_EQ(last.type, FRAME_TYPE_TEXT);
    CHECK(std::string(last.payload.begin(), last.payload.end()) == "OK");
    CHECK(frames.size() <= 3);  // at most the samples already under way, then the answer
}

static std::vector<decoded_frame> stream(sampler_state& s, uint32_t duration_us, int* bad) {
    board.tx.clear();
    sampler_start(s, board.now_us);
    run_for(s, duration_us, 7);
    sampler_stop(s);
    return decode_all(board.tx, bad);
}

TEST(stream_runs_at_300_hz_with_consecutive_sequence) {
    reset_board();
    board.now_us = 0xFFFFFFFFUL - 500000UL;  // cross the micros() wrap mid-run
    sampler_state s;
    sampler_init(s);
    int bad = 0;
    std::vector<decoded_frame> frames = stream(s, 1000000UL, &bad);
    CHECK_EQ(bad, 0);
    CHECK(frames.size() >= 299 && frames.size() <= 301);
    for (size_t i = 1; i < frames.size(); ++i) {
        CHECK_EQ(frames[i].type, FRAME_TYPE_SAMPLE);
        CHECK_EQ(u16(frames[i].payload, 0), (uint16_t)(u16(frames[i - 1].payload, 0) + 1));
        uint32_t t0 = u16(frames[i - 1].payload, 2) | ((uint32_t)u16(frames[i - 1].payload, 4) << 16);
        uint32_t t1 = u16(frames[i].payload, 2) | ((uint32_t)u16(frames[i].payload, 4) << 16);
        CHECK(t1 - t0 >= 3333 - 7 && t1 - t0 <= 3333 + 7);  // within one poll step
        CHECK_EQ(frames[i].payload[12], 0);
    }
}

TEST(counts_match_the_field_at_the_configured_sensitivity) {
    reset_board();
    // the -8760 µT target on Y and the deepest Z of the twin's calibration grid (-34.6 mT)
    board.field_uT[0] = 1500.0; board.field_uT[1] = -8760.0; board.field_uT[2] = -34600.0;
    sampler_state s;
    sampler_init(s);
    int bad = 0;
    std::vector<decoded_frame> frames = stream(s, 20000, &bad);
    CHECK(!frames.empty());
    const std::vector<uint8_t>& p = frames[0].payload;
    // gain 5, res 2: 1.000 µT/LSB on X/Y and 1.612 µT/LSB on Z; within half a step.
    CHECK_NEAR((int16_t)u16(p, 6) * 1.000, 1500.0, 0.5);
    CHECK_NEAR((int16_t)u16(p, 8) * 1.000, -8760.0, 0.5);
    CHECK_NEAR((int16_t)u16(p, 10) * 1.612, -34600.0, 0.81);
    CHECK_EQ(p[12] & SENSOR_STATUS_SATURATED, 0);
}

TEST(saturation_is_flagged) {
    // Beyond the ±32.8 mT of X/Y and the ±52.8 mT of Z at gain 5, res 2, one axis at a time.
    const double beyond_uT[3] = {-33500.0, 33500.0, -54000.0};
    for (int axis = 0; axis < 3; ++axis) {
        reset_board();
        board.field_uT[axis] = beyond_uT[axis];
        sampler_state s;
        sampler_init(s);
        int bad = 0;
        std::vector<decoded_frame> frames = stream(s, 20000, &bad);
        CHECK(!frames.empty());
        CHECK(frames[0].payload[12] & SENSOR_STATUS_SATURATED);
    }
}

TEST(missing_sensor_is_reported_not_zero) {
    reset_board();
    board.mlx_present = false;
    sampler_state s;
    sampler_init(s);
    int bad = 0;
    std::vector<decoded_frame> frames = stream(s, 100000, &bad);
    CHECK(frames.size() >= 29 && frames.size() <= 31);  // still at the rate: the host sees it
    for (const decoded_frame& f : frames) CHECK(f.payload[12] & SENSOR_STATUS_NO_SENSOR);
    // Reconnecting recovers without a restart.
    board.mlx_present = true;
    board.tx.clear();
    sampler_start(s, board.now_us);
    run_for(s, 20000, 7);
    frames = decode_all(board.tx, &bad);
    CHECK(!frames.empty() && frames.back().payload[12] == 0);
}

TEST(full_transmit_buffer_drops_frames_and_says_so) {
    reset_board();
    sampler_state s;
    sampler_init(s);
    board.tx.clear();
    sampler_start(s, board.now_us);
    run_for(s, 10000, 7);
    board.tx_capacity = 10;  // host not reading
    run_for(s, 10000, 7);
    board.tx_capacity = 1024;
    run_for(s, 10000, 7);
    int bad = 0;
    std::vector<decoded_frame> frames = decode_all(board.tx, &bad);
    bool gap_seen = false, overflow_flagged = false;
    for (size_t i = 1; i < frames.size(); ++i) {
        if (u16(frames[i].payload, 0) != (uint16_t)(u16(frames[i - 1].payload, 0) + 1)) {
            gap_seen = true;
            overflow_flagged = (frames[i].payload[12] & SENSOR_STATUS_TX_OVERFLOW) != 0;
        }
    }
    CHECK(gap_seen);
    CHECK(overflow_flagged);
    CHECK(s.frames_dropped >= 2);
}

TEST(stalled_loop_marks_samples_late) {
    reset_board();
    sampler_state s;
    sampler_init(s);
    board.tx.clear();
    sampler_start(s, board.now_us);
    run_for(s, 5000, 7);
    board.now_us += 8000;  // loop blocked for more than two periods
    run_for(s, 10000, 7);
    int bad = 0;
    std::vector<decoded_frame> frames = decode_all(board.tx, &bad);
    bool late = false;
    for (const decoded_frame& f : frames) late = late || (f.payload[12] & SENSOR_STATUS_LATE);
    CHECK(late);
}

int main() { return run_all_tests(); }
