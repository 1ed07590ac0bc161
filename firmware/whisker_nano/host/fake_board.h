// A simulated Nano for the host builds: a clock, an MLX90393 on the I2C bus (registers,
// conversion timing, the ERROR bit on early reads, offset binary at RES 2/3) and a transmit
// buffer. Used by the unit tests and by the conformance simulator.
#ifndef WN_FAKE_BOARD_H
#define WN_FAKE_BOARD_H

#include <stdint.h>

#include <vector>

struct fake_board {
    uint32_t now_us = 0;
    bool mlx_present = true;
    double field_uT[3] = {100.0, 1160.0, -500.0};  // X, Y, Z flux density at the sensor
    uint16_t registers[4] = {0x007C, 0, 0, 0};     // power-up: gain 7, HALLCONF 0xC
    bool converting = false;
    uint32_t conversion_start_us = 0;
    double latched_uT[3] = {0, 0, 0};
    uint16_t tx_capacity = 1024;                    // free transmit space reported
    std::vector<uint8_t> tx;                        // everything the core sent
    unsigned i2c_transactions = 0;
};

extern fake_board board;

// Sensitivity, µT per LSB, of the X/Y (axis 0, 1) or Z (axis 2) channel for gain and res.
double fake_lsb_uT(uint8_t axis, uint8_t gain, uint8_t res);

#endif
