// MLX90393 driver without blocking waits: the caller starts a single measurement, checks the
// clock against mlx_conversion_time_us(), then reads. Register fields and the conversion-time
// table are from the MLX90393 datasheet as carried by the Adafruit driver.
#ifndef WN_MLX_H
#define WN_MLX_H

#include <stdint.h>

enum : uint8_t {
    MLX_ADDRESS = 0x0C,       // Adafruit breakout, A0 = A1 = 0
    MLX_CMD_SM = 0x30,        // start single measurement (| axis mask)
    MLX_CMD_RM = 0x40,        // read measurement (| axis mask)
    MLX_CMD_RR = 0x50,        // read register
    MLX_CMD_WR = 0x60,        // write register
    MLX_CMD_EX = 0x80,        // exit mode
    MLX_CMD_RT = 0xF0,        // reset
    MLX_AXES_XYZ = 0x0E,      // z | y | x, no temperature
    MLX_STATUS_ERROR = 0x10,  // set when data is read before it is ready, or a bad command
    MLX_HALLCONF = 0x0C,      // the sensitivity table holds for HALLCONF 0xC only
    MLX_GAIN_MAX = 7,
    MLX_RES_MAX = 3,
    MLX_OSR_MAX = 3,
    MLX_FILT_MAX = 7,
};

struct mlx_settings {
    uint8_t gain;  // GAIN_SEL 0..7 (7 is the driver's "1x": the finest step, the smallest range)
    uint8_t res;   // RES_X = RES_Y = RES_Z 0..3
    uint8_t osr;   // OSR 0..3
    uint8_t filt;  // DIG_FILT 0..7
};

// Conversion time of an X, Y, Z single measurement, µs.
uint32_t mlx_conversion_time_us(uint8_t osr, uint8_t filt);

// Register 0 and 2 values for the settings (HALLCONF 0xC, no BIST, no Z series, OSR2 0).
uint16_t mlx_register0(const mlx_settings& settings);
uint16_t mlx_register2(const mlx_settings& settings);

// Writes registers 0 and 2; false when the sensor does not answer or flags an error.
bool mlx_configure(const mlx_settings& settings);

// Starts an X, Y, Z single measurement; returns the status byte, or -1 without an answer.
int16_t mlx_start_measurement();

// Reads X, Y, Z (raw register values); returns the status byte, or -1 without an answer.
int16_t mlx_read_measurement(uint16_t raw[3]);

// Raw register value to signed counts: RES 2 and 3 are offset binary (0x8000, 0x4000).
// Sets *saturated when the value sits at an end of the output range.
int16_t mlx_signed_counts(uint16_t raw, uint8_t res, bool* saturated);

#endif
