#include "mlx90393_part.h"

#include <stdio.h>
#include <string.h>

#include <avr_twi.h>

#include "harness.h"

// Status byte (datasheet, "Status byte"): the mode bits, ERROR, and D1:D0 (2 * D + 2 bytes follow).
enum {
    STATUS_SM_MODE = 0x20,
    STATUS_ERROR = 0x10,
    STATUS_RS = 0x04,  // the chip was reset
};

static uint16_t to_register(int16_t counts, uint8_t res) {
    // RES 2 and 3 report offset binary, RES 0 and 1 two's complement (datasheet, "Output data").
    if (res == 2) return (uint16_t)((int32_t)counts + 0x8000);
    if (res == 3) return (uint16_t)((int32_t)counts + 0x4000);
    return (uint16_t)counts;
}

static void settings(const mlx90393_part* p, unsigned* gain, unsigned* res, unsigned* osr, unsigned* filt) {
    *gain = (p->registers[0] >> 4) & 7;
    *res = (p->registers[2] >> 5) & 3;  // RES_X; the sketch sets the three alike
    *filt = (p->registers[2] >> 2) & 7;
    *osr = p->registers[2] & 3;
}

static void reset_registers(mlx90393_part* p) {
    memset(p->registers, 0, sizeof p->registers);
    p->registers[0] = 0x007C;  // power-up: GAIN_SEL 7, HALLCONF 0xC
    p->converting = 0;
}

static void answer(mlx90393_part* p, const uint8_t* bytes, uint8_t n) {
    memcpy(p->response, bytes, n);
    p->response_length = n;
    p->response_index = 0;
}

static void start_measurement(mlx90393_part* p) {
    unsigned gain, res, osr, filt;
    settings(p, &gain, &res, &osr, &filt);
    char request[96], reply[HARNESS_LINE_MAX];
    snprintf(request, sizeof request, "F %llu %u %u %u %u", (unsigned long long)p->avr->cycle, gain, res,
             osr, filt);
    harness_ask(request, reply, sizeof reply);
    int x = 0, y = 0, z = 0;
    unsigned conversion_us = 0;
    if (sscanf(reply, "%d %d %d %u", &x, &y, &z, &conversion_us) != 4) {
        fprintf(stderr, "mlx90393: bad answer to F: %s\n", reply);
        conversion_us = 0;
    }
    p->counts[0] = (int16_t)x;
    p->counts[1] = (int16_t)y;
    p->counts[2] = (int16_t)z;
    p->ready_cycle = p->avr->cycle + (avr_cycle_count_t)conversion_us * (p->avr->frequency / 1000000);
    p->converting = 1;
    ++p->conversions;
}

static void read_measurement(mlx90393_part* p) {
    uint8_t out[7] = {0};
    unsigned gain, res, osr, filt;
    settings(p, &gain, &res, &osr, &filt);
    if (!p->converting) {
        out[0] = STATUS_ERROR;
    } else if (p->avr->cycle < p->ready_cycle) {
        out[0] = STATUS_SM_MODE | STATUS_ERROR;  // read before the conversion finished
        fprintf(stderr, "mlx90393: RM %lld cycles before the conversion finished\n",
                (long long)(p->ready_cycle - p->avr->cycle));
        ++p->early_reads;
    } else {
        out[0] = 0x02;  // D = 2: six data bytes
        for (int axis = 0; axis < 3; ++axis) {
            uint16_t raw = to_register(p->counts[axis], (uint8_t)res);
            out[1 + 2 * axis] = (uint8_t)(raw >> 8);
            out[2 + 2 * axis] = (uint8_t)(raw & 0xFF);
        }
        p->converting = 0;
    }
    answer(p, out, 7);
}

// Runs the command received so far; its answer is what the next read returns.
static void execute(mlx90393_part* p) {
    p->command_done = 1;
    if (p->command_length == 0) return;
    uint8_t command = p->command[0] & 0xF0, status = 0;
    if (command == 0x80) {  // EX: leave any mode
        p->converting = 0;
    } else if (command == 0xF0) {  // RT
        reset_registers(p);
        status = STATUS_RS;
    } else if (command == 0x60 && p->command_length == 4) {  // WR: data high, data low, address << 2
        p->registers[(p->command[3] >> 2) & 31] = (uint16_t)((p->command[1] << 8) | p->command[2]);
    } else if (command == 0x50 && p->command_length == 2) {  // RR
        uint16_t value = p->registers[(p->command[1] >> 2) & 31];
        uint8_t out[3] = {0, (uint8_t)(value >> 8), (uint8_t)(value & 0xFF)};
        answer(p, out, 3);
        return;
    } else if (command == 0x30 && (p->command[0] & 0x0F) == 0x0E) {  // SM of X, Y, Z
        start_measurement(p);
        status = STATUS_SM_MODE;
    } else if (command == 0x40 && (p->command[0] & 0x0F) == 0x0E) {  // RM of X, Y, Z
        read_measurement(p);
        return;
    } else {
        status = STATUS_ERROR;  // not a command this emulation knows (or an axis set it does not)
    }
    answer(p, &status, 1);
}

static void on_twi(avr_irq_t* irq, uint32_t value, void* param) {
    (void)irq;
    mlx90393_part* p = (mlx90393_part*)param;
    avr_twi_msg_irq_t msg;
    msg.u.v = value;
    if (msg.u.twi.msg & TWI_COND_STOP) {
        if (p->selected && !p->command_done) execute(p);
        p->selected = 0;
    }
    if (msg.u.twi.msg & TWI_COND_START) {
        p->selected = (msg.u.twi.addr >> 1) == p->address;
        if (!p->selected) return;
        p->reading = msg.u.twi.addr & 1;
        if (p->reading) {
            if (!p->command_done) execute(p);  // repeated start after the command
        } else {
            p->command_length = 0;
            p->command_done = 0;
        }
        avr_raise_irq(p->irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_ACK, msg.u.twi.addr, 1));
        return;
    }
    if (!p->selected) return;
    if (msg.u.twi.msg & TWI_COND_WRITE) {
        if (p->command_length < MLX_PART_COMMAND_MAX) p->command[p->command_length++] = msg.u.twi.data;
        avr_raise_irq(p->irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_ACK, msg.u.twi.addr, 1));
    } else if (msg.u.twi.msg & TWI_COND_READ) {
        uint8_t data = p->response_index < p->response_length ? p->response[p->response_index] : 0xFF;
        ++p->response_index;
        avr_raise_irq(p->irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_READ, msg.u.twi.addr, data));
    }
}

static const char* IRQ_NAMES[2] = {"8>mlx90393.out", "32<mlx90393.in"};

void mlx90393_part_init(avr_t* avr, mlx90393_part* part, uint8_t address) {
    memset(part, 0, sizeof *part);
    part->avr = avr;
    part->address = address;
    reset_registers(part);
    part->irq = avr_alloc_irq(&avr->irq_pool, 0, 2, IRQ_NAMES);
    avr_irq_register_notify(part->irq + TWI_IRQ_OUTPUT, on_twi, part);
    avr_connect_irq(part->irq + TWI_IRQ_INPUT, avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT));
    avr_connect_irq(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT), part->irq + TWI_IRQ_OUTPUT);
}
