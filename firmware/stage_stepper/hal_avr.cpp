// Board services on an ATmega328P (Arduino Nano or Uno, 16 MHz) with step/dir drivers wired
// as on a "CNC shield V3" (docs/firmware.md has the table):
//   X step D2 (PD2), Y step D3 (PD3), X dir D5 (PD5), Y dir D6 (PD6), drivers enable D8 (PB0),
//   X limit D9 (PB1), Y limit D10 (PB2) (switch to GND, internal pull-up: pressed reads LOW),
//   I2C A4 SDA / A5 SCL to a TCA9548A (0x70): AS5600 of X on channel 0, of Y on channel 1.
#ifdef __AVR__

#include <Arduino.h>
#include <Wire.h>
#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/delay.h>

#include "hal.h"
#include "serial.h"
#include "stepper.h"

static const uint8_t HAL_STEP_MASK[2] = {_BV(PD2), _BV(PD3)};
static const uint8_t HAL_DIR_MASK[2] = {_BV(PD5), _BV(PD6)};
static const uint8_t HAL_LIMIT_MASK[2] = {_BV(PB1), _BV(PB2)};
static const uint8_t HAL_MUX_ADDRESS = 0x70;
static const uint8_t HAL_AS5600_ADDRESS = 0x36;
static const uint8_t HAL_AS5600_STATUS_REGISTER = 0x0B;  // then RAW ANGLE high, low

static void hal_serial_init() {
    // 115200 baud with U2X: UBRR 16 gives 117647 baud (+2.1%), as the Arduino core does.
    UCSR0A = _BV(U2X0);
    UBRR0H = 0;
    UBRR0L = 16;
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);  // 8N1
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

void hal_init() {
    DDRD |= HAL_STEP_MASK[0] | HAL_STEP_MASK[1] | HAL_DIR_MASK[0] | HAL_DIR_MASK[1];
    DDRB |= _BV(PB0);
    PORTB &= (uint8_t)~_BV(PB0);  // drivers enabled (active low)
    DDRB &= (uint8_t)~(HAL_LIMIT_MASK[0] | HAL_LIMIT_MASK[1]);
    PORTB |= HAL_LIMIT_MASK[0] | HAL_LIMIT_MASK[1];  // pull-ups
    // Timer1: CTC on OCR1A, prescaler 8 (2 MHz), interrupt enabled only while stepping.
    TCCR1A = 0;
    TCCR1B = _BV(WGM12) | _BV(CS11);
    TIMSK1 = 0;
    hal_serial_init();
    Wire.begin();
    Wire.setClock(400000);
    // NOTE: a disconnected encoder must raise ALARM:102, not hang the loop on a stuck bus.
    Wire.setWireTimeout(2000, true);
}

uint32_t hal_micros() { return micros(); }

ISR(USART_RX_vect) { serial_receive_byte(UDR0); }

ISR(USART_UDRE_vect) {
    int16_t c = serial_next_tx();
    if (c < 0) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
    } else {
        UDR0 = (uint8_t)c;
    }
}

void hal_serial_kick_tx() { UCSR0B |= _BV(UDRIE0); }

ISR(TIMER1_COMPA_vect) { stepper_isr(); }

void hal_step_timer_start(uint16_t period_ticks) {
    OCR1A = period_ticks - 1;
    TCNT1 = 0;
    TIFR1 = _BV(OCF1A);
    TIMSK1 |= _BV(OCIE1A);
}

void hal_step_timer_set(uint16_t period_ticks) { OCR1A = period_ticks - 1; }

void hal_step_timer_stop() { TIMSK1 &= (uint8_t)~_BV(OCIE1A); }

void hal_step_pulse(uint8_t step_bits, uint8_t direction_bits) {
    uint8_t dirs = 0, steps = 0;
    for (uint8_t axis = 0; axis < 2; ++axis) {
        if (direction_bits & (1 << axis)) dirs |= HAL_DIR_MASK[axis];
        if (step_bits & (1 << axis)) steps |= HAL_STEP_MASK[axis];
    }
    PORTD = (uint8_t)((PORTD & ~(HAL_DIR_MASK[0] | HAL_DIR_MASK[1])) | dirs);
    _delay_us(1);  // NOTE: DRV8825 needs 650 ns of direction set-up before the step edge
    PORTD |= steps;
    _delay_us(2);  // NOTE: DRV8825 needs a 1.9 µs step pulse (A4988: 1 µs)
    PORTD &= (uint8_t)~steps;
}

bool hal_limit_pressed(uint8_t axis) { return (PINB & HAL_LIMIT_MASK[axis]) == 0; }

bool hal_encoder_read(uint8_t axis, uint8_t* status, uint16_t* raw_angle) {
    Wire.beginTransmission(HAL_MUX_ADDRESS);
    Wire.write((uint8_t)(1 << axis));  // TCA9548A: one bit per channel
    if (Wire.endTransmission() != 0) return false;
    Wire.beginTransmission(HAL_AS5600_ADDRESS);
    Wire.write(HAL_AS5600_STATUS_REGISTER);
    if (Wire.endTransmission(false) != 0) return false;
    if (Wire.requestFrom(HAL_AS5600_ADDRESS, (uint8_t)3) != 3) return false;
    *status = (uint8_t)Wire.read();
    uint8_t high = (uint8_t)Wire.read();
    *raw_angle = (uint16_t)(((high & 0x0F) << 8) | (uint8_t)Wire.read());
    return true;
}

void hal_eeprom_read(uint16_t address, uint8_t* data, uint16_t n) {
    eeprom_read_block(data, (const void*)(uintptr_t)address, n);
}

void hal_eeprom_write(uint16_t address, const uint8_t* data, uint16_t n) {
    eeprom_update_block(data, (void*)(uintptr_t)address, n);  // writes only the bytes that change
}

static uint8_t hal_saved_sreg;

void hal_interrupts_off() {
    uint8_t sreg = SREG;
    cli();
    hal_saved_sreg = sreg;
}

void hal_interrupts_on() { SREG = hal_saved_sreg; }

#endif
