#include "fake_board.h"

#include <cmath>

#include "../wn_hal.h"
#include "../wn_mlx.h"

fake_board board;

// Adafruit driver's table for HALLCONF 0xC, RES 0: gain 5x .. 1x; each RES step doubles it.
static const double FAKE_XY_LSB[8] = {0.751, 0.601, 0.451, 0.376, 0.300, 0.250, 0.200, 0.150};
static const double FAKE_Z_LSB[8] = {1.210, 0.968, 0.726, 0.605, 0.484, 0.403, 0.323, 0.242};

double fake_lsb_uT(uint8_t axis, uint8_t gain, uint8_t res) {
    double base = axis < 2 ? FAKE_XY_LSB[gain & 7] : FAKE_Z_LSB[gain & 7];
    return base * (double)(1 << res);
}

uint32_t hal_micros() { return board.now_us; }

uint16_t hal_tx_free() { return board.tx_capacity; }

void hal_tx_write(const uint8_t* data, uint8_t n) { board.tx.insert(board.tx.end(), data, data + n); }

static uint16_t fake_raw(uint8_t axis) {
    uint8_t gain = (board.registers[0] >> 4) & 7;
    uint8_t res = (board.registers[2] >> (5 + 2 * axis)) & 3;
    long counts = std::lround(board.latched_uT[axis] / fake_lsb_uT(axis, gain, res));
    long low = -32768, high = 32767, offset = 0;
    if (res == 2) offset = 0x8000;
    if (res == 3) { offset = 0x4000; low = -0x4000; high = 0x3FFF; }
    counts = counts < low ? low : counts > high ? high : counts;
    return (uint16_t)(counts + offset);
}

static uint8_t fake_status(bool error) {
    return (uint8_t)((board.converting ? 0x20 : 0) | (error ? MLX_STATUS_ERROR : 0) | 0x03);
}

static void fake_read_measurement(uint8_t* rx, uint8_t nrx) {
    uint8_t osr = board.registers[2] & 3, filt = (board.registers[2] >> 2) & 7;
    bool ready = board.converting && board.now_us - board.conversion_start_us >= mlx_conversion_time_us(osr, filt);
    rx[0] = fake_status(!ready);
    for (uint8_t axis = 0; axis < 3 && 2 + 2 * axis < nrx; ++axis) {
        uint16_t raw = fake_raw(axis);
        rx[1 + 2 * axis] = (uint8_t)(raw >> 8);
        rx[2 + 2 * axis] = (uint8_t)(raw & 0xFF);
    }
    if (ready) board.converting = false;
}

bool hal_i2c_transfer(uint8_t address, const uint8_t* tx, uint8_t ntx, uint8_t* rx, uint8_t nrx) {
    ++board.i2c_transactions;
    if (address != MLX_ADDRESS || !board.mlx_present || ntx == 0) return false;
    uint8_t command = tx[0] & 0xF0;
    if (command == MLX_CMD_WR && ntx == 4) {
        board.registers[(tx[3] >> 2) & 3] = (uint16_t)((tx[1] << 8) | tx[2]);
        rx[0] = fake_status(false);
    } else if (command == MLX_CMD_SM) {
        board.converting = true;
        board.conversion_start_us = board.now_us;
        for (int axis = 0; axis < 3; ++axis) board.latched_uT[axis] = board.field_uT[axis];
        rx[0] = fake_status(false);
    } else if (command == MLX_CMD_RM) {
        fake_read_measurement(rx, nrx);
    } else if (command == MLX_CMD_EX) {
        board.converting = false;
        rx[0] = fake_status(false);
    } else {
        rx[0] = fake_status(true);
    }
    return true;
}
