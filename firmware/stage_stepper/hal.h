// The board services of stage_stepper. hal_avr.cpp implements them on an ATmega328P
// (Timer1, USART0, TWI through Wire, EEPROM, pins); host/fake_board.cpp implements them with
// simulated steppers, limit switches, encoders and clock for the host tests and simulator.
#ifndef STAGE_HAL_H
#define STAGE_HAL_H

#include <stdint.h>

void hal_init();

// Clock in µs since power-up; wraps (compare with unsigned differences).
uint32_t hal_micros();

// The transmit buffer gained bytes: make sure they are being sent.
void hal_serial_kick_tx();

// Step timer: start with a first period, change the period (from the ISR), stop.
void hal_step_timer_start(uint16_t period_ticks);
void hal_step_timer_set(uint16_t period_ticks);
void hal_step_timer_stop();

// Drive the step pins (bit per axis) with the direction pins (bit set: negative) first.
void hal_step_pulse(uint8_t step_bits, uint8_t direction_bits);

// True while the axis's limit switch is pressed.
bool hal_limit_pressed(uint8_t axis);

// Reads the AS5600 of an axis: status register and 12-bit raw angle. False without an answer.
bool hal_encoder_read(uint8_t axis, uint8_t* status, uint16_t* raw_angle);

void hal_eeprom_read(uint16_t address, uint8_t* data, uint16_t n);
void hal_eeprom_write(uint16_t address, const uint8_t* data, uint16_t n);

// Interrupts off and on around reads of state the ISR changes.
void hal_interrupts_off();
void hal_interrupts_on();

#endif
