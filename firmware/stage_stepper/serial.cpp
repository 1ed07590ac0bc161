#include "serial.h"

#include "config.h"
#include "hal.h"

static uint8_t serial_rx_buffer[RX_BUFFER_SIZE];
static volatile uint8_t serial_rx_head;  // written by the receive ISR
static volatile uint8_t serial_rx_tail;  // written by the main loop
static volatile uint8_t serial_realtime;

static uint8_t serial_tx_buffer[TX_BUFFER_SIZE];
static volatile uint8_t serial_tx_head;  // written by the main loop
static volatile uint8_t serial_tx_tail;  // written by the transmit ISR

void serial_init() {
    serial_rx_head = serial_rx_tail = 0;
    serial_tx_head = serial_tx_tail = 0;
    serial_realtime = 0;
}

void serial_receive_byte(uint8_t c) {
    switch (c) {
        case '?': serial_realtime |= REALTIME_STATUS; return;
        case '!': serial_realtime |= REALTIME_HOLD; return;
        case '~': serial_realtime |= REALTIME_RESUME; return;
        case 0x18: serial_realtime |= REALTIME_RESET; return;
        default: break;
    }
    uint8_t next = (uint8_t)((serial_rx_head + 1) & (RX_BUFFER_SIZE - 1));
    // NOTE: a full buffer drops the byte; a host that waits for "ok" never fills 128 bytes.
    if (next == serial_rx_tail) return;
    serial_rx_buffer[serial_rx_head] = c;
    serial_rx_head = next;
}

int16_t serial_read() {
    uint8_t tail = serial_rx_tail;
    if (tail == serial_rx_head) return -1;
    uint8_t c = serial_rx_buffer[tail];
    serial_rx_tail = (uint8_t)((tail + 1) & (RX_BUFFER_SIZE - 1));
    return c;
}

uint8_t serial_take_realtime() {
    hal_interrupts_off();
    uint8_t requests = serial_realtime;
    serial_realtime = 0;
    hal_interrupts_on();
    return requests;
}

void serial_write(uint8_t c) {
    uint8_t next = (uint8_t)((serial_tx_head + 1) & (TX_BUFFER_SIZE - 1));
    while (next == serial_tx_tail) hal_serial_kick_tx();  // wait for room
    serial_tx_buffer[serial_tx_head] = c;
    serial_tx_head = next;
    hal_serial_kick_tx();
}

void serial_print(const char* text) {
    while (*text) serial_write((uint8_t)*text++);
}

#ifdef __AVR__
void serial_print_flash(const char* flash_text) {
    for (char c = pgm_read_byte(flash_text); c; c = pgm_read_byte(++flash_text)) serial_write((uint8_t)c);
}
#endif

int16_t serial_next_tx() {
    uint8_t tail = serial_tx_tail;
    if (tail == serial_tx_head) return -1;
    uint8_t c = serial_tx_buffer[tail];
    serial_tx_tail = (uint8_t)((tail + 1) & (TX_BUFFER_SIZE - 1));
    return c;
}

void serial_flush_rx() {
    hal_interrupts_off();
    serial_rx_tail = serial_rx_head;
    hal_interrupts_on();
}
