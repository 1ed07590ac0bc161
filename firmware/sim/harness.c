// Runs a sketch's .hex on an emulated ATmega328P at 16 MHz with the board's parts attached, and
// serves the line protocol of harness.h. Usage: avr_harness sensor|stage FIRMWARE.hex [PINS]
// (PINS, for the stage: "whiskercal", the default, or "grbl": stage_part.h).
#include "harness.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <avr_eeprom.h>
#include <avr_uart.h>
#include <sim_interrupts.h>
#include <sim_hex.h>

#include "mlx90393_part.h"
#include "stage_part.h"

enum {
    F_CPU_HZ = 16000000,
    MLX_ADDRESS = 0x0C,
    RAM_START = 0x100,   // ATmega328P: 2 KiB of SRAM at 0x100..0x8FF
    RAM_END = 0x8FF,
    PAINT = 0xA5,
    EEPROM_BYTES = 1024,
    REQUEST_MAX = 2 * EEPROM_BYTES + 16,  // "W <hex>" carries the whole EEPROM
};

static avr_t* avr;
static avr_irq_t* uart_input;
static mlx90393_part mlx;
static stage_part stage;
static int is_stage;

void harness_say(const char* line) {
    fputs(line, stdout);
    fputc('\n', stdout);
}

void harness_ask(const char* request, char* answer, size_t size) {
    harness_say(request);
    fflush(stdout);
    if (!fgets(answer, (int)size, stdin)) exit(0);  // the host has gone
}

static void on_uart_byte(avr_irq_t* irq, uint32_t value, void* param) {
    (void)irq;
    (void)param;
    printf("U %llu %02x\n", (unsigned long long)avr->cycle, value & 0xFF);
}

// No wall-clock waits: the host decides how fast emulated time runs.
static void sleep_not(avr_t* a, avr_cycle_count_t how_long) {
    (void)a;
    (void)how_long;
}

static int load_hex(const char* path) {
    ihex_chunk_p chunks = NULL;
    int count = read_ihex_chunks(path, &chunks);
    if (count <= 0) return 0;
    for (int i = 0; i < count; ++i) {
        if (chunks[i].baseaddr < 0x800000) avr_loadcode(avr, chunks[i].data, chunks[i].size, chunks[i].baseaddr);
    }
    free_ihex_chunks(chunks);
    return 1;
}

// Fills the SRAM with a pattern before the sketch starts: the C runtime then writes .data and
// .bss, the stack overwrites what it reaches, and the untouched run in between is what was never
// used (read back with "M").
static void paint_ram(void) {
    for (int address = RAM_START; address <= RAM_END; ++address) avr->data[address] = PAINT;
}

// "M <cycle> <stack bytes> <never used bytes>": the deepest the stack went since power-up, from
// the longest painted run (the gap between .bss and the stack's low-water mark).
static void report_memory(void) {
    int best_start = RAM_END + 1, best_length = 0;
    for (int address = RAM_START; address <= RAM_END;) {
        if (avr->data[address] != PAINT) {
            ++address;
            continue;
        }
        int start = address;
        while (address <= RAM_END && avr->data[address] == PAINT) ++address;
        if (address - start > best_length) {
            best_length = address - start;
            best_start = start;
        }
    }
    int stack_bytes = RAM_END - (best_start + best_length) + 1;
    printf("M %llu %d %d\n", (unsigned long long)avr->cycle, stack_bytes, best_length);
}

// Interrupt latency per vector: from its flag raised while the interrupt is enabled to the vector
// being called, the longest and the total, in cycles ("V" reads them back). A flag that was raised
// while its interrupt was off (UDRE between transmissions, Timer1 between moves) is not counted.
enum { VECTORS = 26 };
static avr_int_vector_t* vector_of[VECTORS];
static avr_cycle_count_t pending_since[VECTORS];
static uint64_t latency_max[VECTORS], latency_sum[VECTORS], latency_count[VECTORS];

static void on_pending(avr_irq_t* irq, uint32_t value, void* param) {
    (void)irq;
    int vector = (int)(intptr_t)param;
    if (!value || pending_since[vector]) return;
    if (vector_of[vector] && !avr_regbit_get(avr, vector_of[vector]->enable)) return;
    pending_since[vector] = avr->cycle;
}

static void on_running(avr_irq_t* irq, uint32_t value, void* param) {
    (void)irq;
    int vector = (int)(intptr_t)param;
    if (!value || !pending_since[vector]) return;
    uint64_t latency = avr->cycle - pending_since[vector];
    pending_since[vector] = 0;
    if (latency > latency_max[vector]) latency_max[vector] = latency;
    latency_sum[vector] += latency;
    ++latency_count[vector];
}

