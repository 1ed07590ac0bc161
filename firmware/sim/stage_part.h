// The stage board's parts around the emulated ATmega328P (wiring of stage_stepper/hal_avr.cpp):
// two step/dir drivers counted into motor steps (X step PD2, Y step PD3, X dir PD5, Y dir PD6,
// enable PB0 active low; dir high is the negative direction), the limit switches on PB1/PB2
// (pressed reads low), and a TCA9548A (0x70) with an AS5600 (0x36) on channels 0 and 1.
// The host keeps the mechanics: it gets the step counters at the end of every run ("P" line),
// sets where the switches close in steps ("L" request), and answers each encoder transaction
// ("A <cycle> <axis> <x steps> <y steps>" -> "<status> <raw angle>", or "nack" for an encoder
// that does not answer).
#ifndef WC_SIM_STAGE_PART_H
#define WC_SIM_STAGE_PART_H

#include <stdint.h>
#include <stdio.h>

#include <sim_avr.h>
#include <sim_irq.h>

typedef struct stage_part {
    avr_t* avr;
    avr_irq_t* twi_irq;         // [TWI_IRQ_INPUT] to the TWI, [TWI_IRQ_OUTPUT] from it
    int32_t steps[2];           // motor steps since power-up
    int32_t switch_steps[2];    // a switch is pressed at or below this count
    uint32_t step_events;
    uint8_t mux_channels;       // TCA9548A control register
    int selected;               // 0, 0x70 or 0x36: the device addressed since the last START
    int encoder_answers;        // the addressed encoder answered the host's "A" request
    uint8_t as5600_pointer;
    uint8_t as5600_registers[16];
    FILE* step_log;             // WC_SIM_STEP_LOG: every step edge, for the timing figures
} stage_part;

void stage_part_init(avr_t* avr, stage_part* part);

// "L <x> <y>": where the switches close, in motor steps since power-up.
void stage_part_set_switches(stage_part* part, int32_t x, int32_t y);

// The "P <cycle> <x steps> <y steps>" line for the host.
void stage_part_report(const stage_part* part);

#endif
