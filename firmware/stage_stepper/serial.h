// Serial buffers: the receive path picks out the realtime bytes (? ! ~ 0x18) as they arrive,
// so they act at once even while the line buffer is full or the main loop is busy.
#ifndef STAGE_SERIAL_H
#define STAGE_SERIAL_H

#include <stdint.h>

enum : uint8_t {
    REALTIME_STATUS = 0x01,
    REALTIME_HOLD = 0x02,
    REALTIME_RESUME = 0x04,
    REALTIME_RESET = 0x08,
};

void serial_init();

// Called for every received byte (from the USART receive interrupt on the board).
void serial_receive_byte(uint8_t c);

// Next ordinary received byte, or -1.
int16_t serial_read();

// Realtime requests received since the last call, cleared by reading them.
uint8_t serial_take_realtime();

// Queues a byte or a string for transmission; waits while the buffer is full.
void serial_write(uint8_t c);
void serial_print(const char* text);

// Fixed texts stay in flash on the board (2 KiB of RAM would not hold them all).
#ifdef __AVR__
#include <avr/pgmspace.h>
#define FLASH_TEXT(text) PSTR(text)
void serial_print_flash(const char* flash_text);
#else
#define FLASH_TEXT(text) (text)
#define serial_print_flash serial_print
#endif

// Next byte to transmit, or -1 (called by the transmit interrupt / the host loop).
int16_t serial_next_tx();

// Drops unread received bytes (soft reset).
void serial_flush_rx();

#endif
