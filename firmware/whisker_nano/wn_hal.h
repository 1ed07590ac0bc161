// The board services the whisker_nano core needs. wn_hal_avr.cpp implements them on the
// Arduino Nano (Wire, Serial, micros); host/sim_hal.cpp implements them with a simulated
// MLX90393 and clock so that the same core runs in the host tests and conformance runs.
#ifndef WN_HAL_H
#define WN_HAL_H

#include <stdint.h>

// Clock in µs since power-up; wraps every 71.6 minutes (callers compare with unsigned
// differences only).
uint32_t hal_micros();

// One I2C transaction: write ntx bytes, then (repeated start) read nrx bytes.
// Returns false when the device does not acknowledge or returns fewer bytes.
bool hal_i2c_transfer(uint8_t address, const uint8_t* tx, uint8_t ntx, uint8_t* rx, uint8_t nrx);

// Room in the serial transmit buffer, bytes.
uint16_t hal_tx_free();

// Queue bytes for transmission. Callers check hal_tx_free() first for frames they may drop.
void hal_tx_write(const uint8_t* data, uint8_t n);

#endif
