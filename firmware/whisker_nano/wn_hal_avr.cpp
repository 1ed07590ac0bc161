// Board services on the Arduino Nano (ATmega328P, 16 MHz): Wire at 400 kHz, Serial at 115200.
#ifdef __AVR__

#include <Arduino.h>
#include <Wire.h>

#include "wn_hal.h"

uint32_t hal_micros() { return micros(); }

bool hal_i2c_transfer(uint8_t address, const uint8_t* tx, uint8_t ntx, uint8_t* rx, uint8_t nrx) {
    Wire.beginTransmission(address);
    Wire.write(tx, ntx);
    // Repeated start between the command and its answer, as the MLX90393 expects.
    if (Wire.endTransmission(nrx == 0) != 0) return false;
    if (nrx == 0) return true;
    if (Wire.requestFrom(address, nrx) != nrx) return false;
    for (uint8_t i = 0; i < nrx; ++i) rx[i] = (uint8_t)Wire.read();
    return true;
}

uint16_t hal_tx_free() { return (uint16_t)Serial.availableForWrite(); }

void hal_tx_write(const uint8_t* data, uint8_t n) { Serial.write(data, n); }

#endif
