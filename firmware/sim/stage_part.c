#include "stage_part.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <avr_ioport.h>
#include <avr_twi.h>

#include "harness.h"

enum {
    PORTB_ADDRESS = 0x25,  // data-space addresses of the I/O registers
    PORTD_ADDRESS = 0x2B,
    MUX_ADDRESS = 0x70,
    AS5600_ADDRESS = 0x36,
    NONE = 0xFF,
    OCR1AL_ADDRESS = 0x88,
};

// grbl runs Timer1 in CTC mode from power-up with OCR1A still 0 and relies on the chip matching
// every cycle, so that its first step interrupt comes as soon as st_wake_up() enables it. simavr
// 1.6 instead stops a CTC timer whose TOP is 0 (fewer than two cycles a period), and grbl never
// steps. For grbl's map the harness starts with OCR1A = 1: the first step interrupt comes one
// cycle later than on the chip, and from then on grbl sets OCR1A itself.

static const stage_pins PIN_MAPS[] = {
    {"whiskercal", {2, 3, NONE}, {1 << 5, 1 << 6, 0}, 1 << 0, {1, 2, NONE}, 1, 0},
    {"grbl", {2, 3, 4}, {1 << 5, 1 << 6, 1 << 7}, 1 << 0, {1, 2, 4}, 0, 1},
};

const stage_pins* stage_pins_named(const char* name) {
    for (size_t i = 0; i < sizeof PIN_MAPS / sizeof PIN_MAPS[0]; ++i) {
        if (strcmp(PIN_MAPS[i].name, name) == 0) return &PIN_MAPS[i];
    }
    return NULL;
}

// X and Y close where the host says; a Z switch (grbl's map) never closes: the stage has no Z.
static void update_switches(stage_part* p) {
    for (int axis = 0; axis < STAGE_AXES; ++axis) {
        if (p->pins->limit_pin[axis] == NONE) continue;
        int pressed = axis < 2 && p->steps[axis] <= p->switch_steps[axis];
        avr_raise_irq(avr_io_getirq(p->avr, AVR_IOCTL_IOPORT_GETIRQ('B'), p->pins->limit_pin[axis]), pressed ? 0 : 1);
    }
}

static void on_step(stage_part* p, int axis, uint32_t value, uint32_t previous) {
    if (!value || previous) return;  // rising edges only
    if (p->avr->data[PORTB_ADDRESS] & p->pins->enable_mask) return;  // drivers disabled
    p->steps[axis] += (p->avr->data[PORTD_ADDRESS] & p->pins->dir_mask[axis]) ? -1 : 1;
    ++p->step_events;
    if (p->step_log) fprintf(p->step_log, "%d %llu\n", axis, (unsigned long long)p->avr->cycle);
    update_switches(p);
}

static void on_step_x(avr_irq_t* irq, uint32_t value, void* param) { on_step(param, 0, value, irq->value); }
static void on_step_y(avr_irq_t* irq, uint32_t value, void* param) { on_step(param, 1, value, irq->value); }
static void on_step_z(avr_irq_t* irq, uint32_t value, void* param) { on_step(param, 2, value, irq->value); }
static void (*const ON_STEP[STAGE_AXES])(avr_irq_t*, uint32_t, void*) = {on_step_x, on_step_y, on_step_z};

// Asks the host what the selected encoder reads now; false when it does not answer.
static int ask_encoder(stage_part* p) {
    int axis = (p->mux_channels & 1) ? 0 : (p->mux_channels & 2) ? 1 : -1;
    if (axis < 0) return 0;  // no channel open: nothing answers at 0x36
    char request[64], reply[HARNESS_LINE_MAX];
    snprintf(request, sizeof request, "A %llu %d %ld %ld", (unsigned long long)p->avr->cycle, axis,
             (long)p->steps[0], (long)p->steps[1]);
    harness_ask(request, reply, sizeof reply);
    unsigned status = 0, raw = 0;
    if (sscanf(reply, "%u %u", &status, &raw) != 2) return 0;
    p->as5600_registers[0x0B] = (uint8_t)status;
    p->as5600_registers[0x0C] = (uint8_t)((raw >> 8) & 0x0F);
    p->as5600_registers[0x0D] = (uint8_t)(raw & 0xFF);
    p->as5600_registers[0x0E] = p->as5600_registers[0x0C];  // ANGLE: no start/stop position set
    p->as5600_registers[0x0F] = p->as5600_registers[0x0D];
    return 1;
}

