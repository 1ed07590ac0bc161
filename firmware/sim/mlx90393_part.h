// An emulated MLX90393 (I2C, HALLCONF 0xC) on simavr's TWI: the command set the sketch uses (EX,
// RT, WR, RR, SM, RM), the status byte, conversion time and measurement registers. The counts of
// each conversion come from the host when it starts (harness "F" request), so the world's physics
// stays on the host side.
#ifndef WC_SIM_MLX90393_PART_H
#define WC_SIM_MLX90393_PART_H

#include <stdint.h>

#include <sim_avr.h>
#include <sim_irq.h>

enum { MLX_PART_RESPONSE_MAX = 9, MLX_PART_COMMAND_MAX = 4 };

typedef struct mlx90393_part {
    avr_t* avr;
    avr_irq_t* irq;       // [TWI_IRQ_INPUT] to the TWI, [TWI_IRQ_OUTPUT] from it
    uint8_t address;      // 7-bit
    int selected;         // addressed since the last START
    int reading;          // addressed for reading
    uint8_t command[MLX_PART_COMMAND_MAX];
    uint8_t command_length;
    int command_done;     // the command has been executed (its answer is in response)
    uint8_t response[MLX_PART_RESPONSE_MAX];
    uint8_t response_length;
    uint8_t response_index;
    uint16_t registers[32];
    int converting;       // a single measurement was started and not yet read
    avr_cycle_count_t ready_cycle;
    int16_t counts[3];
    uint32_t conversions;   // statistics for the host's report
    uint32_t early_reads;   // RM before the conversion time had passed
} mlx90393_part;

void mlx90393_part_init(avr_t* avr, mlx90393_part* part, uint8_t address);

#endif
