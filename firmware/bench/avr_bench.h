// Cycle counting on the ATmega328P (run under simavr, or on a board with a serial terminal):
// Timer1 runs at the CPU clock, results go out on the UART as "name cycles" lines.
#ifndef AVR_BENCH_H
#define AVR_BENCH_H

#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

static void bench_uart_init() {
    UCSR0A = _BV(U2X0);
    UBRR0L = 16;  // 115200 baud at 16 MHz
    UCSR0B = _BV(TXEN0);
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
}

static void bench_putc(char c) {
    while (!(UCSR0A & _BV(UDRE0))) {}
    UDR0 = (uint8_t)c;
}

static void bench_print(const char* text) {
    while (*text) bench_putc(*text++);
}

static void bench_print_uint(uint32_t value) {
    char digits[11];
    uint8_t n = 0;
    do {
        digits[n++] = (char)('0' + value % 10);
        value /= 10;
    } while (value);
    while (n) bench_putc(digits[--n]);
}

static void bench_timer_start() {
    TCCR1A = 0;
    TCCR1B = _BV(CS10);  // no prescaler: one count per CPU cycle (up to 65535)
    TCNT1 = 0;
}

static uint16_t bench_timer_read() { return TCNT1; }

static void bench_report(const char* name, uint16_t cycles) {
    bench_print(name);
    bench_putc(' ');
    bench_print_uint(cycles);
    bench_putc('\n');
}

// simavr stops on sleep with interrupts off.
static void bench_end() {
    bench_print("done\n");
    while (!(UCSR0A & _BV(TXC0))) {}
    cli();
    sleep_enable();
    sleep_cpu();
}

#endif