static void ack(stage_part* p, uint8_t address) {
    avr_raise_irq(p->twi_irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_ACK, address, 1));
}

static void on_start(stage_part* p, uint8_t address) {
    uint8_t device = address >> 1;
    int writing = !(address & 1);
    p->selected = 0;
    if (device == MUX_ADDRESS) {
        p->selected = MUX_ADDRESS;
    } else if (device == AS5600_ADDRESS) {
        // a new transaction that sets the register pointer samples the angle; the read after a
        // repeated start returns that sample
        if (writing) p->encoder_answers = ask_encoder(p);
        if (p->encoder_answers) p->selected = AS5600_ADDRESS;
    }
    if (p->selected) ack(p, address);
}

static void on_write(stage_part* p, uint8_t address, uint8_t data) {
    if (p->selected == MUX_ADDRESS) p->mux_channels = data;
    if (p->selected == AS5600_ADDRESS) p->as5600_pointer = data & 0x0F;
    ack(p, address);
}

static uint8_t on_read(stage_part* p) {
    if (p->selected == MUX_ADDRESS) return p->mux_channels;
    uint8_t data = p->as5600_registers[p->as5600_pointer & 0x0F];
    p->as5600_pointer = (uint8_t)((p->as5600_pointer + 1) & 0x0F);
    return data;
}

static void on_twi(avr_irq_t* irq, uint32_t value, void* param) {
    (void)irq;
    stage_part* p = (stage_part*)param;
    avr_twi_msg_irq_t msg;
    msg.u.v = value;
    if (msg.u.twi.msg & TWI_COND_STOP) p->selected = 0;
    if (msg.u.twi.msg & TWI_COND_START) {
        on_start(p, msg.u.twi.addr);
        return;
    }
    if (!p->selected) return;
    if (msg.u.twi.msg & TWI_COND_WRITE) on_write(p, msg.u.twi.addr, msg.u.twi.data);
    if (msg.u.twi.msg & TWI_COND_READ) {
        avr_raise_irq(p->twi_irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_READ, msg.u.twi.addr, on_read(p)));
    }
}

static void attach_encoders(avr_t* avr, stage_part* part);

static const char* IRQ_NAMES[2] = {"8>stage_i2c.out", "32<stage_i2c.in"};

void stage_part_init(avr_t* avr, stage_part* part, const stage_pins* pins) {
    memset(part, 0, sizeof *part);
    part->avr = avr;
    part->pins = pins;
    part->switch_steps[0] = part->switch_steps[1] = INT32_MIN;  // until the host says
    const char* log_path = getenv("WC_SIM_STEP_LOG");  // "<axis> <cycle>" per step edge, for timing figures
    if (log_path && *log_path) part->step_log = fopen(log_path, "w");
    for (int axis = 0; axis < STAGE_AXES; ++axis) {
        if (pins->step_pin[axis] == NONE) continue;
        avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), pins->step_pin[axis]), ON_STEP[axis], part);
    }
    if (pins->encoders) attach_encoders(avr, part);
    if (pins->ocr1a_at_reset) avr->data[OCR1AL_ADDRESS] = (uint8_t)pins->ocr1a_at_reset;
    update_switches(part);
}

static void attach_encoders(avr_t* avr, stage_part* part) {
    part->twi_irq = avr_alloc_irq(&avr->irq_pool, 0, 2, IRQ_NAMES);
    avr_irq_register_notify(part->twi_irq + TWI_IRQ_OUTPUT, on_twi, part);
    avr_connect_irq(part->twi_irq + TWI_IRQ_INPUT, avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT));
    avr_connect_irq(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT), part->twi_irq + TWI_IRQ_OUTPUT);
}

void stage_part_set_switches(stage_part* part, int32_t x, int32_t y) {
    part->switch_steps[0] = x;
    part->switch_steps[1] = y;
    update_switches(part);
}

void stage_part_report(const stage_part* part) {
    printf("P %llu %ld %ld %ld\n", (unsigned long long)part->avr->cycle, (long)part->steps[0], (long)part->steps[1],
           (long)part->steps[2]);
}
