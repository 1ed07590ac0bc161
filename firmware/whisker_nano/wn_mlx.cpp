#include "wn_mlx.h"

#include "wn_hal.h"

// Datasheet table, 3 axes, µs: rows DIG_FILT 0..3, columns OSR 0..3 (reference/README.md).
static const uint16_t MLX_CONVERSION_TABLE_US[4][4] = {
    {1270, 1840, 3000, 5300},
    {1460, 2230, 3760, 6840},
    {1840, 3000, 5300, 9910},
    {2610, 4530, 8370, 16050},
};

uint32_t mlx_conversion_time_us(uint8_t osr, uint8_t filt) {
    if (filt <= 3) return MLX_CONVERSION_TABLE_US[filt][osr & 3];
    // Datasheet formula TCONVM = 67 + 64 * 2^OSR * (2 + 2^DIG_FILT) µs per axis, plus the
    // ~490 µs of start-up and end-of-conversion time that the table above implies.
    uint32_t per_axis = (uint32_t)67 + (uint32_t)64 * ((uint32_t)1 << osr) * ((uint32_t)2 + ((uint32_t)1 << filt));
    return (uint32_t)3 * per_axis + (uint32_t)490;  // up to 200 ms at DIG_FILT 7, OSR 3
}

uint16_t mlx_register0(const mlx_settings& settings) {
    return (uint16_t)(((settings.gain & 7) << 4) | MLX_HALLCONF);
}

uint16_t mlx_register2(const mlx_settings& settings) {
    uint16_t res = settings.res & 3;
    return (uint16_t)((res << 9) | (res << 7) | (res << 5) | ((settings.filt & 7) << 2) |
                      (settings.osr & 3));
}

static bool mlx_write_register(uint8_t reg, uint16_t value) {
    uint8_t tx[4] = {MLX_CMD_WR, (uint8_t)(value >> 8), (uint8_t)(value & 0xFF), (uint8_t)(reg << 2)};
    uint8_t status = 0;
    if (!hal_i2c_transfer(MLX_ADDRESS, tx, 4, &status, 1)) return false;
    return (status & MLX_STATUS_ERROR) == 0;
}

bool mlx_configure(const mlx_settings& settings) {
    uint8_t exit_cmd = MLX_CMD_EX;  // leave any burst or wake-on-change mode first
    uint8_t status = 0;
    if (!hal_i2c_transfer(MLX_ADDRESS, &exit_cmd, 1, &status, 1)) return false;
    return mlx_write_register(0, mlx_register0(settings)) &&
           mlx_write_register(2, mlx_register2(settings));
}

int16_t mlx_start_measurement() {
    uint8_t cmd = MLX_CMD_SM | MLX_AXES_XYZ;
    uint8_t status = 0;
    if (!hal_i2c_transfer(MLX_ADDRESS, &cmd, 1, &status, 1)) return -1;
    return status;
}

int16_t mlx_read_measurement(uint16_t raw[3]) {
    uint8_t cmd = MLX_CMD_RM | MLX_AXES_XYZ;
    uint8_t rx[7];
    if (!hal_i2c_transfer(MLX_ADDRESS, &cmd, 1, rx, 7)) return -1;
    for (uint8_t axis = 0; axis < 3; ++axis) {
        raw[axis] = (uint16_t)((rx[1 + 2 * axis] << 8) | rx[2 + 2 * axis]);  // big-endian
    }
    return rx[0];
}

int16_t mlx_signed_counts(uint16_t raw, uint8_t res, bool* saturated) {
    int32_t counts;
    int32_t low, high;
    // NOTE: the bounds are long literals: with the AVR's 16-bit int, -0x8000 is the unsigned
    // 0x8000 (+32768), which flagged every reading as saturated.
    if (res == 2) {
        counts = (int32_t)raw - 0x8000;
        low = -0x8000L;
        high = 0x7FFF;
    } else if (res == 3) {
        counts = (int32_t)raw - 0x4000;
        low = -0x4000;
        high = 0x3FFF;  // RES 3 spans 15 bits
    } else {
        counts = (int16_t)raw;
        low = -0x8000L;
        high = 0x7FFF;
    }
    if (counts <= low || counts >= high) *saturated = true;
    return (int16_t)counts;
}
