// stage_stepper's top level, shared by the sketch and the host simulator.
#ifndef STAGE_STAGE_H
#define STAGE_STAGE_H

#include <stdint.h>

// Power-up: settings from EEPROM, modules, banner.
void stage_init();

// One pass of the main loop: realtime requests, lines, supervision, segment preparation.
void stage_loop();

#endif