static void watch_interrupts(void) {
    for (int i = 0; i < avr->interrupts.vector_count; ++i) {
        avr_int_vector_t* v = avr->interrupts.vector[i];
        if (v && v->vector < VECTORS) vector_of[v->vector] = v;
    }
    for (int vector = 1; vector < VECTORS; ++vector) {
        avr_irq_t* irq = avr_get_interrupt_irq(avr, (uint8_t)vector);
        if (!irq) continue;
        avr_irq_register_notify(irq + AVR_INT_IRQ_PENDING, on_pending, (void*)(intptr_t)vector);
        avr_irq_register_notify(irq + AVR_INT_IRQ_RUNNING, on_running, (void*)(intptr_t)vector);
    }
}

// "V <vector> <calls> <longest cycles> <total cycles>" for every vector that ran.
static void report_latency(void) {
    for (int vector = 1; vector < VECTORS; ++vector) {
        if (!latency_count[vector]) continue;
        printf("V %d %llu %llu %llu\n", vector, (unsigned long long)latency_count[vector],
               (unsigned long long)latency_max[vector], (unsigned long long)latency_sum[vector]);
    }
}

static void attach_uart(void) {
    uint32_t flags = 0;  // neither usleep while the sketch polls nor echo to the console
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), on_uart_byte, NULL);
    uart_input = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
}

static void run_to(avr_cycle_count_t target) {
    while (avr->cycle < target) {
        int state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed) {
            printf("X %llu crashed\n", (unsigned long long)avr->cycle);
            fflush(stdout);
            exit(3);
        }
    }
}

static void feed_uart(const char* hex) {
    unsigned byte;
    while (sscanf(hex, "%2x", &byte) == 1) {
        avr_raise_irq(uart_input, byte);
        hex += 2;
    }
}

// "E <cycle> <hex>": the EEPROM's 1 KiB, so that the host can keep it across a power-up as the
// chip does; "W <hex>" writes it back (before the first run, as if it had been there all along).
static void report_eeprom(void) {
    uint8_t bytes[EEPROM_BYTES];
    avr_eeprom_desc_t desc = {bytes, 0, EEPROM_BYTES};
    avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &desc);
    printf("E %llu ", (unsigned long long)avr->cycle);
    for (int i = 0; i < EEPROM_BYTES; ++i) printf("%02x", bytes[i]);
    putchar('\n');
}

static void write_eeprom(const char* hex) {
    uint8_t bytes[EEPROM_BYTES];
    unsigned byte;
    int count = 0;
    while (count < EEPROM_BYTES && sscanf(hex, "%2x", &byte) == 1) {
        bytes[count++] = (uint8_t)byte;
        hex += 2;
    }
    avr_eeprom_desc_t desc = {bytes, 0, (uint32_t)count};
    if (count) avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &desc);
}

static void serve(void) {
    static char line[REQUEST_MAX];
    while (fgets(line, sizeof line, stdin)) {
        if (line[0] == 'R') {
            run_to(strtoull(line + 1, NULL, 10));
            if (is_stage) stage_part_report(&stage);
        } else if (line[0] == 'L' && is_stage) {
            long x = 0, y = 0;
            if (sscanf(line + 1, "%ld %ld", &x, &y) == 2) stage_part_set_switches(&stage, (int32_t)x, (int32_t)y);
        } else if (line[0] == 'M') {
            report_memory();
        } else if (line[0] == 'V') {
            report_latency();
        } else if (line[0] == 'E') {
            report_eeprom();
        } else if (line[0] == 'W') {
            write_eeprom(line + 2);
        } else if (line[0] == 'I') {
            feed_uart(line + 2);
        } else if (line[0] == 'Q') {
            break;
        } else {
            fprintf(stderr, "avr_harness: unknown request %s", line);
        }
        printf("K %llu\n", (unsigned long long)avr->cycle);
        fflush(stdout);
    }
}

int main(int argc, char** argv) {
    const stage_pins* pins = stage_pins_named(argc == 4 ? argv[3] : "whiskercal");
    if (argc < 3 || argc > 4 || (strcmp(argv[1], "sensor") != 0 && strcmp(argv[1], "stage") != 0) || !pins) {
        fprintf(stderr, "usage: avr_harness sensor|stage FIRMWARE.hex [whiskercal|grbl]\n");
        return 2;
    }
    avr = avr_make_mcu_by_name("atmega328p");
    if (!avr) return 1;
    avr_init(avr);
    avr->frequency = F_CPU_HZ;
    avr->sleep = sleep_not;
    avr->log = LOG_ERROR;
    if (!load_hex(argv[2])) {
        fprintf(stderr, "avr_harness: cannot read %s\n", argv[2]);
        return 1;
    }
    paint_ram();
    attach_uart();
    watch_interrupts();
    is_stage = strcmp(argv[1], "stage") == 0;
    if (is_stage) {
        stage_part_init(avr, &stage, pins);
    } else {
        mlx90393_part_init(avr, &mlx, MLX_ADDRESS);
    }
    printf("K %llu\n", (unsigned long long)avr->cycle);
    fflush(stdout);
    serve();
    return 0;
}
