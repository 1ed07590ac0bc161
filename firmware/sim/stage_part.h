// The stage board's parts around the emulated ATmega328P: step/dir drivers counted into motor
// steps, the limit switches (pressed reads low), and for whiskercal's board a TCA9548A (0x70) with
// an AS5600 (0x36) on channels 0 and 1. Two pin maps (stage_pins): "whiskercal" is the wiring of
// stage_stepper/hal_avr.cpp (X step PD2, Y step PD3, X dir PD5, Y dir PD6, enable PB0 active low,
// limits PB1/PB2); "grbl" is stock grbl 1.1's ATmega328P map (grbl/cpu_map.h: step X/Y/Z PD2/3/4,
// dir PD5/6/7, enable PB0, limits X PB1, Y PB2, Z PB4 with the variable spindle), whose Z axis
// has no switch (it never closes) and whose board has no encoders. Dir high is the negative direction.
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

enum { STAGE_AXES = 3 };

typedef struct stage_pins {
    const char* name;
    uint8_t step_pin[STAGE_AXES];  // port D; 0xFF: no such axis
    uint8_t dir_mask[STAGE_AXES];  // port D
    uint8_t enable_mask;           // port B, high: drivers disabled
    uint8_t limit_pin[STAGE_AXES]; // port B; 0xFF: no switch
    int encoders;                  // the TCA9548A and the AS5600s are on the TWI
    int ocr1a_at_reset;            // see stage_part.c: simavr and a CTC timer whose TOP is 0
} stage_pins;

// The pin map called ``name`` ("whiskercal" or "grbl"); NULL for an unknown name.
const stage_pins* stage_pins_named(const char* name);

typedef struct stage_part {
    avr_t* avr;
    const stage_pins* pins;
    avr_irq_t* twi_irq;         // [TWI_IRQ_INPUT] to the TWI, [TWI_IRQ_OUTPUT] from it
    int32_t steps[STAGE_AXES];  // motor steps since power-up (Z: grbl's, no motor)
    int32_t switch_steps[2];    // a switch is pressed at or below this count
    uint32_t step_events;
    uint8_t mux_channels;       // TCA9548A control register
    int selected;               // 0, 0x70 or 0x36: the device addressed since the last START
    int encoder_answers;        // the addressed encoder answered the host's "A" request
    uint8_t as5600_pointer;
    uint8_t as5600_registers[16];
    FILE* step_log;             // WC_SIM_STEP_LOG: every step edge, for the timing figures
} stage_part;

void stage_part_init(avr_t* avr, stage_part* part, const stage_pins* pins);

// "L <x> <y>": where the switches close, in motor steps since power-up.
void stage_part_set_switches(stage_part* part, int32_t x, int32_t y);

// The "P <cycle> <x steps> <y steps> <z steps>" line for the host.
void stage_part_report(const stage_part* part);

#endif
